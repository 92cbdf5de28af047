// What the parts of a peer (peer.cpp and the parts it is made of) share: who it is, its options,
// the time now, its counters, the one way it sends, and the other peers as it has heard them.
// Internal to the core.
#pragma once

#include "kiji/peer.h"

#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>

namespace kiji::detail {

struct PeerCore {
  std::uint32_t id = 0;
  PeerOptions opt;
  double now = 0;  // seconds, on the caller's clock
  PeerStats stats;
  // One message of a type (PeerMessage) to every peer.
  std::function<void(std::uint8_t type, const std::string& body)> send;
};

// Another peer, as last heard.
struct Member {
  std::string name;
  bool sequencer = false, joined = false;
  std::uint64_t step = 0, received = 0, horizon = 0;
  double heard = -1;  // when (-1: never; only named by an order or a report)
  PeerPresence presence;
};

struct Members {
  std::map<std::uint32_t, Member> all;
  std::set<std::uint32_t> left;  // said goodbye, went silent, or ordered out

  // Neither gone nor silent for longer than `silence` seconds.
  bool live(std::uint32_t id, const Member& m, double now, double silence) const {
    return !left.count(id) && m.heard >= 0 && now - m.heard <= silence;
  }
};

}  // namespace kiji::detail
