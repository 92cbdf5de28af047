// Peer messages (kiji::Peer::receive): any bytes from the network are dropped and counted, or read,
// never a crash. The first byte picks a message type and the rest is its body, sealed with the
// session's key as a member would seal it, so that the fuzzer reaches every body decoder behind the
// authentication; the raw bytes are also given as they came (the checks before authentication).
#include "net/peer_wire.h"
#include "kiji/error.h"
#include "kiji/garment.h"
#include "kiji/pattern.h"
#include "kiji/peer.h"
#include "kiji/session.h"

#include <memory>

namespace {

constexpr const char* kKey = "the fuzzed session's key";

struct Discard : kiji::PeerTransport {
  void send(const std::string&) override {}
};

struct World {
  kiji::Session session;
  Discard transport;
  std::unique_ptr<kiji::Peer> peer;
  kiji::detail::PeerWire other{kKey, 7};  // another member of the session
  double now = 0;
  World() {
    session.add_garment(kiji::make_rectangle(0.2, 0.2, 4, 4));
    kiji::PeerOptions o;
    o.key = kKey;
    o.host = true;
    o.id = 1;
    o.real_time = false;
    peer = std::make_unique<kiji::Peer>(session, transport, o);
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static World w;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  w.now += 0.01;
  w.peer->receive(bytes, w.now);
  if (size > 0) {
    const std::string sealed = w.other.seal(data[0], 1, bytes.substr(1, kiji::detail::kMaxPeerBody));
    w.peer->receive(sealed, w.now);
  }
  w.peer->tick(w.now);
  return 0;
}
