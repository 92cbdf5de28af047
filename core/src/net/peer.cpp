#include "kiji/peer.h"

#include "kiji/error.h"
#include "net/peer_messages.h"
#include "net/peer_wire.h"

#include <sodium.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>

namespace kiji {

using namespace detail;

namespace {
// How long a join may wait for the strokes in progress to end (seconds).
constexpr double kJoinWaitForStrokes = 2.0;

constexpr std::size_t kInlinePayload = 900;    // larger ordered payloads go as blobs
constexpr std::size_t kKeepApplied = 8192;     // applied orders kept to repair others' gaps
constexpr std::size_t kMaxNackRange = 64;
constexpr std::size_t kChunkBurst = 4096;      // blob chunks handed to the transport a tick at most
constexpr int kMaxStepsPerTick = 8;            // catching up, a tick steps at most this many
constexpr int kMaxNacksARound = 16;             // requests for one blob's missing chunks at once
// After shipping a state, a sequencer whose steps are slow (two frames or more) waits this long
// before its next step, to hear and answer the joiner's requests for lost chunks (a step later
// would be tenths of a second on a large garment).
constexpr double kRepairWindow = 0.15;

ToolEvent cancel_event(double time) {
  ToolEvent e;
  e.phase = Phase::Cancel;
  e.time = time;
  return e;
}

}  // namespace

void PeerOptions::validate() const {
  if (key.size() < 16) throw InputError("a peer needs the session's key, 16 bytes or more (a key file of 32 random bytes)");
  if (name.empty() || name.size() > 64) throw InputError("a peer's name must be 1 to 64 characters");
  if (lookahead_steps < 1 || lookahead_steps > 60) throw InputError("lookahead_steps must be 1 to 60");
  if (hash_interval < 1 || hash_interval > 10000) throw InputError("hash_interval must be 1 to 10000 steps");
  if (max_lag_steps < 1 || max_lag_steps > 600) throw InputError("max_lag_steps must be 1 to 600");
  if (!(heartbeat_seconds > 0 && heartbeat_seconds < silence_seconds))
    throw InputError("heartbeat_seconds must be positive and shorter than silence_seconds");
  if (!(silence_seconds > 0 && silence_seconds <= 60)) throw InputError("silence_seconds must be in (0, 60]");
  if (!(lease_radius > 0 && lease_radius <= 10)) throw InputError("lease_radius must be in (0, 10] metres");
  if (!(lease_hold_seconds >= 0 && lease_hold_seconds <= 3600)) throw InputError("lease_hold_seconds must be 0 to 3600");
}

std::uint64_t session_state_hash(const Session& s) {
  std::uint64_t h = hash_bytes(std::string_view());
  auto mix = [&](const void* p, std::size_t n) { h = hash_bytes(std::string_view(static_cast<const char*>(p), n), h); };
  const std::uint64_t steps = s.steps();
  mix(&steps, sizeof steps);
  const std::uint64_t count = s.garment_count();
  mix(&count, sizeof count);
  for (std::size_t i = 0; i < s.garment_count(); ++i) {
    const Garment& g = s.garment(i);
    const std::uint64_t sizes[2] = {g.vertex_capacity(), g.mesh().number_of_faces()};
    mix(sizes, sizeof sizes);
    for (Vertex v : g.mesh().vertices()) {
      const Vec3 p = g.position(v), vel = g.velocity(v);
      mix(p.data(), 3 * sizeof(double));
      mix(vel.data(), 3 * sizeof(double));
    }
  }
  return h;
}

struct Peer::Impl {
  Session& session;
  PeerTransport& transport;
  PeerOptions opt;
  std::uint32_t id = 0;
  std::unique_ptr<PeerWire> wire;
  PeerStats stats;
  std::vector<PeerRefusal> refusals;
  std::vector<PeerDivergence> divergences;
  double now = 0;
  double started = -1;

  std::uint32_t sequencer = 0;
  std::uint64_t epoch = 0;
  bool joined = false;

  // --- the order, as every peer keeps it ---
  struct Ordered {
    std::uint64_t exec_step = 0;
    std::uint32_t origin = 0;
    std::uint64_t pseq = 0;
    std::uint64_t epoch = 0;
    Payload payload;
  };
  std::map<std::uint64_t, Ordered> ordered;  // received, not yet applied
  std::map<std::uint64_t, Ordered> applied_log;  // applied, kept to repair others
  std::uint64_t applied = 0;     // the next number to apply
  std::uint64_t known_next = 0;  // orders below this number exist
  std::uint64_t horizon = 0;     // no order to come applies at or before this step
  std::uint64_t stop = 0;
  double last_nack = -1;

  // --- this peer's proposals ---
  struct Proposal {
    std::uint64_t desired = 0;
    Payload payload;
    bool ordered = false;
    double sent = -1;
  };
  std::map<std::uint64_t, Proposal> pending;
  std::uint64_t next_pseq = 1;

  // --- the sequencer's ---
  std::uint64_t next_gseq = 0;
  std::uint64_t announced = 0;  // the largest horizon announced
  double step_seconds = 0;      // a step's wall time from step to step (a moving mean; 0: unknown)
  double shipped_at = -1;       // when a state was last shipped to a joining peer (on opt.clock)
  std::uint64_t last_exec = 0;
  std::map<std::uint32_t, std::uint64_t> ordered_hw;
  std::map<std::uint32_t, std::map<std::uint64_t, Propose>> waiting;
  std::set<std::uint32_t> checkpoint_for;  // peers a checkpoint is ordered for and not yet applied
  std::set<std::uint32_t> joins;            // peers asking to join, gathered for one checkpoint
  double first_join = -1;
  struct Shipped {
    StateOffer offer;
    std::uint64_t step = 0;  // the checkpoint's step: the shared clock waits there for the peer
    double sent = -1;
  };
  std::map<std::uint32_t, Shipped> offers;  // states shipped, until their peers have joined
  double last_beat = -1;
  // taking the role over
  bool claiming = false;
  std::uint64_t claim_epoch = 0;
  double claim_started = 0;

  // --- the other peers ---
  struct Known {
    std::string name;
    bool sequencer = false, joined = false;
    std::uint64_t step = 0, received = 0, horizon = 0;
    double heard = -1;
    PeerPresence presence;
    std::map<std::uint64_t, std::uint64_t> hashes;  // their latest reports
  };
  std::map<std::uint32_t, Known> peers;
  std::set<std::uint32_t> left;

  // --- blobs ---
  struct Blob {
    std::uint32_t size = 0, count = 0, got = 0;
    std::vector<std::string> chunks;
    std::vector<char> have;
    std::string data;
    bool complete = false, mine = false;
    double last_chunk = -1, asked = -1;
  };
  std::map<std::uint64_t, Blob> blobs;
  std::deque<std::pair<std::uint64_t, std::uint32_t>> outgoing;
  std::set<std::pair<std::uint64_t, std::uint32_t>> queued;  // what outgoing holds

  // --- joining ---
  bool have_offer = false;
  StateOffer offer;
  double join_asked = -1;

  // --- hashes ---
  std::map<std::uint64_t, std::uint64_t> own_hashes, reference;
  double heal_asked = -1;

  // --- leases: decided as ordered operations are applied, the same on every peer ---
  struct Lease {
    std::map<std::uint32_t, std::set<std::uint32_t>> vertices;  // by garment
    std::uint64_t expires = 0;
  };
  std::map<UserId, Lease> leases;
  std::set<UserId> refused;  // users whose stroke was refused: their events are dropped until a begin

  // --- pacing and presence ---
  double next_step_time = -1;
  double stalled_since = -1;
  std::uint64_t final_hash_step = std::numeric_limits<std::uint64_t>::max();
  double final_hash_sent = -1;
  PeerPresence presence;
  bool presence_set = false;
  double last_presence = -1;

  Impl(Session& s, PeerTransport& t, PeerOptions o) : session(s), transport(t), opt(std::move(o)) {}

  // ---------------------------------------------------------------- sending
  void send(std::uint8_t type, const std::string& body) {
    const std::string bytes = wire->seal(type, epoch, body);
    ++stats.sent;
    stats.bytes_sent += bytes.size();
    transport.send(bytes);
  }

  std::uint64_t received_through() const {
    std::uint64_t g = applied;
    while (ordered.count(g)) ++g;
    return g;
  }

  void heartbeat() {
    Heartbeat h;
    h.name = opt.name;
    h.sequencer = sequencer == id;
    h.joined = joined;
    h.step = session.steps();
    h.received = received_through();
    h.horizon = sequencer == id ? announced : horizon;
    h.next = sequencer == id ? next_gseq : known_next;
    h.stop = stop ? stop : opt.stop_step;
    if (sequencer == id)
      for (const auto& [origin, pseq] : ordered_hw) h.ordered.emplace_back(origin, pseq);
    send(kHeartbeat, encode(h));
    last_beat = now;
  }

  Payload make_payload(const std::string& bytes) {
    Payload p;
    if (bytes.size() <= kInlinePayload) {
      p.bytes = bytes;
      return p;
    }
    const std::string packed = deflate_bytes(bytes);
    p.blob = true;
    p.hash = hash_bytes(packed);
    p.size = static_cast<std::uint32_t>(packed.size());
    publish_blob(p.hash, packed);
    return p;
  }

  void publish_blob(std::uint64_t hash, const std::string& packed) {
    Blob& b = blobs[hash];
    if (!b.complete) {
      b.size = static_cast<std::uint32_t>(packed.size());
      b.count = static_cast<std::uint32_t>((packed.size() + kBlobChunkBytes - 1) / kBlobChunkBytes);
      b.data = packed;
      b.complete = true;
    }
    b.mine = true;
    for (std::uint32_t i = 0; i < b.count; ++i)
      if (queued.insert({hash, i}).second) outgoing.emplace_back(hash, i);
  }

  void send_chunks() {
    for (std::size_t n = 0; n < kChunkBurst && !outgoing.empty(); ++n) {
      const auto [hash, index] = outgoing.front();
      outgoing.pop_front();
      queued.erase({hash, index});
      auto it = blobs.find(hash);
      if (it == blobs.end() || !it->second.complete) continue;
      const Blob& b = it->second;
      BlobChunk c;
      c.hash = hash;
      c.size = b.size;
      c.index = index;
      c.count = b.count;
      c.data = b.data.substr(std::size_t(index) * kBlobChunkBytes, kBlobChunkBytes);
      send(kBlobChunk, encode(c));
    }
  }

  // ---------------------------------------------------------------- local proposals
  void propose_local(std::uint64_t desired, const std::string& peer_op) {
    const std::uint64_t pseq = next_pseq++;
    Proposal& p = pending[pseq];
    p.desired = desired;
    p.payload = make_payload(peer_op);
    send_proposal(pseq, p);
  }

  void send_proposal(std::uint64_t pseq, Proposal& p) {
    p.sent = now;
    Propose msg{pseq, p.desired, p.payload};
    if (sequencer == id && !claiming) {
      on_propose(id, msg);
      return;
    }
    send(kPropose, encode(msg));
  }

  // ---------------------------------------------------------------- the sequencer
  void on_propose(std::uint32_t origin, const Propose& p) {
    if (sequencer != id || claiming || left.count(origin)) return;
    const std::uint64_t hw = ordered_hw[origin];
    if (p.pseq <= hw) return;  // ordered already (its order went out; the origin will see it)
    waiting[origin][p.pseq] = p;
    auto& queue = waiting[origin];
    while (!queue.empty() && queue.begin()->first == ordered_hw[origin] + 1) {
      assign(origin, queue.begin()->second);
      queue.erase(queue.begin());
    }
  }

  void assign(std::uint32_t origin, const Propose& p) {
    Ordered o;
    o.exec_step = std::max({p.desired_step, announced + 1, last_exec});
    o.origin = origin;
    o.pseq = p.pseq;
    o.epoch = epoch;
    o.payload = p.payload;
    last_exec = o.exec_step;
    const std::uint64_t gseq = next_gseq++;
    ordered_hw[origin] = p.pseq;
    ordered[gseq] = o;
    known_next = next_gseq;
    send_order(gseq, o);
    if (origin == id) acknowledge(p.pseq);
  }

  void order_own(const PeerOp& op) {
    Propose p;
    p.pseq = ordered_hw[0] + 1;
    p.desired_step = 0;
    p.payload = make_payload(encode(op));
    assign(0, p);  // origin 0: the sequencer's own bookkeeping, not a user's
  }

  void send_order(std::uint64_t gseq, const Ordered& o) {
    send(kOrder, encode(Order{gseq, o.exec_step, o.origin, o.pseq, o.payload}));
  }

  const Ordered* find_order(std::uint64_t gseq) const {
    auto it = ordered.find(gseq);
    if (it != ordered.end()) return &it->second;
    auto a = applied_log.find(gseq);
    return a != applied_log.end() ? &a->second : nullptr;
  }

  void sequencer_duties() {
    // A checkpoint cancels the strokes in progress (a tool's state is not in a snapshot): joins wait
    // for them to end, up to kJoinWaitForStrokes, so that a user's pull is not undone by a join.
    if (!joins.empty() && now - first_join >= 0.02 &&
        (session.active_users().empty() || now - first_join >= kJoinWaitForStrokes))
      order_checkpoint();
    // Peers gone silent, or that said goodbye, leave the order (their strokes end, their leases go).
    for (auto& [pid, k] : peers) {
      if (left.count(pid) || !k.joined || k.heard < 0) continue;
      if (now - k.heard > opt.silence_seconds) {
        left.insert(pid);
        PeerOp op;
        op.kind = PeerOp::PeerLeft;
        op.peer = pid;
        order_own(op);
      }
    }
    // The states shipped go out again until their peers are in.
    for (auto it = offers.begin(); it != offers.end();) {
      auto k = peers.find(it->first);
      const bool gone = left.count(it->first) || (k != peers.end() && now - k->second.heard > opt.silence_seconds);
      if (gone || (k != peers.end() && k->second.joined && k->second.received > it->second.offer.gseq)) {
        it = offers.erase(it);
        continue;
      }
      if (now - it->second.sent > 0.05) {
        send(kState, encode(it->second.offer));
        it->second.sent = now;
      }
      ++it;
    }
  }

  // Steps of two frames or more (a large garment), as this peer's clock measures them.
  bool slow_steps() const { return opt.clock && step_seconds >= 2.0 / session.frame_rate(); }

  // The steps the sequencer looks ahead: lookahead_steps frames' worth of time, so that steps slower
  // than a frame (a large garment) do not multiply the latency of every operation. Without a clock
  // (deterministic runs) always lookahead_steps.
  int lookahead() const {
    if (!opt.clock || step_seconds <= 0) return opt.lookahead_steps;
    const double want = opt.lookahead_steps / session.frame_rate();
    return std::clamp(static_cast<int>(std::ceil(want / step_seconds - 1e-6)), 1, opt.lookahead_steps);
  }

  // The sequencer's clock as last heard (0 if unknown).
  std::uint64_t sequencer_clock() const {
    auto k = peers.find(sequencer);
    return k != peers.end() && k->second.sequencer ? k->second.step : 0;
  }

  // The slowest joined peer's clock: the sequencer runs at most max_lag_steps ahead of it.
  std::uint64_t slowest() const {
    std::uint64_t s = session.steps();
    for (const auto& [pid, k] : peers)
      if (k.joined && !left.count(pid) && now - k.heard <= opt.silence_seconds) s = std::min(s, k.step);
    // A peer being given the state starts at its checkpoint: the clock waits for it there.
    for (const auto& [pid, shipped] : offers) s = std::min(s, shipped.step);
    return s;
  }

  // ---------------------------------------------------------------- receiving
  void receive(std::string_view bytes) {
    ++stats.received;
    stats.bytes_received += bytes.size();
    PeerEnvelope env;
    const WireVerdict v = wire->open(bytes, env);
    if (v != WireVerdict::Ok) {
      ++stats.dropped[wire_verdict_name(v)];
      return;
    }
    try {
      dispatch(env);
    } catch (const InputError&) {  // authentic but malformed: a bug elsewhere, never a crash here
      ++stats.dropped["malformed body"];
    }
  }

  void dispatch(const PeerEnvelope& env) {
    Known& k = peers[env.sender];
    k.heard = now;
    if (env.epoch > epoch && (env.type == kHeartbeat || env.type == kOrder || env.type == kClaim)) {
      // A newer term: its sequencer (or its claimant) is the one to follow.
      if (sequencer == id && !claiming) step_down();
    }
    switch (env.type) {
      case kHeartbeat: on_heartbeat(env, decode_heartbeat(env.body)); break;
      case kPropose: on_propose(env.sender, decode_propose(env.body)); break;
      case kOrder:
        // From the sequencer, or a repair from any peer; never from an older term.
        if (env.epoch < epoch) {
          ++stats.dropped["stale epoch"];
          break;
        }
        on_order(decode_order(env.body), env.epoch);
        break;
      case kNackOrder: on_nack_order(env.sender, decode_nack_order(env.body)); break;
      case kBlobChunk: on_chunk(env.sender, decode_blob_chunk(env.body)); break;
      case kBlobNack: on_blob_nack(decode_blob_nack(env.body)); break;
      case kHash: on_hash(env.sender, decode_hash(env.body)); break;
      case kJoin:
        k.name = decode_name(env.body);
        k.joined = false;
        left.erase(env.sender);
        if (sequencer == id && !claiming && !checkpoint_for.count(env.sender) && !offers.count(env.sender)) {
          if (joins.empty()) first_join = now;
          joins.insert(env.sender);
        }
        break;
      case kPresence: k.presence = decode_presence(env.body); break;
      case kClaim: {
        const Claim c = decode_claim(env.body);
        if (c.epoch > epoch) heartbeat();  // tell the claimant what this peer has
        break;
      }
      case kLeave:
        if (sequencer == id && !left.count(env.sender)) {
          left.insert(env.sender);
          PeerOp op;
          op.kind = PeerOp::PeerLeft;
          op.peer = env.sender;
          order_own(op);
        }
        k.joined = false;
        break;
      case kState: {
        const StateOffer s = decode_state_offer(env.body);
        if (s.target == id && !joined && (!have_offer || s.gseq >= offer.gseq)) {
          offer = s;
          have_offer = true;
          Blob& b = blobs[s.hash];
          if (b.count == 0) {
            b.size = s.size;
            b.count = static_cast<std::uint32_t>((s.size + kBlobChunkBytes - 1) / kBlobChunkBytes);
            b.chunks.assign(b.count, {});
            b.have.assign(b.count, 0);
            b.last_chunk = now;
          }
        }
        break;
      }
      case kHeal:
        if (sequencer == id && !claiming && !checkpoint_for.count(env.sender) && !offers.count(env.sender)) {
          if (joins.empty()) first_join = now;
          joins.insert(env.sender);
        }
        break;
      default: ++stats.dropped["unknown type"]; break;
    }
  }

  // One checkpoint for every peer that asked within a few milliseconds of the first: each costs
  // every peer a rebuild of its state.
  void order_checkpoint() {
    PeerOp op;
    op.kind = PeerOp::Checkpoint;
    op.targets.assign(joins.begin(), joins.end());
    checkpoint_for.insert(joins.begin(), joins.end());
    joins.clear();
    order_own(op);
  }

  void step_down() {
    sequencer = 0;
    waiting.clear();
  }

  void on_heartbeat(const PeerEnvelope& env, const Heartbeat& h) {
    Known& k = peers[env.sender];
    k.name = h.name;
    k.joined = h.joined;
    k.step = h.step;
    k.received = h.received;
    k.horizon = h.horizon;
    k.sequencer = h.sequencer;
    if (!h.sequencer) return;
    if (env.epoch > epoch || (env.epoch == epoch && sequencer == 0) ||
        (env.epoch == epoch && sequencer == id && env.sender < id)) {
      adopt(env.sender, env.epoch, h.next);
    }
    if (env.sender != sequencer || env.epoch != epoch) return;
    horizon = std::max(horizon, h.horizon);
    known_next = std::max(known_next, h.next);
    stop = h.stop;
    for (const auto& [origin, pseq] : h.ordered)
      if (origin == id) acknowledge_through(pseq);
  }

  void adopt(std::uint32_t new_sequencer, std::uint64_t new_epoch, std::uint64_t next) {
    const bool new_term = new_epoch != epoch;
    sequencer = new_sequencer;
    epoch = new_epoch;
    claiming = false;
    if (!new_term) return;
    // Orders of an older term past the new sequencer's start were lost with it; proposals not yet
    // applied go to the new one (which drops what it has ordered already).
    for (auto it = ordered.lower_bound(next); it != ordered.end();)
      it = it->second.epoch < new_epoch ? ordered.erase(it) : std::next(it);
    known_next = next;
    for (auto& [pseq, p] : pending) p.ordered = false;
  }

  void acknowledge(std::uint64_t pseq) {
    auto it = pending.find(pseq);
    if (it != pending.end()) it->second.ordered = true;
  }
  void acknowledge_through(std::uint64_t pseq) {
    for (auto& [s, p] : pending)
      if (s <= pseq) p.ordered = true;
  }

  void on_order(const Order& o, std::uint64_t order_epoch) {
    if (o.gseq < applied || ordered.count(o.gseq)) return;
    Ordered e;
    e.exec_step = o.exec_step;
    e.origin = o.origin;
    e.pseq = o.pseq;
    e.epoch = order_epoch;
    e.payload = o.payload;
    ordered[o.gseq] = e;
    known_next = std::max(known_next, o.gseq + 1);
    if (o.origin == id) acknowledge(o.pseq);
    if (o.payload.blob) want_blob(o.payload.hash, o.payload.size);
  }

  void want_blob(std::uint64_t hash, std::uint32_t size) {
    Blob& b = blobs[hash];
    if (b.count != 0 || b.complete) return;
    b.size = size;
    b.count = static_cast<std::uint32_t>((size + kBlobChunkBytes - 1) / kBlobChunkBytes);
    b.chunks.assign(b.count, {});
    b.have.assign(b.count, 0);
    b.last_chunk = now;
  }

  void on_nack_order(std::uint32_t from, const NackOrder& n) {
    const bool mine_to_answer = n.target == id || (n.target == 0 && sequencer == id);
    if (!mine_to_answer) return;
    for (std::uint64_t g = n.from; g < n.to && g < n.from + kMaxNackRange; ++g)
      if (const Ordered* o = find_order(g)) {
        send_order(g, *o);
        ++stats.resent;
      }
  }

  void on_chunk(std::uint32_t from, const BlobChunk& c) {
    Blob& b = blobs[c.hash];
    if (b.complete) return;
    if (b.count == 0) {
      b.size = c.size;
      b.count = c.count;
      b.chunks.assign(b.count, {});
      b.have.assign(b.count, 0);
    }
    if (b.size != c.size || b.count != c.count || b.have[c.index]) return;
    b.chunks[c.index] = c.data;
    b.have[c.index] = 1;
    b.last_chunk = now;
    if (++b.got < b.count) return;
    std::string data;
    data.reserve(b.size);
    for (const auto& chunk : b.chunks) data += chunk;
    if (hash_bytes(data) != c.hash) {  // a chunk was not what its sender meant: start again
      ++stats.dropped["blob hash"];
      b = Blob{};
      return;
    }
    b.data = std::move(data);
    b.complete = true;
    b.chunks.clear();
    b.have.clear();
  }

  void on_blob_nack(const BlobNack& n) {
    auto it = blobs.find(n.hash);
    if (it == blobs.end() || !it->second.complete || (!it->second.mine && sequencer != id)) return;
    // A chunk still waiting its turn is not queued twice: a receiver asks again while a burst is
    // under way, and duplicates would push the rest of the blob back.
    for (std::uint32_t i : n.missing)
      if (i < it->second.count && queued.insert({n.hash, i}).second) {
        outgoing.emplace_front(n.hash, i);
        ++stats.resent;
        ++stats.chunks_resent;
      }
  }

  void on_hash(std::uint32_t from, const HashReport& h) {
    Known& k = peers[from];
    k.hashes[h.step] = h.hash;
    while (k.hashes.size() > 16) k.hashes.erase(k.hashes.begin());
    if (from == sequencer) {
      reference[h.step] = h.hash;
      while (reference.size() > 64) reference.erase(reference.begin());
      compare(h.step);
    }
  }

  void compare(std::uint64_t step) {
    auto own = own_hashes.find(step);
    auto ref = reference.find(step);
    if (own == own_hashes.end() || ref == reference.end() || !joined) return;
    if (own->second == ref->second) return;
    divergences.push_back({step, own->second, ref->second, sequencer});
    reference.erase(ref);
    if (heal_asked < 0 || now - heal_asked > 1.0) {
      heal_asked = now;
      ++stats.heals;
      send(kHeal, std::string());
    }
  }

  void record_hash() {
    const std::uint64_t h = session_state_hash(session);
    own_hashes[session.steps()] = h;
    while (own_hashes.size() > 64) own_hashes.erase(own_hashes.begin());
    send(kHash, encode(HashReport{session.steps(), h}));
    compare(session.steps());
  }

  // ---------------------------------------------------------------- applying the order
  // The bytes of an ordered payload, or null while a blob is still coming.
  const std::string* payload_bytes(const Payload& p, std::string& inflated) {
    if (!p.blob) return &p.bytes;
    auto it = blobs.find(p.hash);
    if (it == blobs.end() || !it->second.complete) return nullptr;
    inflated = inflate_bytes(it->second.data);
    return &inflated;
  }

  void refuse(UserId user, const std::string& reason) {
    if (user == id) refusals.push_back({session.steps(), reason});
  }

  // Vertices of garment g within the lease radius of p.
  std::vector<std::uint32_t> region(std::size_t g, const Vec3& p, double radius) const {
    std::vector<std::uint32_t> out;
    const Garment& garment = session.garment(g);
    const double r2 = radius * radius;
    for (Vertex v : garment.mesh().vertices())
      if ((garment.position(v) - p).squaredNorm() <= r2) out.push_back(v.idx());
    return out;
  }

  // Another user's unexpired lease on any of `vertices` of garment g (all of g when null), or 0.
  UserId holder(UserId user, std::size_t g, const std::vector<std::uint32_t>* vertices) const {
    for (const auto& [other, lease] : leases) {
      if (other == user || lease.expires <= session.steps()) continue;
      auto it = lease.vertices.find(static_cast<std::uint32_t>(g));
      if (it == lease.vertices.end() || it->second.empty()) continue;
      if (!vertices) return other;
      for (std::uint32_t v : *vertices)
        if (it->second.count(v)) return other;
    }
    return 0;
  }

  std::string name_of(UserId user) const {
    auto it = peers.find(user);
    return it != peers.end() && !it->second.name.empty() ? it->second.name : "peer " + std::to_string(user);
  }

  void grant(UserId user, std::size_t g, const std::vector<std::uint32_t>& vertices, double seconds) {
    Lease& lease = leases[user];
    lease.vertices[static_cast<std::uint32_t>(g)].insert(vertices.begin(), vertices.end());
    const auto hold = static_cast<std::uint64_t>(std::ceil(seconds * session.frame_rate()));
    lease.expires = std::max(lease.expires, session.steps() + hold);
  }

  // Whether `op` by `user` may apply under the leases, granting what a tool event takes.
  bool leased(UserId user, Operation& op) {
    const auto refuse_for = [&](UserId other, const std::string& what) {
      refuse(user, what + ": " + name_of(other) + " is working there (their lease ends at step " +
                       std::to_string(leases[other].expires) + ")");
    };
    if (auto* t = std::get_if<op::ToolInput>(&op.data)) {
      const Phase phase = t->event.phase;
      if (phase == Phase::Begin) refused.erase(user);
      else if (refused.count(user)) return false;  // the rest of a refused stroke
      if (phase == Phase::Cancel) return true;
      const SurfaceHit hit = session.pick(t->event.position, t->event.ray);
      if (!hit.hit) return true;
      const std::vector<std::uint32_t> area = region(hit.garment, hit.point, opt.lease_radius);
      if (const UserId other = holder(user, hit.garment, &area)) {
        refused.insert(user);
        refuse_for(other, "the '" + t->tool + "' stroke was refused");
        if (phase != Phase::Begin && session.stroke_active(user))
          session.perform({session.steps(), user, op::ToolInput{session.active_tool(user), {}, cancel_event(session.time())}});
        return false;
      }
      grant(user, hit.garment, area, opt.lease_hold_seconds);
      return true;
    }
    auto whole = [&](std::size_t g, const char* what) {
      if (g >= session.garment_count()) return true;
      if (const UserId other = holder(user, g, nullptr)) {
        refuse_for(other, std::string(what) + " of garment " + std::to_string(g) + " was refused");
        return false;
      }
      return true;
    };
    if (const auto* s = std::get_if<op::SetGarment>(&op.data)) return whole(s->index, "an edit");
    if (const auto* r = std::get_if<op::RemoveGarment>(&op.data)) return whole(r->index, "removing");
    if (std::holds_alternative<op::Undo>(op.data) || std::holds_alternative<op::Redo>(op.data)) {
      for (std::size_t g = 0; g < session.garment_count(); ++g)
        if (!whole(g, std::holds_alternative<op::Undo>(op.data) ? "undo" : "redo")) return false;
    }
    return true;
  }

  void apply(std::uint64_t gseq, const Ordered& o) {
    std::string inflated;
    const std::string* bytes = payload_bytes(o.payload, inflated);
    PeerOp pop;
    try {
      pop = decode_peer_op(*bytes);
    } catch (const InputError&) {
      ++stats.dropped["malformed order"];
      return;
    }
    const UserId user = o.origin;
    switch (pop.kind) {
      case PeerOp::Session: {
        Operation op;
        try {
          op = decode_operation(pop.operation);
        } catch (const InputError&) {
          ++stats.dropped["malformed order"];
          return;
        }
        op.user = user;
        op.step = session.steps();
        // The shared step is the event's time: no event steps the shared clock itself.
        if (auto* t = std::get_if<op::ToolInput>(&op.data)) t->event.time = session.time();
        if (!leased(user, op)) return;
        try {
          session.perform(op);
          if (!session.last_tool_error().empty()) refuse(user, session.last_tool_error());
        } catch (const Error& e) {  // refused the same way on every peer
          refuse(user, e.what());
        }
        if (std::holds_alternative<op::RemoveGarment>(op.data)) leases.clear();
        break;
      }
      case PeerOp::Lease: {
        if (pop.garment >= session.garment_count()) {
          refuse(user, "a lease on garment " + std::to_string(pop.garment) + ", which does not exist");
          break;
        }
        const std::vector<std::uint32_t> area = region(pop.garment, pop.center, pop.radius);
        if (const UserId other = holder(user, pop.garment, &area)) {
          refuse(user, "the lease was refused: " + name_of(other) + " holds cloth there");
          break;
        }
        grant(user, pop.garment, area, pop.seconds);
        break;
      }
      case PeerOp::Release: leases.erase(user); break;
      case PeerOp::Checkpoint: {
        refused.clear();
        // With no stroke to cancel, the checkpoint's state is the session as it is now: the
        // sequencer ships it before its own rebuild, which the joiner need not wait for.
        const bool ship_first = sequencer == id && session.active_users().empty();
        if (ship_first) ship_state(gseq, pop.targets);
        session.perform({session.steps(), 0, op::Checkpoint{}});
        ++stats.checkpoints;
        for (std::uint32_t t : pop.targets) checkpoint_for.erase(t);
        if (sequencer == id && !ship_first) ship_state(gseq, pop.targets);
        // The repair window starts once the chunks are out and this peer's rebuild is done.
        if (sequencer == id && opt.clock) shipped_at = opt.clock();
        if (std::find(pop.targets.begin(), pop.targets.end(), id) != pop.targets.end() && sequencer != id) {
          joined = false;  // this peer's state was the wrong one: it waits for the sequencer's
          have_offer = false;
        }
        break;
      }
      case PeerOp::PeerLeft: {
        if (session.stroke_active(pop.peer))
          session.perform(
              {session.steps(), pop.peer, op::ToolInput{session.active_tool(pop.peer), {}, cancel_event(session.time())}});
        leases.erase(pop.peer);
        refused.erase(pop.peer);
        left.insert(pop.peer);
        break;
      }
    }
  }

  std::string encode_leases() const {
    ByteWriter w;
    w.u32(static_cast<std::uint32_t>(leases.size()));
    for (const auto& [user, lease] : leases) {
      w.u32(user);
      w.u64(lease.expires);
      w.u32(static_cast<std::uint32_t>(lease.vertices.size()));
      for (const auto& [g, vs] : lease.vertices) {
        w.u32(g);
        w.u32(static_cast<std::uint32_t>(vs.size()));
        for (std::uint32_t v : vs) w.u32(v);
      }
    }
    return w.take();
  }

  void decode_leases(std::string_view bytes) {
    ByteReader r(bytes, "the leases of a snapshot");
    std::map<UserId, Lease> out;
    const std::size_t n = r.count(4096, 16, "the number of leases");
    for (std::size_t i = 0; i < n; ++i) {
      Lease& lease = out[r.u32()];
      lease.expires = r.u64();
      const std::size_t gs = r.count(4096, 8, "the number of garments");
      for (std::size_t k = 0; k < gs; ++k) {
        std::set<std::uint32_t>& vs = lease.vertices[r.u32()];
        const std::size_t m = r.count(1u << 24, 4, "the number of vertices");
        for (std::size_t j = 0; j < m; ++j) vs.insert(r.u32());
      }
    }
    leases = std::move(out);
  }

  void ship_state(std::uint64_t gseq, const std::vector<std::uint32_t>& targets) {
    ByteWriter w;
    w.bytes(session.encode_state());
    w.bytes(encode_leases());
    const std::string packed = deflate_bytes(w.take());
    const std::uint64_t hash = hash_bytes(packed);
    publish_blob(hash, packed);
    for (std::uint32_t t : targets) {
      StateOffer s{t, gseq, hash, static_cast<std::uint32_t>(packed.size())};
      offers[t] = {s, session.steps(), now};
      send(kState, encode(s));
    }
    send_chunks();  // now, not after this peer's own rebuild and next step
  }

  void try_load_offer() {
    if (joined || !have_offer) return;
    auto it = blobs.find(offer.hash);
    if (it == blobs.end() || !it->second.complete) return;
    const std::string whole = inflate_bytes(it->second.data);
    ByteReader r(whole, "snapshot");
    const std::string state(r.bytes(r.left(), "the session's state"));
    const std::string lease_bytes(r.bytes(r.left(), "the leases"));
    session.perform({0, 0, op::Checkpoint{std::make_shared<const std::string>(state)}});
    decode_leases(lease_bytes);
    refused.clear();
    applied = offer.gseq + 1;
    for (auto o = ordered.begin(); o != ordered.end() && o->first <= offer.gseq;) o = ordered.erase(o);
    applied_log.clear();
    // This peer's proposals ordered before the checkpoint are in the state already.
    for (auto p = pending.begin(); p != pending.end();) {
      bool later = false;
      for (const auto& [g, o] : ordered) later = later || (o.origin == id && o.pseq == p->first);
      p = p->second.ordered && !later ? pending.erase(p) : std::next(p);
    }
    joined = true;
    have_offer = false;
    next_step_time = now;
    heartbeat();
  }

  // Applies what is due and steps the shared clock as far as it may go now.
  void advance() {
    const double began = opt.clock ? opt.clock() : 0;
    for (int n = 0; n < kMaxStepsPerTick; ++n) {
      if (n > 0 && opt.clock && opt.clock() - began >= 1.0 / session.frame_rate()) break;
      // Everything ordered for this step, in order.
      for (;;) {
        auto it = ordered.find(applied);
        if (it == ordered.end() || it->second.exec_step > session.steps()) break;
        std::string inflated;
        if (it->second.payload.blob && !payload_bytes(it->second.payload, inflated)) return;  // its blob is coming
        const Ordered o = it->second;
        ordered.erase(it);
        apply(applied, o);
        if (o.origin == id) pending.erase(o.pseq);
        applied_log[applied] = o;
        while (applied_log.size() > kKeepApplied) applied_log.erase(applied_log.begin());
        ++applied;
        ++stats.orders_applied;
        if (!joined) return;  // a checkpoint made this peer wait for the sequencer's state
      }
      // May the clock move on? Not past the horizon, not past an order it has not received, not
      // past the stop, and (in real time) not ahead of the wall clock.
      const std::uint64_t s = session.steps();
      const bool seq = sequencer == id && !claiming;
      if (seq) {
        if (s + 1 > slowest() + static_cast<std::uint64_t>(opt.max_lag_steps)) break;
      } else {
        if (s > horizon || received_through() < known_next) break;
        auto next = ordered.find(applied);
        if (next != ordered.end() && next->second.exec_step <= s) break;
      }
      const std::uint64_t stop_at = stop ? stop : opt.stop_step;
      if (stop_at && s >= stop_at) break;
      // In real time a peer behind the sequencer's clock catches up at once: otherwise a peer that
      // joined a few frames late would apply every order those frames after the others, for good.
      const bool behind = !seq && sequencer_clock() > s;
      if (opt.real_time && !behind && now + 1e-9 < next_step_time) break;
      if (seq && slow_steps() && shipped_at >= 0 && opt.clock() - shipped_at < kRepairWindow) break;
      const double step_began = opt.clock ? opt.clock() : 0;
      session.step(this);
      if (opt.clock) {
        const double took = std::max(opt.clock() - step_began, 1.0 / session.frame_rate());
        step_seconds = step_seconds > 0 ? 0.75 * step_seconds + 0.25 * took : took;
      }
      send_chunks();  // a snapshot's chunks go out between steps, not only once a tick
      if (opt.real_time)
        next_step_time = behind ? now + 1.0 / session.frame_rate()
                                : std::max(next_step_time + 1.0 / session.frame_rate(), now - 0.25);
      if (seq) {
        announced = std::max(announced, session.steps() + static_cast<std::uint64_t>(lookahead()));
        if (stop_at) announced = std::min(announced, std::max(stop_at, last_exec));
        heartbeat();
      }
      if (session.steps() % static_cast<std::uint64_t>(opt.hash_interval) == 0) record_hash();
      stalled_since = -1;
    }
  }

  // ---------------------------------------------------------------- timers
  void tick() {
    if (started < 0) started = now;
    const bool seq = sequencer == id && !claiming;
    if (seq) sequencer_duties();
    if (last_beat < 0 || now - last_beat >= (seq ? 1.0 / session.frame_rate() : opt.heartbeat_seconds)) heartbeat();

    // Proposals not yet ordered go again.
    for (auto& [pseq, p] : pending)
      if (!p.ordered && now - p.sent > 0.1) send_proposal(pseq, p);

    // Orders known to exist but not received are asked for.
    const std::uint64_t through = received_through();
    if (through < known_next && (last_nack < 0 || now - last_nack > 0.03)) {
      send(kNackOrder, encode(NackOrder{through, std::min(known_next, through + kMaxNackRange), 0}));
      ++stats.nacks_sent;
      last_nack = now;
    }
    // Chunks that stopped coming are asked for, up to kMaxNacksARound messages of 200 at once: a
    // sender busy with a slow step answers what it heard since, and a request for only the first
    // 200 of a large snapshot's losses made a round of repairs for every 200 (a step each).
    for (auto& [hash, b] : blobs) {
      if (b.complete || b.count == 0 || now - b.last_chunk < 0.03 || (b.asked >= 0 && now - b.asked < 0.03)) continue;
      BlobNack n;
      n.hash = hash;
      int messages = 0;
      for (std::uint32_t i = 0; i < b.count && messages < kMaxNacksARound; ++i) {
        if (!b.have[i]) n.missing.push_back(i);
        if (n.missing.size() == kMaxNackedChunks || (i + 1 == b.count && !n.missing.empty())) {
          send(kBlobNack, encode(n));
          stats.chunks_asked += n.missing.size();
          n.missing.clear();
          ++messages;
          ++stats.nacks_sent;
        }
      }
      b.asked = now;
    }

    const bool was_joined = joined;
    if (!joined) {
      if (join_asked < 0 || now - join_asked > 0.03) {
        send(kJoin, encode_name(opt.name));
        join_asked = now;
      }
      try_load_offer();
    }
    if (!seq && joined) elect();
    send_chunks();  // chunks asked for again go out now, not after the next (maybe slow) step
    // A peer that has just loaded the shared state lets its user see it before it steps on: on a
    // large garment a step is tenths of a second more to wait.
    if (joined && was_joined) advance();

    // A clock stopped for good (at the shared stop) reports its hash there, again now and then
    // (a report can be lost, and the others wait for it to say they agree).
    const std::uint64_t stop_at = stop ? stop : opt.stop_step;
    if (joined && stop_at && session.steps() >= stop_at && (final_hash_step != session.steps() || now - final_hash_sent > 0.1)) {
      final_hash_step = session.steps();
      final_hash_sent = now;
      if (!own_hashes.count(session.steps())) record_hash();
      else send(kHash, encode(HashReport{session.steps(), own_hashes[session.steps()]}));
    }
    if (joined && stop_at && session.steps() >= stop_at && !pending.empty()) give_up_after_stop(stop_at);
    if (presence_set && (last_presence < 0 || now - last_presence > 0.05)) {
      send(kPresence, encode_presence(presence));
      last_presence = now;
    }
    // Expired leases go.
    for (auto it = leases.begin(); it != leases.end();)
      it = it->second.expires <= session.steps() ? leases.erase(it) : std::next(it);
    send_chunks();
  }

  // At the shared stop nothing ordered after it is applied anywhere: this peer's proposals ordered
  // past it, and those still unordered once every live peer agrees there, would wait for ever (a
  // stroke longer than the session). They are given up, and said as one refusal.
  void give_up_after_stop(std::uint64_t stop_at) {
    const bool all_agree = agree_at(stop_at);
    std::size_t dropped = 0;
    for (auto p = pending.begin(); p != pending.end();) {
      bool past = false, found = false;
      for (const auto& [g, o] : ordered)
        if (o.origin == id && o.pseq == p->first) {
          found = true;
          past = o.exec_step > stop_at;
        }
      if (past || (!found && all_agree)) {
        p = pending.erase(p);
        ++dropped;
      } else {
        ++p;
      }
    }
    if (!dropped) return;
    if (given_up_after_stop == 0) {
      given_up_refusal = refusals.size();
      refusals.push_back({session.steps(), {}});
    }
    given_up_after_stop += dropped;
    refusals[given_up_refusal].reason = std::to_string(given_up_after_stop) +
                                        " change(s) came after the shared clock stopped at step " +
                                        std::to_string(stop_at) + " and were not applied";
  }
  std::size_t given_up_after_stop = 0;  // counted in one refusal, refusals[given_up_refusal]
  std::size_t given_up_refusal = 0;

  // Whether this peer and every live peer reported the same state hash for `step`.
  bool agree_at(std::uint64_t step) const {
    const auto own = own_hashes.find(step);
    if (own == own_hashes.end()) return false;
    for (const auto& [pid, k] : peers) {
      if (left.count(pid) || k.heard < 0 || now - k.heard > opt.silence_seconds) continue;
      const auto h = k.hashes.find(step);
      if (h == k.hashes.end() || h->second != own->second) return false;
    }
    return true;
  }

  // The sequencer is silent: the live peer with the lowest id takes the role over with the next
  // epoch, once it holds every order any live peer received.
  void elect() {
    const auto s = peers.find(sequencer);
    const double heard = s == peers.end() ? started : s->second.heard;
    if (now - heard <= opt.silence_seconds) {
      claiming = false;
      return;
    }
    auto live = [&](std::uint32_t pid) {
      auto k = peers.find(pid);
      return pid != sequencer && !left.count(pid) && k != peers.end() && k->second.joined &&
             now - k->second.heard <= opt.silence_seconds;
    };
    std::uint32_t candidate = id;
    for (const auto& [pid, k] : peers)
      if (live(pid) && pid < candidate) candidate = pid;
    if (candidate != id) return;
    if (!claiming) {
      claiming = true;
      claim_epoch = epoch + 1;
      claim_started = now;
      send(kClaim, encode(Claim{claim_epoch, received_through()}));
      return;
    }
    if (now - claim_started < 3 * opt.heartbeat_seconds) return;
    // Gather: whoever received more, asked for the rest.
    std::uint64_t most = received_through();
    std::uint32_t richest = id;
    for (const auto& [pid, k] : peers)
      if (live(pid) && k.heard >= claim_started && k.received > most) most = k.received, richest = pid;
    if (richest != id && now - claim_started < 2 * opt.silence_seconds) {
      if (last_nack < 0 || now - last_nack > 0.03) {
        const std::uint64_t through = received_through();
        send(kNackOrder, encode(NackOrder{through, std::min(most, through + kMaxNackRange), richest}));
        last_nack = now;
      }
      return;
    }
    become_sequencer();
  }

  void become_sequencer() {
    const std::uint32_t old = sequencer;
    epoch = claim_epoch;
    sequencer = id;
    claiming = false;
    ++stats.elections;
    next_gseq = received_through();
    for (auto it = ordered.lower_bound(next_gseq); it != ordered.end();) it = ordered.erase(it);
    known_next = next_gseq;
    // Orders to come apply after any step a peer may have reached.
    announced = std::max(horizon, session.steps());
    for (const auto& [pid, k] : peers) announced = std::max({announced, k.horizon, k.step});
    last_exec = announced;
    ordered_hw.clear();
    for (const auto* log : {&applied_log, &ordered})
      for (const auto& [g, o] : *log) ordered_hw[o.origin] = std::max(ordered_hw[o.origin], o.pseq);
    for (auto& [pseq, p] : pending) p.ordered = false;
    heartbeat();
    if (old != 0 && old != id && !left.count(old)) {
      left.insert(old);
      PeerOp op;
      op.kind = PeerOp::PeerLeft;
      op.peer = old;
      order_own(op);
    }
  }
};

Peer::Peer(Session& session, PeerTransport& transport, PeerOptions options)
    : impl_(std::make_unique<Impl>(session, transport, std::move(options))) {
  Impl& m = *impl_;
  m.opt.validate();
  if (sodium_init() < 0) throw Error("libsodium could not start");
  m.id = m.opt.id;
  while (m.id == 0) m.id = randombytes_random() & 0x7fffffffu;
  m.wire = std::make_unique<PeerWire>(m.opt.key, m.id);
  if (m.opt.host) {
    m.sequencer = m.id;
    m.epoch = 1;
    m.joined = true;
    m.announced = session.steps();
    m.last_exec = session.steps();
  }
  session.set_gate([this](const Operation& op) { on_local(op); }, impl_.get());
}

Peer::~Peer() { impl_->session.clear_gate(); }

void Peer::on_local(const Operation& op) {
  PeerOp pop;
  pop.kind = PeerOp::Session;
  Operation own = op;
  own.user = 0;
  pop.operation = encode_operation(own);
  impl_->propose_local(op.step, encode(pop));
}

void Peer::propose(const Operation& op) { on_local(op); }

void Peer::receive(std::string_view bytes, double now) {
  impl_->now = now;
  impl_->receive(bytes);
}

void Peer::tick(double now) {
  impl_->now = now;
  impl_->tick();
}

void Peer::leave(double now) {
  impl_->now = now;
  impl_->send(kLeave, std::string());
}

std::uint32_t Peer::id() const { return impl_->id; }
std::uint64_t Peer::stop_step() const { return impl_->stop ? impl_->stop : impl_->opt.stop_step; }
const PeerOptions& Peer::options() const { return impl_->opt; }
bool Peer::joined() const { return impl_->joined; }
bool Peer::is_sequencer() const { return impl_->sequencer == impl_->id && !impl_->claiming; }
std::uint32_t Peer::sequencer() const { return impl_->sequencer; }
std::uint64_t Peer::epoch() const { return impl_->epoch; }
std::size_t Peer::pending() const { return impl_->pending.size(); }
std::uint64_t Peer::applied() const { return impl_->applied; }
const PeerStats& Peer::stats() const { return impl_->stats; }
const std::vector<PeerRefusal>& Peer::refusals() const { return impl_->refusals; }
const std::vector<PeerDivergence>& Peer::divergences() const { return impl_->divergences; }
std::uint64_t Peer::state_hash() const { return session_state_hash(impl_->session); }

std::vector<PeerInfo> Peer::peers() const {
  const Impl& m = *impl_;
  std::vector<PeerInfo> out;
  PeerInfo self;
  self.id = m.id;
  self.name = m.opt.name;
  self.self = true;
  self.sequencer = is_sequencer();
  self.joined = m.joined;
  self.step = m.session.steps();
  self.last_heard = m.now;
  self.presence = m.presence;
  out.push_back(self);
  for (const auto& [pid, k] : m.peers) {
    if (m.left.count(pid) || k.heard < 0 || m.now - k.heard > m.opt.silence_seconds) continue;
    PeerInfo p;
    p.id = pid;
    p.name = k.name;
    p.sequencer = pid == m.sequencer;
    p.joined = k.joined;
    p.step = k.step;
    p.last_heard = k.heard;
    p.presence = k.presence;
    for (auto own = m.own_hashes.rbegin(); own != m.own_hashes.rend(); ++own) {
      auto h = k.hashes.find(own->first);
      if (h == k.hashes.end()) continue;
      p.hash_agrees = h->second == own->second;
      break;
    }
    out.push_back(p);
  }
  return out;
}

std::vector<LeaseInfo> Peer::leases() const {
  std::vector<LeaseInfo> out;
  for (const auto& [user, lease] : impl_->leases) {
    if (lease.expires <= impl_->session.steps()) continue;
    for (const auto& [g, vs] : lease.vertices)
      out.push_back({user, g, std::vector<std::uint32_t>(vs.begin(), vs.end()), lease.expires});
  }
  return out;
}

bool Peer::converged() const {
  const Impl& m = *impl_;
  if (!m.joined || m.own_hashes.empty()) return false;
  // The latest step every live peer reported a hash for, and whether all equal this peer's.
  for (auto own = m.own_hashes.rbegin(); own != m.own_hashes.rend(); ++own) {
    bool all = true, same = true;
    for (const auto& [pid, k] : m.peers) {
      if (m.left.count(pid) || k.heard < 0 || m.now - k.heard > m.opt.silence_seconds) continue;
      auto h = k.hashes.find(own->first);
      if (h == k.hashes.end()) {
        all = false;
        break;
      }
      same = same && h->second == own->second;
    }
    if (all) return same;
  }
  return false;
}

void Peer::set_presence(const PeerPresence& presence) {
  impl_->presence = presence;
  impl_->presence_set = true;
}

void Peer::lease(std::size_t garment, const Vec3& center, double radius, double seconds) {
  if (!all_finite(center) || !(radius > 0 && radius <= 10) || !(seconds > 0 && seconds <= 3600))
    throw InputError("a lease needs a finite centre, a radius in (0, 10] m and a time in (0, 3600] s");
  PeerOp op;
  op.kind = PeerOp::Lease;
  op.garment = static_cast<std::uint32_t>(garment);
  op.center = center;
  op.radius = radius;
  op.seconds = seconds;
  impl_->propose_local(impl_->session.steps(), encode(op));
}

void Peer::release() {
  PeerOp op;
  op.kind = PeerOp::Release;
  impl_->propose_local(impl_->session.steps(), encode(op));
}

}  // namespace kiji
