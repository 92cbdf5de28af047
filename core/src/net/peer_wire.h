// The peer protocol's envelope: kiji_lcm::peer_msg_t, authenticated with the session's key, with a
// replay window for each sender, and every length checked before LCM's decoder sees it (lcm-gen's
// decoders trust the array lengths they read). Internal to the core.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>

namespace kiji::detail {

constexpr std::int16_t kPeerProtocol = 1;
// At most this many body bytes a message, so that every message stays under about 1,200 bytes (a
// datagram that survives a lossy network whole).
constexpr std::size_t kMaxPeerBody = 1100;

struct PeerEnvelope {
  std::int64_t session = 0;
  std::uint32_t sender = 0;
  std::uint64_t seq = 0;
  std::uint8_t type = 0;
  std::uint64_t epoch = 0;
  std::string body;
};

// Why a message was dropped (or Ok).
enum class WireVerdict { Ok, Malformed, Oversized, BadMac, OtherSession, Replayed, OwnEcho };
const char* wire_verdict_name(WireVerdict v);

class PeerWire {
 public:
  // `key`: the session's shared secret, any length (at least 16 bytes); hashed to the MAC key and
  // the session's name.
  PeerWire(std::string_view key, std::uint32_t self);
  std::int64_t session() const { return session_; }

  // The message, authenticated. Its seq is the next of this sender's.
  std::string seal(std::uint8_t type, std::uint64_t epoch, std::string_view body);
  // Checks and opens a message: the MAC before anything, then the lengths, then the sender's replay
  // window; only then is it decoded.
  WireVerdict open(std::string_view bytes, PeerEnvelope& out);

 private:
  std::array<unsigned char, 32> mac_key_{};
  std::int64_t session_ = 0;
  std::uint32_t self_;
  std::uint64_t next_seq_;
  // The last kReplayWindow sequence numbers of a sender: wide enough for a burst of repairs
  // (hundreds of chunks) reordered on the way, which a 64-message window took for replays.
  static constexpr std::uint64_t kReplayWindow = 1024;
  struct Window {
    std::uint64_t highest = 0;
    std::array<std::uint64_t, kReplayWindow / 64> seen{};  // bit s % kReplayWindow: s was seen
    bool has(std::uint64_t s) const { return (seen[(s / 64) % seen.size()] >> (s % 64)) & 1; }
    void mark(std::uint64_t s, bool on) {
      std::uint64_t& word = seen[(s / 64) % seen.size()];
      word = on ? word | (std::uint64_t(1) << (s % 64)) : word & ~(std::uint64_t(1) << (s % 64));
    }
  };
  std::map<std::uint32_t, Window> windows_;
};

}  // namespace kiji::detail
