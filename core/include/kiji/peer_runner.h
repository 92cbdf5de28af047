// Runs a Peer in real time on LCM: a thread that receives the peers' messages, ticks the engine and
// steps the shared session, so that an app, a script or the command line only makes its changes to
// the session as usual and reads what it likes. Everything happens under the session's mutex: the
// thread holds it for each batch of messages and each tick, a user holds it for each change.
#pragma once

#include "kiji/peer.h"

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>

namespace kiji {

namespace detail {
class LcmBus;
}

struct PeerNetwork {
  // The LCM provider. ttl=0 keeps the packets on this host; ttl=1 reaches the local network.
  std::string url = "udpm://239.255.76.67:7667?ttl=0";
  std::string channel = "KIJI_PEER";  // sessions on one network differ by key, and may by channel
  // The share (0 to 0.9) of arriving messages dropped at random before the peer reads them: for
  // trying a session, or measuring it, as if on a lossy network.
  double loss = 0;
  // A channel of recorded operations (kiji_lcm::op_record_t, as a session file holds them on
  // KIJI_OPS) that this peer proposes as its user's, in the order they come: `lcm-logplayer FILE`
  // plays a recorded design session to a running peer. "" listens to none. The recording's own
  // time passing and whole states are left out: the shared clock is the peers'. Messages on it are
  // not authenticated: listen only on a network you trust (ttl=0 keeps it on this host).
  std::string play_channel;
};

class PeerRunner {
 public:
  // Opens the network (an InputError says why it could not) and starts the thread.
  PeerRunner(Session& session, PeerOptions options, PeerNetwork network = {});
  ~PeerRunner();  // leaves (the others free this peer's leases at once) and stops the thread
  PeerRunner(const PeerRunner&) = delete;
  PeerRunner& operator=(const PeerRunner&) = delete;

  // Runs f(peer) under the session's lock, for reading the peer's state or calling its methods.
  template <class F>
  auto with_peer(F&& f) -> decltype(f(std::declval<Peer&>())) {
    std::lock_guard<std::recursive_mutex> lock(session_.mutex());
    return f(static_cast<Peer&>(*peer_));
  }
  // Leaves and stops; the session is the users' own again (safe to call twice).
  void stop();
  bool running() const { return running_.load(); }
  // Whether the peer has the shared session, without waiting for the session's lock (which a
  // peer catching up on a large garment holds for a step at a time).
  bool joined() const { return joined_.load(); }
  // Why the thread stopped by itself (empty while it runs or if it was stopped).
  std::string error() const;
  // Recorded operations taken from the play channel and proposed, and those dropped (not a record,
  // or time passing and whole states); the last reason one was dropped.
  std::uint64_t played() const { return played_.load(); }
  std::uint64_t play_dropped() const { return play_dropped_.load(); }
  std::string play_error() const;

 private:
  class Transport;
  void run();
  Session& session_;
  std::unique_ptr<detail::LcmBus> bus_;
  std::unique_ptr<Transport> transport_;
  std::unique_ptr<Peer> peer_;
  double loss_ = 0;
  std::atomic<bool> stop_{false}, running_{false}, joined_{false};
  std::atomic<std::uint64_t> played_{0}, play_dropped_{0};
  mutable std::mutex error_mutex_;
  std::string error_, play_error_;
  void play(const std::string& record);
  std::thread thread_;
};

}  // namespace kiji
