#include "kiji/peer.h"

#include "kiji/error.h"
#include "net/chunked_transfer.h"
#include "net/hash_audit.h"
#include "net/joining.h"
#include "net/lease_table.h"
#include "net/ordered_log.h"
#include "net/peer_core.h"
#include "net/peer_messages.h"
#include "net/peer_wire.h"
#include "net/sequencer.h"

#include <sodium.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace kiji {

using namespace detail;

namespace {
constexpr int kMaxStepsPerTick = 8;  // catching up, a tick steps at most this many
// After shipping a state, a sequencer whose steps are slow (two frames or more) waits this long
// before its next step, to hear and answer the joiner's requests for lost chunks (a step later
// would be tenths of a second on a large garment).
constexpr double kRepairWindow = 0.15;
// A peer taken for gone waits this long before it asks to join again: longer than any message
// it sent before it knew is on the way.
constexpr double kRejoinAfter = 0.2;
constexpr int kMostKeepAlives = 64;

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

// The peer: its parts (the ordered log, the sequencer and its election, chunked transfer, leases,
// the hash audit, joining), and what joins them: receiving and dispatching messages, this peer's
// own proposals, applying the order and stepping the shared clock, and the timers.
struct Peer::Impl final : SequencerHost {
  Session& session;
  PeerTransport& transport;
  PeerCore core;
  const PeerOptions& opt = core.opt;
  std::unique_ptr<PeerWire> wire;
  Members members;
  OrderedLog log;
  ChunkedTransfer transfer{core};
  Sequencer sequencer{core, log, members, *this};
  LeaseTable leases;
  HashAudit audit{core, session, members};
  Joining joining{core, members, transfer};

  std::vector<PeerRefusal> refusals;
  double started = -1;
  bool joined = false;

  // --- this peer's proposals ---
  struct Proposal {
    std::uint64_t desired = 0;
    Payload payload;
    bool ordered = false;
    double sent = -1;
  };
  std::map<std::uint64_t, Proposal> pending;
  std::uint64_t next_pseq = 1;
  // Changes given up in bulk, each kind said as one refusal that counts them.
  struct Tally {
    std::size_t refusal = 0, count = 0;  // refusals[refusal] says `count` changes
  };
  Tally after_stop;
  // The sequencer took this peer for gone (it heard nothing from it for silence_seconds: a peer
  // too slow to answer, or paused) and orders nothing of it after, until it asks to join again:
  // its changes until it asks are given up, counted in one refusal (tally `gone`). Its
  // state is still the shared one (it applies every order), so it asks with a join, which the
  // sequencer answers as any join, with a checkpoint and its state; asked again until that comes.
  bool taken_for_gone = false, rejoining = false;
  bool stroke_cut_off = false;  // the stroke its user was drawing then, cancelled everywhere: given up to its end
  double gone_at = -1;
  Tally gone;

  // --- pacing and presence ---
  double step_seconds = 0;   // a step's wall time from step to step (a moving mean; 0: unknown)
  double shipped_at = -1;    // when a state was last shipped to a joining peer (on opt.clock)
  double last_beat = -1;
  double next_step_time = -1;
  PeerPresence presence;
  bool presence_set = false;
  double last_presence = -1;

  Impl(Session& s, PeerTransport& t, PeerOptions o)
      : session(s), transport(t),
        leases(s, o.lease_radius, o.lease_hold_seconds, [this](UserId u) { return name_of(u); },
               [this](UserId u, const std::string& reason) { refuse(u, reason); }) {
    core.opt = std::move(o);
    core.send = [this](std::uint8_t type, const std::string& body) { send(type, body); };
  }

  double now() const { return core.now; }

  // ---------------------------------------------------------------- sending
  void send(std::uint8_t type, const std::string& body) {
    const std::string bytes = wire->seal(type, sequencer.epoch(), body);
    ++core.stats.sent;
    core.stats.bytes_sent += bytes.size();
    transport.send(bytes);
  }

  void heartbeat() override {
    send(kHeartbeat, encode(heartbeat_now()));
    last_beat = now();
  }

  // Heartbeats sealed now for the transport to send while this peer's thread is busy (a step, a
  // state loaded or shipped: what they say stays true until it ends), one every third of the
  // silence that makes a peer gone, for eight times the last step's length (a step of unknown
  // length, the first after a join rebuilds the solver: for the most); taken back after.
  // Only in real time, where the work may outlast a heartbeat (`long_work`).
  class KeptAlive {
   public:
    KeptAlive(Impl& m, bool long_work) : m_(m), on_(long_work && m.opt.clock) {
      if (!on_) return;
      const double every = m.opt.silence_seconds / 3;
      const int count = m.step_seconds > 0 ? static_cast<int>(std::ceil(8 * m.step_seconds / every)) : kMostKeepAlives;
      const std::string body = encode(m.heartbeat_now());
      std::vector<std::string> sealed;
      for (int k = 0; k < std::clamp(count, 2, kMostKeepAlives); ++k)
        sealed.push_back(m.wire->seal(kHeartbeat, m.sequencer.epoch(), body));
      m.transport.keep_alive(std::move(sealed), every);
    }
    ~KeptAlive() {
      if (on_) m_.transport.keep_alive({}, 0);
    }
    KeptAlive(const KeptAlive&) = delete;
    KeptAlive& operator=(const KeptAlive&) = delete;

   private:
    Impl& m_;
    const bool on_;
  };

  Heartbeat heartbeat_now() {
    Heartbeat h;
    const bool seq = sequencer.is_self();
    h.name = opt.name;
    h.sequencer = seq;
    h.joined = joined && !rejoining;  // back after it was taken for gone: not until its state has come
    h.step = session.steps();
    h.received = log.received_through();
    h.horizon = seq ? sequencer.announced() : log.horizon();
    h.next = seq ? sequencer.next_number() : log.known_next();
    h.stop = log.stop() ? log.stop() : opt.stop_step;
    if (seq)
      for (const auto& [origin, pseq] : sequencer.ordered()) h.ordered.emplace_back(origin, pseq);
    return h;
  }

  // ---------------------------------------------------------------- what the sequencer asks
  std::uint64_t steps() const override { return session.steps(); }
  Payload carry(const std::string& bytes) override { return transfer.carry(bytes); }
  void acknowledge(std::uint64_t pseq) override {
    auto it = pending.find(pseq);
    if (it != pending.end()) it->second.ordered = true;
  }
  void new_term() override {
    for (auto& [pseq, p] : pending) p.ordered = false;
  }
  void acknowledge_through(std::uint64_t pseq) {
    for (auto& [s, p] : pending)
      if (s <= pseq) p.ordered = true;
  }

  // ---------------------------------------------------------------- local proposals
  void propose_local(std::uint64_t desired, const std::string& peer_op) {
    if (taken_for_gone) return give_up_gone(1);
    const std::uint64_t pseq = next_pseq++;
    Proposal& p = pending[pseq];
    p.desired = desired;
    p.payload = transfer.carry(peer_op);
    send_proposal(pseq, p);
  }

  void send_proposal(std::uint64_t pseq, Proposal& p) {
    p.sent = now();
    Propose msg{pseq, p.desired, p.payload};
    if (sequencer.acting()) {
      sequencer.on_propose(core.id, msg);
      return;
    }
    send(kPropose, encode(msg));
  }

  // ---------------------------------------------------------------- the sequencer's duties
  void sequencer_duties() {
    if (joining.checkpoint_due(!session.active_users().empty())) order_checkpoint();
    sequencer.drop_silent();
    joining.offer_again();
  }

  // One checkpoint for every peer that asked within a few milliseconds of the first: each costs
  // every peer a rebuild of its state.
  void order_checkpoint() {
    PeerOp op;
    op.kind = PeerOp::Checkpoint;
    op.targets = joining.gather();
    sequencer.order_own(op);
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
    auto m = members.all.find(sequencer.holder());
    return m != members.all.end() && m->second.sequencer ? m->second.step : 0;
  }

  // The slowest joined peer's clock: the sequencer runs at most max_lag_steps ahead of it.
  std::uint64_t slowest() const {
    std::uint64_t s = session.steps();
    for (const auto& [pid, m] : members.all)
      if (m.joined && !members.left.count(pid) && now() - m.heard <= opt.silence_seconds) s = std::min(s, m.step);
    // A peer being given the state starts at its checkpoint: the clock waits for it there.
    return joining.slowest(s);
  }

  // ---------------------------------------------------------------- receiving
  void receive(std::string_view bytes) {
    ++core.stats.received;
    core.stats.bytes_received += bytes.size();
    PeerEnvelope env;
    const WireVerdict v = wire->open(bytes, env);
    if (v != WireVerdict::Ok) {
      ++core.stats.dropped[wire_verdict_name(v)];
      return;
    }
    try {
      dispatch(env);
    } catch (const InputError&) {  // authentic but malformed: a bug elsewhere, never a crash here
      ++core.stats.dropped["malformed body"];
    }
  }

  void dispatch(const PeerEnvelope& env) {
    Member& m = members.all[env.sender];
    m.heard = now();
    if (env.type == kHeartbeat || env.type == kOrder || env.type == kClaim) sequencer.on_newer_term(env.epoch);
    switch (env.type) {
      case kHeartbeat: on_heartbeat(env, decode_heartbeat(env.body)); break;
      case kPropose: sequencer.on_propose(env.sender, decode_propose(env.body)); break;
      case kOrder:
        // From the sequencer, or a repair from any peer; never from an older term.
        if (env.epoch < sequencer.epoch()) {
          ++core.stats.dropped["stale epoch"];
          break;
        }
        on_order(decode_order(env.body), env.epoch);
        break;
      case kNackOrder: on_nack_order(decode_nack_order(env.body)); break;
      case kBlobChunk: transfer.on_chunk(decode_blob_chunk(env.body)); break;
      case kBlobNack: transfer.on_nack(decode_blob_nack(env.body), sequencer.is_self()); break;
      case kHash: audit.on_report(env.sender, decode_hash(env.body), joined, sequencer.holder()); break;
      case kJoin:
        m.name = decode_name(env.body);
        m.joined = false;
        members.left.erase(env.sender);
        joining.on_request(env.sender, sequencer.acting());
        break;
      case kPresence: m.presence = decode_presence(env.body); break;
      case kClaim:
        if (decode_claim(env.body).epoch > sequencer.epoch()) heartbeat();  // tell the claimant what this peer has
        break;
      case kLeave:
        if (sequencer.is_self() && !members.left.count(env.sender)) sequencer.order_departure(env.sender);
        m.joined = false;
        break;
      case kState: joining.on_offer(decode_state_offer(env.body), joined && !rejoining); break;
      case kHeal: joining.on_request(env.sender, sequencer.acting()); break;
      default: ++core.stats.dropped["unknown type"]; break;
    }
  }

  void on_heartbeat(const PeerEnvelope& env, const Heartbeat& h) {
    Member& m = members.all[env.sender];
    m.name = h.name;
    m.joined = h.joined;
    m.step = h.step;
    m.received = h.received;
    m.horizon = h.horizon;
    m.sequencer = h.sequencer;
    if (!h.sequencer || !sequencer.on_heartbeat(env.sender, env.epoch, h)) return;
    log.raise_horizon(h.horizon);
    log.know(h.next);
    log.set_stop(h.stop);
    for (const auto& [origin, pseq] : h.ordered)
      if (origin == core.id) acknowledge_through(pseq);
  }

  void on_order(const Order& o, std::uint64_t order_epoch) {
    if (!log.receive(o.gseq, {o.exec_step, o.origin, o.pseq, order_epoch, o.payload})) return;
    if (o.origin == core.id) acknowledge(o.pseq);
    if (o.payload.blob) transfer.want(o.payload.hash, o.payload.size);
  }

  void on_nack_order(const NackOrder& n) {
    const bool mine_to_answer = n.target == core.id || (n.target == 0 && sequencer.is_self());
    if (!mine_to_answer) return;
    for (std::uint64_t g = n.from; g < n.to && g < n.from + OrderedLog::kMaxNackRange; ++g)
      if (const Ordered* o = log.find(g)) {
        send(kOrder, encode_order(g, *o));
        ++core.stats.resent;
      }
  }

  // ---------------------------------------------------------------- applying the order
  void refuse(UserId user, const std::string& reason) {
    if (user == core.id) refusals.push_back({session.steps(), reason});
  }

  std::string name_of(UserId user) const {
    auto it = members.all.find(user);
    return it != members.all.end() && !it->second.name.empty() ? it->second.name : "peer " + std::to_string(user);
  }

  void apply(std::uint64_t gseq, const Ordered& o) {
    std::string inflated;
    const std::string* bytes = transfer.bytes(o.payload, inflated);
    PeerOp pop;
    try {
      pop = decode_peer_op(*bytes);
    } catch (const InputError&) {
      ++core.stats.dropped["malformed order"];
      return;
    }
    const UserId user = o.origin;
    switch (pop.kind) {
      case PeerOp::Session: {
        Operation op;
        try {
          op = decode_operation(pop.operation);
        } catch (const InputError&) {
          ++core.stats.dropped["malformed order"];
          return;
        }
        op.user = user;
        op.step = session.steps();
        // The shared step is the event's time: no event steps the shared clock itself.
        if (auto* t = std::get_if<op::ToolInput>(&op.data)) t->event.time = session.time();
        if (!leases.admit(user, op)) return;
        try {
          session.perform(op);
          if (!session.last_tool_error().empty()) refuse(user, session.last_tool_error());
        } catch (const Error& e) {  // refused the same way on every peer
          refuse(user, e.what());
        }
        if (std::holds_alternative<op::RemoveGarment>(op.data)) leases.clear();
        break;
      }
      case PeerOp::Lease: leases.lease(user, pop.garment, pop.center, pop.radius, pop.seconds); break;
      case PeerOp::Release: leases.release(user); break;
      case PeerOp::Checkpoint: {
        leases.clear_refused();
        // With no stroke to cancel, the checkpoint's state is the session as it is now: the
        // sequencer ships it before its own rebuild, which the joiner need not wait for.
        const bool seq = sequencer.is_self();
        const bool ship_first = seq && session.active_users().empty();
        if (ship_first) ship_state(gseq, pop.targets);
        session.perform({session.steps(), 0, op::Checkpoint{}});
        ++core.stats.checkpoints;
        joining.checkpoint_applied(pop.targets);
        if (seq && !ship_first) ship_state(gseq, pop.targets);
        // The repair window starts once the chunks are out and this peer's rebuild is done.
        if (seq && opt.clock) shipped_at = opt.clock();
        if (std::find(pop.targets.begin(), pop.targets.end(), core.id) != pop.targets.end() && !seq) {
          joined = false;  // healed, or back after it was taken for gone: it waits for the sequencer's state
          if (!rejoining) joining.forget_offer();  // back, the offer may have come already: it is this one's
        }
        break;
      }
      case PeerOp::PeerLeft: {
        if (session.stroke_active(pop.peer))
          session.perform(
              {session.steps(), pop.peer, op::ToolInput{session.active_tool(pop.peer), {}, cancel_event(session.time())}});
        leases.forget(pop.peer);
        members.left.insert(pop.peer);
        if (pop.peer == core.id) {
          // Everything of this peer ordered before its departure is applied by now: what is left
          // was never ordered, and never will be. Its numbers go to the proposals after it joins
          // again (the sequencer takes each origin's proposals in an unbroken run).
          if (!taken_for_gone) gone = {};
          taken_for_gone = true;
          stroke_cut_off = true;
          rejoining = false;
          gone_at = now();
          give_up_gone(pending.size());
          if (!pending.empty()) next_pseq = pending.begin()->first;
          pending.clear();
        }
        break;
      }
    }
  }

  void ship_state(std::uint64_t gseq, const std::vector<std::uint32_t>& targets) {
    const KeptAlive kept(*this, true);
    joining.ship(gseq, targets, session.steps(), Snapshot{session.encode_state(), leases.encode()});
  }

  void try_load_offer() {
    if (joined) return;
    auto offered = joining.take();
    if (!offered) return;
    const auto& [gseq, snapshot] = *offered;
    {
      const KeptAlive kept(*this, true);
      session.perform({0, 0, op::Checkpoint{std::make_shared<const std::string>(snapshot.state)}});
    }
    leases.decode(snapshot.leases);
    leases.clear_refused();
    log.start_after(gseq);
    // This peer's proposals ordered before the checkpoint are in the state already.
    for (auto p = pending.begin(); p != pending.end();) {
      bool later = false;
      for (const auto& [g, o] : log.waiting()) later = later || (o.origin == core.id && o.pseq == p->first);
      p = p->second.ordered && !later ? pending.erase(p) : std::next(p);
    }
    joined = true;
    rejoining = false;
    joining.forget_offer();
    next_step_time = now();
    heartbeat();
  }

  // Applies what is due and steps the shared clock as far as it may go now.
  void advance() {
    const double began = opt.clock ? opt.clock() : 0;
    for (int n = 0; n < kMaxStepsPerTick; ++n) {
      if (n > 0 && opt.clock && opt.clock() - began >= 1.0 / session.frame_rate()) break;
      // Everything ordered for this step, in order.
      for (;;) {
        const Ordered* next = log.next();
        if (!next || next->exec_step > session.steps()) break;
        std::string inflated;
        if (next->payload.blob && !transfer.bytes(next->payload, inflated)) return;  // its blob is coming
        const std::uint64_t gseq = log.applied();
        const Ordered o = log.take_next();
        apply(gseq, o);
        if (o.origin == core.id) pending.erase(o.pseq);
        log.applied(o);
        ++core.stats.orders_applied;
        if (!joined) return;  // a checkpoint made this peer wait for the sequencer's state
      }
      // May the clock move on? Not past the horizon, not past an order it has not received, not
      // past the stop, and (in real time) not ahead of the wall clock.
      const std::uint64_t s = session.steps();
      const bool seq = sequencer.acting();
      if (seq) {
        if (s + 1 > slowest() + static_cast<std::uint64_t>(opt.max_lag_steps)) break;
      } else {
        if (s > log.horizon() || log.received_through() < log.known_next()) break;
        const Ordered* next = log.next();
        if (next && next->exec_step <= s) break;
      }
      const std::uint64_t stop_at = log.stop() ? log.stop() : opt.stop_step;
      if (stop_at && s >= stop_at) break;
      // In real time a peer behind the sequencer's clock catches up at once: otherwise a peer that
      // joined a few frames late would apply every order those frames after the others, for good.
      const bool behind = !seq && sequencer_clock() > s;
      if (opt.real_time && !behind && now() + 1e-9 < next_step_time) break;
      if (seq && slow_steps() && shipped_at >= 0 && opt.clock() - shipped_at < kRepairWindow) break;
      const double step_began = opt.clock ? opt.clock() : 0;
      {
        const KeptAlive kept(*this, step_seconds == 0 || step_seconds > opt.heartbeat_seconds);
        session.step(this);
      }
      if (opt.clock) {
        const double took = std::max(opt.clock() - step_began, 1.0 / session.frame_rate());
        step_seconds = step_seconds > 0 ? 0.75 * step_seconds + 0.25 * took : took;
      }
      transfer.send_chunks();  // a snapshot's chunks go out between steps, not only once a tick
      if (opt.real_time)
        next_step_time = behind ? now() + 1.0 / session.frame_rate()
                                : std::max(next_step_time + 1.0 / session.frame_rate(), now() - 0.25);
      if (seq) {
        sequencer.announce(session.steps(), lookahead(), stop_at);
        heartbeat();
      }
      if (session.steps() % static_cast<std::uint64_t>(opt.hash_interval) == 0) audit.record(joined, sequencer.holder());
    }
  }

  // ---------------------------------------------------------------- timers
  void tick() {
    if (started < 0) started = now();
    const bool seq = sequencer.acting();
    if (seq) sequencer_duties();
    if (last_beat < 0 || now() - last_beat >= (seq ? 1.0 / session.frame_rate() : opt.heartbeat_seconds)) heartbeat();

    // Proposals not yet ordered go again.
    for (auto& [pseq, p] : pending)
      if (!p.ordered && now() - p.sent > 0.1) send_proposal(pseq, p);

    // Orders known to exist but not received are asked for, and chunks that stopped coming.
    if (const auto gap = log.gap(now())) {
      send(kNackOrder, encode(*gap));
      ++core.stats.nacks_sent;
    }
    transfer.ask_for_missing();

    const bool was_joined = joined;
    if (!joined) {
      joining.ask();
      try_load_offer();
    }
    ask_back();
    if (!seq && joined) sequencer.elect(started);
    transfer.send_chunks();  // chunks asked for again go out now, not after the next (maybe slow) step
    // A peer that has just loaded the shared state lets its user see it before it steps on: on a
    // large garment a step is tenths of a second more to wait.
    if (joined && was_joined) advance();

    // A clock stopped for good (at the shared stop) reports its hash there, again now and then
    // (a report can be lost, and the others wait for it to say they agree).
    const std::uint64_t stop_at = log.stop() ? log.stop() : opt.stop_step;
    if (joined && stop_at && session.steps() >= stop_at) audit.report_at_stop(joined, sequencer.holder());
    if (joined && stop_at && session.steps() >= stop_at && !pending.empty()) give_up_after_stop(stop_at);
    if (presence_set && (last_presence < 0 || now() - last_presence > 0.05)) {
      send(kPresence, encode_presence(presence));
      last_presence = now();
    }
    leases.expire();
    transfer.send_chunks();
  }

  // Taken for gone, it asks to join again once its last proposals can no longer be on the way (the
  // sequencer, taking it back, would order them), and again while no checkpoint for it has come.
  void ask_back() {
    const std::uint64_t stop_at = log.stop() ? log.stop() : opt.stop_step;
    if (!joined || (stop_at && session.steps() >= stop_at)) return;
    if (taken_for_gone && now() - gone_at >= kRejoinAfter) {
      taken_for_gone = false;
      rejoining = true;
    }
    if (rejoining) joining.ask();
  }

  // Adds `changes` to a tally, opening its refusal (at this step) with the first.
  void give_up(Tally& t, std::size_t changes, const std::function<std::string(const Tally&)>& reason) {
    if (changes == 0) return;
    if (t.count == 0) {
      t.refusal = refusals.size();
      refusals.push_back({session.steps(), {}});
    }
    t.count += changes;
    refusals[t.refusal].reason = reason(t);
  }

  void give_up_gone(std::size_t changes) {
    give_up(gone, changes, [&](const Tally& t) {
      std::ostringstream why;
      why << "the session took this peer for gone at step " << refusals[t.refusal].step << " (nothing was heard "
          << "from it for " << opt.silence_seconds << " s): " << t.count
          << " change(s) made until it had joined again, or in the stroke it cut off, were not applied";
      return why.str();
    });
  }

  // At the shared stop nothing ordered after it is applied anywhere: this peer's proposals ordered
  // past it, and those still unordered once every live peer agrees there, would wait for ever (a
  // stroke longer than the session). They are given up, and said as one refusal.
  void give_up_after_stop(std::uint64_t stop_at) {
    const bool all_agree = audit.agree_at(stop_at);
    std::size_t dropped = 0;
    for (auto p = pending.begin(); p != pending.end();) {
      bool past = false, found = false;
      for (const auto& [g, o] : log.waiting())
        if (o.origin == core.id && o.pseq == p->first) {
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
    give_up(after_stop, dropped, [&](const Tally& t) {
      return std::to_string(t.count) + " change(s) came after the shared clock stopped at step " +
             std::to_string(stop_at) + " and were not applied";
    });
  }
};

Peer::Peer(Session& session, PeerTransport& transport, PeerOptions options)
    : impl_(std::make_unique<Impl>(session, transport, std::move(options))) {
  Impl& m = *impl_;
  m.opt.validate();
  if (sodium_init() < 0) throw Error("libsodium could not start");
  m.core.id = m.opt.id;
  while (m.core.id == 0) m.core.id = randombytes_random() & 0x7fffffffu;
  m.wire = std::make_unique<PeerWire>(m.opt.key, m.core.id);
  if (m.opt.host) {
    m.sequencer.start(session.steps());
    m.joined = true;
  }
  session.set_gate([this](const Operation& op) { on_local(op); }, impl_.get());
}

Peer::~Peer() { impl_->session.clear_gate(); }

void Peer::on_local(const Operation& op) {
  Impl& m = *impl_;
  if (const auto* input = std::get_if<op::ToolInput>(&op.data)) {
    // A stroke begun while taken for gone is given up whole, as is the rest of one it cut off.
    if (input->event.phase == Phase::Begin) m.stroke_cut_off = m.taken_for_gone;
    else if (m.stroke_cut_off) return m.give_up_gone(1);
  }
  PeerOp pop;
  pop.kind = PeerOp::Session;
  Operation own = op;
  own.user = 0;
  pop.operation = encode_operation(own);
  impl_->propose_local(op.step, encode(pop));
}

void Peer::propose(const Operation& op) { on_local(op); }

void Peer::receive(std::string_view bytes, double now) {
  impl_->core.now = now;
  impl_->receive(bytes);
}

void Peer::tick(double now) {
  impl_->core.now = now;
  impl_->tick();
}

void Peer::leave(double now) {
  impl_->core.now = now;
  impl_->send(kLeave, std::string());
}

std::uint32_t Peer::id() const { return impl_->core.id; }
std::uint64_t Peer::stop_step() const { return impl_->log.stop() ? impl_->log.stop() : impl_->opt.stop_step; }
const PeerOptions& Peer::options() const { return impl_->opt; }
bool Peer::joined() const { return impl_->joined; }
bool Peer::is_sequencer() const { return impl_->sequencer.acting(); }
std::uint32_t Peer::sequencer() const { return impl_->sequencer.holder(); }
std::uint64_t Peer::epoch() const { return impl_->sequencer.epoch(); }
std::size_t Peer::pending() const { return impl_->pending.size(); }
std::uint64_t Peer::applied() const { return impl_->log.applied(); }
const PeerStats& Peer::stats() const { return impl_->core.stats; }
const std::vector<PeerRefusal>& Peer::refusals() const { return impl_->refusals; }
const std::vector<PeerDivergence>& Peer::divergences() const { return impl_->audit.divergences(); }
std::uint64_t Peer::state_hash() const { return session_state_hash(impl_->session); }

std::vector<PeerInfo> Peer::peers() const {
  const Impl& m = *impl_;
  std::vector<PeerInfo> out;
  PeerInfo self;
  self.id = m.core.id;
  self.name = m.opt.name;
  self.self = true;
  self.sequencer = is_sequencer();
  self.joined = m.joined;
  self.step = m.session.steps();
  self.last_heard = m.now();
  self.presence = m.presence;
  out.push_back(self);
  for (const auto& [pid, member] : m.members.all) {
    if (!m.members.live(pid, member, m.now(), m.opt.silence_seconds)) continue;
    PeerInfo p;
    p.id = pid;
    p.name = member.name;
    p.sequencer = pid == m.sequencer.holder();
    p.joined = member.joined;
    p.step = member.step;
    p.last_heard = member.heard;
    p.presence = member.presence;
    p.hash_agrees = m.audit.agrees_with(pid);
    out.push_back(p);
  }
  return out;
}

std::vector<LeaseInfo> Peer::leases() const { return impl_->leases.infos(); }

bool Peer::converged() const { return impl_->joined && impl_->audit.converged(); }

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
