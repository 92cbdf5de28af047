#include "net/peer_wire.h"

#include "kiji/error.h"

#include <kiji_lcm/peer_msg_t.hpp>
#include <sodium.h>

#include <chrono>
#include <cstring>

namespace kiji::detail {

namespace {
// The encoded message: fingerprint (8), protocol (2), session (8), sender (4), seq (8), type (1),
// epoch (8), size (4), body, mac (32).
constexpr std::size_t kHeader = 8 + 2 + 8 + 4 + 8 + 1 + 8 + 4;
constexpr std::size_t kMac = 32;

std::uint64_t be(const unsigned char* p, int n) {
  std::uint64_t v = 0;
  for (int i = 0; i < n; ++i) v = (v << 8) | p[i];
  return v;
}
}  // namespace

const char* wire_verdict_name(WireVerdict v) {
  switch (v) {
    case WireVerdict::Ok: return "ok";
    case WireVerdict::Malformed: return "malformed";
    case WireVerdict::Oversized: return "oversized";
    case WireVerdict::BadMac: return "forged";
    case WireVerdict::OtherSession: return "other session";
    case WireVerdict::Replayed: return "replayed";
    case WireVerdict::OwnEcho: return "own echo";
  }
  return "?";
}

PeerWire::PeerWire(std::string_view key, std::uint32_t self) : self_(self) {
  if (sodium_init() < 0) throw Error("libsodium could not start");
  if (key.size() < 16) throw InputError("a session key must be at least 16 bytes: make one with 32 random bytes");
  // Two keys from one secret: the MAC key, and a name for the session that says nothing of the key.
  crypto_generichash(mac_key_.data(), mac_key_.size(), reinterpret_cast<const unsigned char*>(key.data()), key.size(),
                     reinterpret_cast<const unsigned char*>("kiji-mac-key-v1."), 16);
  unsigned char name[8];
  crypto_generichash(name, sizeof name, reinterpret_cast<const unsigned char*>(key.data()), key.size(),
                     reinterpret_cast<const unsigned char*>("kiji-session-v1."), 16);
  std::memcpy(&session_, name, 8);
  // Numbers that go on rising when a peer restarts with the same id.
  next_seq_ = static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
          .count());
}

std::string PeerWire::seal(std::uint8_t type, std::uint64_t epoch, std::string_view body) {
  if (body.size() > kMaxPeerBody) throw Error("a peer message body of " + std::to_string(body.size()) + " bytes");
  kiji_lcm::peer_msg_t m;
  m.protocol = kPeerProtocol;
  m.session = session_;
  m.sender = static_cast<std::int32_t>(self_);
  m.seq = static_cast<std::int64_t>(next_seq_++);
  m.type = static_cast<std::int8_t>(type);
  m.epoch = static_cast<std::int64_t>(epoch);
  m.size = static_cast<std::int32_t>(body.size());
  m.body.assign(body.begin(), body.end());
  std::string out(static_cast<std::size_t>(m.getEncodedSize()), '\0');
  m.encode(out.data(), 0, static_cast<int>(out.size()));
  auto* p = reinterpret_cast<unsigned char*>(out.data());
  crypto_auth(p + out.size() - kMac, p, out.size() - kMac, mac_key_.data());
  return out;
}

WireVerdict PeerWire::open(std::string_view bytes, PeerEnvelope& out) {
  if (bytes.size() < kHeader + kMac) return WireVerdict::Malformed;
  if (bytes.size() > kHeader + kMaxPeerBody + kMac) return WireVerdict::Oversized;
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  if (crypto_auth_verify(p + bytes.size() - kMac, p, bytes.size() - kMac, mac_key_.data()) != 0)
    return WireVerdict::BadMac;
  // Authentic: the fields at their fixed places, the size against the length, before decoding.
  const std::uint64_t size = be(p + kHeader - 4, 4);
  if (size > kMaxPeerBody || kHeader + size + kMac != bytes.size()) return WireVerdict::Malformed;
  kiji_lcm::peer_msg_t m;
  if (m.decode(bytes.data(), 0, static_cast<int>(bytes.size())) < 0) return WireVerdict::Malformed;
  if (m.protocol != kPeerProtocol) return WireVerdict::Malformed;
  if (m.session != session_) return WireVerdict::OtherSession;
  const auto sender = static_cast<std::uint32_t>(m.sender);
  if (sender == self_) return WireVerdict::OwnEcho;
  const auto seq = static_cast<std::uint64_t>(m.seq);
  Window& w = windows_[sender];
  if (seq > w.highest || w.highest == 0) {
    // The numbers skipped over are not seen yet (their bits last held numbers a window older).
    if (w.highest == 0 || seq - w.highest >= kReplayWindow)
      w.seen.fill(0);
    else
      for (std::uint64_t s = w.highest + 1; s < seq; ++s) w.mark(s, false);
    w.mark(seq, true);
    w.highest = seq;
  } else {
    if (w.highest - seq >= kReplayWindow || w.has(seq)) return WireVerdict::Replayed;
    w.mark(seq, true);
  }
  out.session = m.session;
  out.sender = sender;
  out.seq = seq;
  out.type = static_cast<std::uint8_t>(m.type);
  out.epoch = static_cast<std::uint64_t>(m.epoch);
  out.body.assign(m.body.begin(), m.body.end());
  return WireVerdict::Ok;
}

}  // namespace kiji::detail
