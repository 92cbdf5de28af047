// Peers: several people design one garment at once (the paper's section 6), each machine holding
// the whole session and simulating it. Peers replicate operations, not meshes: every change a user
// makes is proposed to the session's sequencer, which gives it its place in one order and the
// simulation step it applies at; every peer applies the same operations in the same order at the
// same step, and so computes the same cloth. State hashes every few steps prove it; a peer that
// disagrees is healed from a snapshot, and the disagreement is reported.
//
//  - The sequencer is a role, held under an epoch (a fencing token): when it goes silent, the live
//    peer with the lowest id takes it over with the next epoch, after gathering every ordered
//    operation any live peer received, so that none acknowledged is lost.
//  - Exclusive control: each tool event leases the cloth around its hit point to its user; an event
//    on cloth another user holds is refused with a reason (a stroke so refused is cancelled: nothing
//    is half-applied). Leases are decided as ordered operations are applied, so every peer grants
//    the same, and they expire in simulation time.
//  - Loss: messages are small (under about 1,200 bytes), numbered per sender; gaps are found from
//    heartbeats and repaired by negative acknowledgement; large payloads (garments, snapshots) go in
//    hashed chunks. A late joiner gets a snapshot at an ordered checkpoint and the operations after.
//  - Every message is authenticated with the session's key, with a replay window, before it is read.
//
// The engine (Peer) is driven from outside: receive() for each message that arrives, tick() with
// the time, and a PeerTransport to send with. PeerRunner (peer_runner.h) runs it on LCM in real
// time; the tests run many peers in one process on a simulated network.
#pragma once

#include "kiji/session.h"

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace kiji {

struct PeerOptions {
  std::string name = "peer";
  std::string key;             // the session's shared secret (16 bytes or more)
  std::uint32_t id = 0;        // 0: a random one
  bool host = false;           // start the shared session (its first sequencer) with this session's state
  // Steps the sequencer looks ahead: an operation applies at least this many steps after the
  // sequencer's clock when it was ordered. More hides more network jitter; each is a frame of latency.
  // With a clock, steps slower than a frame look ahead as far in time (fewer steps, at least one).
  int lookahead_steps = 2;
  int hash_interval = 30;        // steps between state hashes
  int max_lag_steps = 6;         // how far the sequencer's clock may run ahead of the slowest peer
  double heartbeat_seconds = 0.05;
  double silence_seconds = 0.6;  // not heard from for this long: gone (a sequencer: replaced)
  double lease_radius = 0.06;    // metres of cloth around a tool event's hit that it leases
  double lease_hold_seconds = 1.5;  // how long a lease outlives its user's last event
  bool real_time = true;         // step at the session's frame rate; false: as fast as allowed
  std::uint64_t stop_step = 0;   // the shared clock stops here (0: never)
  // Seconds on the caller's clock, for real time: a tick catching up then stops stepping once it
  // has stepped for a frame's time, so that messages are heard and state sent between slow steps
  // (a large garment). Unset: a tick steps as far as it may (deterministic tests drive the clock).
  std::function<double()> clock;
  void validate() const;
};

// Sends one message to every peer (a multicast); whatever it returns, the protocol repairs losses.
class PeerTransport {
 public:
  virtual ~PeerTransport() = default;
  virtual void send(const std::string& bytes) = 0;
  // While the peer's thread is busy longer than a heartbeat (a step, a state loaded or shipped),
  // messages sealed before (heartbeats, each with its own number) for the transport to send one
  // every `every` seconds, so that the others still hear this peer; called again with none when
  // the work is done. A transport that sends only from the peer's own thread ignores them.
  virtual void keep_alive(std::vector<std::string> sealed, double every) {
    (void)sealed;
    (void)every;
  }
};

struct PeerPresence {
  Vec3 pointer{0, 0, 0};
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  std::uint32_t buttons = 0;
  Vec3 eye{0, 0, 0}, target{0, 0, 0};  // the user's viewpoint
  std::string tool;
};

struct PeerInfo {
  std::uint32_t id = 0;
  std::string name;
  bool self = false;
  bool sequencer = false;
  bool joined = false;
  std::uint64_t step = 0;       // the peer's clock as last heard
  double last_heard = 0;        // seconds, on the caller's clock
  PeerPresence presence;
  // Whether its state hash equals this peer's at the latest step both hashed (unset: none yet).
  std::optional<bool> hash_agrees;
};

struct LeaseInfo {
  UserId holder = 0;
  std::size_t garment = 0;
  std::vector<std::uint32_t> vertices;  // the vertex indices of cloth held (for drawing it shaded)
  std::uint64_t expires = 0;    // the step it ends at
};

struct PeerRefusal {
  std::uint64_t step = 0;
  std::string reason;
};

struct PeerDivergence {
  std::uint64_t step = 0;
  std::uint64_t own = 0, reference = 0;  // this peer's state hash and the sequencer's
  std::uint32_t reference_peer = 0;
};

struct PeerStats {
  std::uint64_t sent = 0, received = 0, bytes_sent = 0, bytes_received = 0;
  std::map<std::string, std::uint64_t> dropped;  // by reason: forged, replayed, malformed, ...
  std::uint64_t nacks_sent = 0, resent = 0, orders_applied = 0, stalls = 0;
  // Of those: the snapshot chunks this peer asked for again, and those it sent again when asked.
  std::uint64_t chunks_asked = 0, chunks_resent = 0;
  std::uint64_t checkpoints = 0, heals = 0, elections = 0;
};

class Peer {
 public:
  // Shares `session`: from now on the changes its users make are proposed to the peers (the session
  // gets a gate, and only this peer steps its clock). A host's session is the shared session's
  // start; a joiner's is replaced by the shared state when it arrives.
  Peer(Session& session, PeerTransport& transport, PeerOptions options);
  ~Peer();  // the session is the users' own again
  Peer(const Peer&) = delete;
  Peer& operator=(const Peer&) = delete;

  std::uint32_t id() const;
  const PeerOptions& options() const;

  // A message from the network, and the time (seconds on any steady clock, the same as tick's).
  void receive(std::string_view bytes, double now);
  // Timers, sending, applying what is ordered and stepping the shared clock.
  void tick(double now);
  // Says goodbye (the others free this peer's leases at once rather than after its silence).
  void leave(double now);

  // Whether this peer has the shared state (a host at once, a joiner once its snapshot arrived).
  bool joined() const;
  bool is_sequencer() const;
  std::uint32_t sequencer() const;
  std::uint64_t epoch() const;
  // Proposals of this peer's users not yet applied.
  std::size_t pending() const;
  // Operations applied so far in the shared order.
  std::uint64_t applied() const;
  // The step the shared clock stops at (the host's PeerOptions::stop_step; 0: never).
  std::uint64_t stop_step() const;

  std::vector<PeerInfo> peers() const;
  std::vector<LeaseInfo> leases() const;
  // A hash of the session's state now (garments' positions, velocities and topology, the clock).
  std::uint64_t state_hash() const;
  // True when every peer known has reported, for the latest step all reported, this peer's hash.
  bool converged() const;
  void set_presence(const PeerPresence& presence);
  // Leases the cloth within `radius` of `center` on a garment for `seconds` of simulated time.
  void lease(std::size_t garment, const Vec3& center, double radius, double seconds);
  // Lets go of every lease this peer's user holds.
  void release();
  // Proposes an operation as this peer's user's, as the session's gate does with the user's own
  // changes (op.step is the step it was made at): a recorded session played to this peer goes so.
  void propose(const Operation& op);

  const PeerStats& stats() const;
  const std::vector<PeerRefusal>& refusals() const;
  const std::vector<PeerDivergence>& divergences() const;

 private:
  struct Impl;
  void on_local(const Operation& op);
  std::unique_ptr<Impl> impl_;
};

// The hash of a session's state that peers compare.
std::uint64_t session_state_hash(const Session& session);

}  // namespace kiji
