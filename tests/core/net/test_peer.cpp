// Peers: many in one process on a simulated network with seeded loss, duplication, reordering,
// delay and crashes; every seed ends with every live peer holding the same garment bit for bit,
// no region ever held by two users, no acknowledged operation lost. And the messages themselves:
// forged, replayed, cut short or oversized, each dropped and counted.
#include "kiji/error.h"
#include "kiji/pattern.h"
#include "kiji/peer.h"
#include "kiji/session.h"
#include "support/peer_sim.h"
#include "net/peer_messages.h"
#include "net/peer_wire.h"
#include "support/test_shapes.h"
#include "support/test_strokes.h"

#include <gtest/gtest.h>

#include <optional>
#include <set>

using namespace kiji;
using test::line;
using test::plugins;
using test::SimNetwork;

namespace {

const std::string kKey = "a shared secret for the tests, 32 bytes or so";

void host_garment(Session& s);

// N peers on one simulated network, stepped a millisecond at a time.
struct Group {
  SimNetwork net;
  struct Node {
    std::unique_ptr<Session> session;
    std::unique_ptr<Peer> peer;
    bool started = false;
  };
  std::vector<Node> nodes;
  PeerOptions base;

  Group(std::uint64_t seed, SimNetwork::Faults faults, int n) : net(seed, faults) {
    base.key = kKey;
    base.hash_interval = 15;
    base.silence_seconds = 0.4;
    base.heartbeat_seconds = 0.04;
    for (int i = 0; i < n; ++i) {
      net.add_node();
      nodes.push_back({std::make_unique<Session>(plugins()), nullptr, false});
    }
  }

  // Node i starts its peer now (node 0 hosts, with the garment its session has).
  void start(int i) {
    PeerOptions o = base;
    o.id = static_cast<std::uint32_t>(100 + i);
    o.name = "peer" + std::to_string(i);
    o.host = i == 0;
    nodes[i].peer = std::make_unique<Peer>(*nodes[i].session, net.port(i), o);
    nodes[i].started = true;
  }

  void run_until(double t, const std::function<void()>& each_ms = {}) {
    while (net.now() < t - 1e-9) {
      net.set_now(net.now() + 0.001);
      net.deliver([&](int node, const std::string& bytes) {
        if (nodes[node].started) nodes[node].peer->receive(bytes, net.now());
      });
      for (int i = 0; i < static_cast<int>(nodes.size()); ++i)
        if (nodes[i].started && net.alive(i)) nodes[i].peer->tick(net.now());
      if (each_ms) each_ms();
    }
  }

  // Node 0 hosts its garment (host_garment), node 1 joins; the network runs until `t`.
  void host_and_join(double t) {
    host_garment(*nodes[0].session);
    start(0);
    start(1);
    run_until(t);
  }

  // Node n's user draws a pinch stroke, an event about every frame on its session's clock, while
  // the network runs until `t` (`each` after each event); the events drawn.
  std::size_t draw(int n, const Stroke& stroke, double t, const std::function<void()>& each = {}) {
    Session& s = *nodes[n].session;
    const ParamSet params = s.params_for("pinch");
    std::size_t i = 0;
    run_until(t, [&] {
      if (i < stroke.size() && std::fmod(net.now(), 0.017) < 0.001) {
        ToolEvent e = stroke[i++];
        e.time = s.time();
        s.apply("pinch", e, &params);
        if (each) each();
      }
    });
    return i;
  }

  std::vector<int> live() const {
    std::vector<int> out;
    for (int i = 0; i < static_cast<int>(nodes.size()); ++i)
      if (nodes[i].started && net.alive(i)) out.push_back(i);
    return out;
  }
};

// The host's garment: a cloth 0.6 m square standing in the z = 0 plane, without gravity (so the
// users' strokes find it where they aim), above a floor.
void host_garment(Session& s) {
  Garment g = make_rectangle(0.6, 0.6, 9, 9);
  g.transform(Eigen::Affine3d(Eigen::Translation3d(-0.3, 0.5, 0)));
  s.add_garment(g);
  s.set_body(test::make_floor());
  SolverParams p;
  p.gravity = Vec3::Zero();
  s.set_solver_params(p);
}

// A host alone on a simulated network. With `reading`, its clock moves that many seconds between
// readings (a step's wall time); without, it has no clock (a deterministic run).
struct LoneHost {
  Session session{plugins()};
  SimNetwork net{1, {}};
  double spent = 0;
  std::unique_ptr<Peer> peer;
  explicit LoneHost(std::optional<double> reading) {
    host_garment(session);
    net.add_node();
    PeerOptions o;
    o.key = kKey;
    o.host = true;
    if (reading) o.clock = [this, r = *reading] { return net.now() + (spent += r); };
    peer = std::make_unique<Peer>(session, net.port(0), o);
  }
};

// Whether some vertex is held by two users, in a peer's lease table.
bool doubly_held(const Peer& p) {
  std::map<std::pair<std::size_t, std::uint32_t>, UserId> owner;
  for (const LeaseInfo& l : p.leases())
    for (std::uint32_t v : l.vertices) {
      auto [it, fresh] = owner.emplace(std::make_pair(l.garment, v), l.holder);
      if (!fresh && it->second != l.holder) return true;
    }
  return false;
}

}  // namespace

// One seed of a shared design session: 8 peers joining one by one, strokes of several tools from
// several users, undo, pausing, a peer crashing and (every third seed) the sequencer killed.
void run_seed(std::uint64_t seed, bool crash_sequencer) {
  SCOPED_TRACE("seed " + std::to_string(seed) + " (rerun with KIJI_PEER_SEED=" + std::to_string(seed) + ")");
  SimNetwork::Faults faults;
  faults.loss = 0.10;
  faults.duplicate = 0.05;
  faults.min_delay = 0.0002;
  faults.max_delay = 0.006;
  Group g(seed, faults, 8);
  g.base.stop_step = 150;
  host_garment(*g.nodes[0].session);
  g.start(0);
  std::mt19937 rng(static_cast<unsigned>(seed));
  for (int i = 1; i < 7; ++i) g.start(i);
  double all_joined = -1;
  g.run_until(0.4, [&] {
    bool all = true;
    for (int i : g.live()) all = all && g.nodes[i].peer->joined();
    if (all && all_joined < 0) all_joined = g.net.now();
  });
  ASSERT_GT(all_joined, 0) << "seven peers joining at once under loss were not all in within 0.4 s";

  // Users work: each a stroke somewhere on the cloth, some at the same time.
  struct Act {
    double at;
    int node;
    std::function<void(Session&)> act;
  };
  const auto pinch = [](Vec3 from, Vec3 to) {
    return [=](Session& s) { s.run("pinch", s.params_for("pinch"), line(from, to, 6, s.time())); };
  };
  std::vector<Act> acts = {
      {0.45, 1, pinch(Vec3(-0.3, 0.5, 0), Vec3(-0.4, 0.6, 0.1))},
      {0.45, 2, pinch(Vec3(0.3, 0.5, 0), Vec3(0.4, 0.6, 0.1))},
      {0.5, 3, [](Session& s) {  // a mouse's cut: rays from the front onto the cloth
         Stroke cut = line(Vec3(-0.7, 0.8, 1), Vec3(0.7, 0.8, 1), 24, s.time());
         for (ToolEvent& e : cut) e.ray = Vec3(0, 0, -1);
         s.run("cut", s.params_for("cut"), cut);
       }},
      {0.6, 4, [](Session& s) { s.set_simulating(false); }},
      {0.7, 5, [](Session& s) { s.run("paint", s.params_for("paint", {{"resolution", 32LL}}), line(Vec3(0, 0.6, 0), Vec3(0.1, 0.6, 0), 4, s.time())); }},
      {0.8, 4, [](Session& s) { s.set_simulating(true); }},
      {1.0, 6, pinch(Vec3(0.3, 1.1, 0), Vec3(0.35, 1.2, 0.05))},
      {1.1, 7, [](Session& s) { s.undo(); }},
      {1.3, 2, pinch(Vec3(-0.3, 1.1, 0), Vec3(-0.3, 1.0, 0.1))},
      {1.6, 1, pinch(Vec3(0, 0.5, 0), Vec3(0, 0.4, 0.1))},
  };
  const int victim = 1 + static_cast<int>(rng() % 6);
  // Another peer pauses (it neither hears nor speaks) for longer than silence_seconds: taken for
  // gone, it joins again.
  const int paused = 1 + (victim % 6);
  std::size_t next = 0;
  double crash_at = 1.2;
  bool crashed = false, overlap = false;
  std::size_t leased = 0;
  g.run_until(2.6, [&] {
    for (int i : g.live()) {
      overlap = overlap || doubly_held(*g.nodes[i].peer);
      leased = std::max(leased, g.nodes[i].peer->leases().size());
    }
    g.nodes[paused].started = g.net.now() < 1.4 || g.net.now() >= 2.0;
    while (next < acts.size() && acts[next].at <= g.net.now() + 1e-9) {
      const Act& a = acts[next++];
      if (g.net.alive(a.node) && g.nodes[a.node].started) a.act(*g.nodes[a.node].session);
    }
    if (!g.nodes[7].started && g.net.now() >= 0.9) g.start(7);  // a late joiner
    if (!crashed && g.net.now() >= crash_at) {
      crashed = true;
      g.net.crash(crash_sequencer ? 0 : victim);
    }
  });
  g.run_until(4.0);

  EXPECT_FALSE(overlap) << "two users held the same cloth";
  EXPECT_GE(leased, 2u) << "several users held cloth at once";
  const auto live = g.live();
  ASSERT_GE(live.size(), 6u);
  const Peer& first = *g.nodes[live[0]].peer;
  for (int i : live) {
    const Peer& p = *g.nodes[i].peer;
    EXPECT_TRUE(p.joined()) << "peer " << i;
    EXPECT_EQ(g.nodes[i].session->steps(), 150u) << "peer " << i << " reached the shared stop";
    EXPECT_EQ(p.state_hash(), first.state_hash()) << "peer " << i << " holds the same garment";
    EXPECT_EQ(p.pending(), 0u) << "peer " << i << ": an operation it proposed was never applied";
    EXPECT_TRUE(p.converged()) << "peer " << i << " knows the others agree";
    EXPECT_TRUE(p.divergences().empty()) << "peer " << i << " disagreed at step " << p.divergences()[0].step;
  }
  if (crash_sequencer) {
    EXPECT_NE(first.sequencer(), 100u) << "a new sequencer took over";
    EXPECT_GE(first.epoch(), 2u);
  }
  std::set<UserId> users;
  for (const Operation& op : g.nodes[live[0]].session->journal().operations())
    if (std::holds_alternative<op::ToolInput>(op.data)) users.insert(op.user);
  EXPECT_GE(users.size(), 4u) << "strokes of several users were applied";
}

TEST(Peers, ManySeedsOfEightPeersUnderLossEndBitIdentical) {
  const char* only = std::getenv("KIJI_PEER_SEED");
  const int seeds = std::getenv("KIJI_PEER_SEEDS") ? std::atoi(std::getenv("KIJI_PEER_SEEDS")) : 12;
  if (only) {
    run_seed(std::strtoull(only, nullptr, 10), std::strtoull(only, nullptr, 10) % 3 == 0);
    return;
  }
  for (int seed = 1; seed <= seeds; ++seed) run_seed(static_cast<std::uint64_t>(seed), seed % 3 == 0);
}

TEST(Peers, TwoUsersNeverHoldTheSameClothAndTheRefusedOneIsTold) {
  Group g(7, {}, 2);
  g.base.stop_step = 150;
  g.host_and_join(0.3);
  ASSERT_TRUE(g.nodes[1].peer->joined());
  // Both grab the same corner at once: the order gives it to one, the other is refused.
  Session& a = *g.nodes[0].session;
  Session& b = *g.nodes[1].session;
  const Vec3 corner(-0.3, 0.5, 0);
  const ParamSet params = a.params_for("pinch");
  const Stroke stroke = line(corner, corner + Vec3(0, 0.05, 0.1), 20, 0);
  std::size_t i = 0;
  bool both = false;
  g.run_until(1.0, [&] {
    if (i < stroke.size() && std::fmod(g.net.now(), 0.017) < 0.001) {
      ToolEvent e = stroke[i++];
      e.time = a.time();
      a.apply("pinch", e, &params);
      b.apply("pinch", e, &params);
    }
    both = both || (a.stroke_active(100) && a.stroke_active(101));
  });
  EXPECT_FALSE(both) << "two users held the same cloth";
  const std::size_t refused = g.nodes[0].peer->refusals().size() + g.nodes[1].peer->refusals().size();
  EXPECT_EQ(refused, 1u);
  const auto& r = g.nodes[0].peer->refusals().empty() ? g.nodes[1].peer->refusals() : g.nodes[0].peer->refusals();
  ASSERT_FALSE(r.empty());
  EXPECT_NE(r[0].reason.find("is working there"), std::string::npos) << r[0].reason;
  // Leases expire in simulated time: later, the refused user may work there.
  g.run_until(3.0);
  EXPECT_TRUE(g.nodes[0].peer->leases().empty());
  EXPECT_EQ(a.steps(), 150u);
  EXPECT_EQ(g.nodes[0].peer->state_hash(), g.nodes[1].peer->state_hash());
}

TEST(Peers, ALateJoinerGetsTheStateAndIsInStep) {
  Group g(11, {0.1, 0.05, 0.0002, 0.004}, 3);
  g.base.stop_step = 170;
  g.host_and_join(0.3);
  Session& b = *g.nodes[1].session;
  b.run("pinch", b.params_for("pinch"), line(Vec3(0.3, 0.5, 0), Vec3(0.3, 0.6, 0.1), 8, b.time()));
  g.run_until(1.5);
  g.start(2);
  double joined_at = -1;
  g.run_until(3.5, [&] {
    if (joined_at < 0 && g.nodes[2].peer->joined()) joined_at = g.net.now();
  });
  EXPECT_EQ(g.nodes[2].session->steps(), 170u);
  ASSERT_GT(joined_at, 0) << "the late joiner never got the state";
  EXPECT_LT(joined_at - 1.5, 0.5) << "joining took too long";
  EXPECT_EQ(g.nodes[2].peer->state_hash(), g.nodes[0].peer->state_hash());
  EXPECT_EQ(g.nodes[2].session->garment_count(), 1u);
  EXPECT_GE(g.nodes[0].peer->stats().checkpoints, 1u);
}

TEST(Peers, AStrokeGoingOnPastTheSharedStopIsGivenUpThereAndSaid) {
  // A scripted session stops at step 60; a user's stroke goes on after it. Its later events can
  // never be applied anywhere: they are given up and said, instead of waiting for ever.
  Group g(3, {}, 2);
  g.base.stop_step = 60;
  g.host_and_join(0.3);
  ASSERT_TRUE(g.nodes[1].peer->joined());
  const Stroke stroke = line(Vec3(0.3, 0.5, 0), Vec3(0.3, 0.6, 0.1), 60, 0);
  ASSERT_EQ(g.draw(1, stroke, 2.5), stroke.size());
  for (int n : {0, 1}) {
    EXPECT_EQ(g.nodes[n].session->steps(), 60u);
    EXPECT_EQ(g.nodes[n].peer->pending(), 0u) << "peer " << n << " still waits for changes that cannot come";
    EXPECT_TRUE(g.nodes[n].peer->converged());
  }
  EXPECT_EQ(g.nodes[0].peer->state_hash(), g.nodes[1].peer->state_hash());
  EXPECT_TRUE(g.nodes[0].peer->refusals().empty());
  const auto& r = g.nodes[1].peer->refusals();
  ASSERT_EQ(r.size(), 1u);
  EXPECT_NE(r[0].reason.find("came after the shared clock stopped at step 60 and were not applied"), std::string::npos)
      << r[0].reason;
  // The stroke's first part, before the stop, was applied on both.
  EXPECT_GT(g.nodes[0].peer->applied(), 1u);
}

TEST(Peers, APeerTakenForGoneSaysWhatWasNotAppliedAndJoinsAgain) {
  // A peer that says nothing for longer than silence_seconds (a machine too slow to answer while
  // it loads a large state, a paused process) is taken for gone, and the sequencer orders nothing
  // of it after. Back, the stroke its user drew before it knew is given up and said (it had been
  // sent again for ever and applied nowhere), and it joins again: its next stroke is applied.
  Group g(5, {}, 2);
  g.base.stop_step = 400;
  g.host_and_join(0.3);
  ASSERT_TRUE(g.nodes[1].peer->joined());
  g.nodes[1].started = false;  // it neither hears nor speaks
  g.run_until(1.0);
  g.nodes[1].started = true;
  const std::uint64_t checkpoints_before = g.nodes[0].peer->stats().checkpoints;
  bool back_before_its_end = false;
  // Drawn from its return for a third of a second: past the moment it has joined again (the rest
  // of a stroke cancelled everywhere is given up too, not refused event by event).
  const Stroke unseen = line(Vec3(0.3, 0.5, 0), Vec3(0.3, 0.6, 0.1), 20, 0);
  const auto note_if_back = [&] {
    back_before_its_end = g.nodes[1].peer->joined() && g.nodes[0].peer->stats().checkpoints > checkpoints_before;
  };
  ASSERT_EQ(g.draw(1, unseen, 1.6, note_if_back), unseen.size());
  EXPECT_TRUE(back_before_its_end) << "the stroke was to go on after it had joined again";
  auto strokes_of_peer1 = [&](int node) {
    std::size_t n = 0;
    for (const Operation& op : g.nodes[node].session->journal().operations())
      n += std::holds_alternative<op::ToolInput>(op.data) && op.user == 101u;
    return n;
  };
  EXPECT_EQ(strokes_of_peer1(0), 0u) << "the host applied the stroke drawn while it was taken for gone";
  EXPECT_EQ(g.nodes[1].peer->pending(), 0u) << "the peer still waits for changes that will never be taken";
  const auto& r = g.nodes[1].peer->refusals();
  ASSERT_EQ(r.size(), 1u);
  EXPECT_NE(r[0].reason.find("took this peer for gone"), std::string::npos) << r[0].reason;
  EXPECT_NE(r[0].reason.find(std::to_string(unseen.size()) + " change(s) made until it had joined again, or in the "
                                                           "stroke it cut off, were not applied"),
            std::string::npos)
      << r[0].reason;
  ASSERT_TRUE(g.nodes[1].peer->joined()) << "it did not join again";

  const Stroke seen = line(Vec3(-0.3, 0.5, 0), Vec3(-0.35, 0.6, 0.1), 6, 0);
  ASSERT_EQ(g.draw(1, seen, 2.4), seen.size());
  g.run_until(8.0);
  EXPECT_EQ(strokes_of_peer1(0), seen.size()) << "the stroke drawn after it joined again";
  for (int n : {0, 1}) {
    EXPECT_EQ(g.nodes[n].session->steps(), 400u) << "peer " << n << " reached the shared stop";
    EXPECT_TRUE(g.nodes[n].peer->converged()) << "peer " << n;
  }
  EXPECT_EQ(g.nodes[1].peer->pending(), 0u);
  EXPECT_EQ(g.nodes[1].peer->refusals().size(), 1u);
  EXPECT_EQ(g.nodes[0].peer->state_hash(), g.nodes[1].peer->state_hash());
}

TEST(Peers, ADisagreementIsFoundReportedAndHealed) {
  Group g(5, {}, 2);
  g.base.stop_step = 120;
  g.host_and_join(0.5);
  ASSERT_TRUE(g.nodes[1].peer->converged());
  // A change that bypasses the order (what a bug, or a bit flipped in memory, would do).
  Garment& wrong = g.nodes[1].session->garment(0);
  const Vertex v = *wrong.mesh().vertices().begin();
  wrong.set_position(v, wrong.position(v) + Vec3(0, 0, 0.01));
  g.run_until(2.5);
  ASSERT_FALSE(g.nodes[1].peer->divergences().empty()) << "the disagreement was not found";
  EXPECT_GE(g.nodes[1].peer->stats().heals, 1u);
  EXPECT_EQ(g.nodes[1].peer->state_hash(), g.nodes[0].peer->state_hash()) << "healed from the sequencer's state";
  EXPECT_TRUE(g.nodes[1].peer->converged());
}

TEST(Peers, ForgedReplayedCutOrOversizedMessagesAreDroppedAndCounted) {
  Group g(3, {}, 2);
  g.base.stop_step = 90;
  g.host_and_join(0.3);
  Peer& victim = *g.nodes[1].peer;
  const std::string genuine = g.net.sent().back();
  // Replayed: a message already seen.
  for (const std::string& m : g.net.sent()) victim.receive(m, g.net.now());
  EXPECT_GT(victim.stats().dropped.at("replayed"), 0u);
  // Forged: the right shape with a wrong key, and a flipped bit.
  {
    Session other(plugins());
    SimNetwork net2(1, {});
    net2.add_node();
    PeerOptions o;
    o.key = "another key entirely, not this session's";
    o.host = true;
    o.id = 555;
    Peer forger(other, net2.port(0), o);
    forger.tick(0.0);
    for (const std::string& m : net2.sent()) victim.receive(m, g.net.now());
  }
  std::string flipped = genuine;
  flipped[20] ^= 1;
  victim.receive(flipped, g.net.now());
  EXPECT_GE(victim.stats().dropped.at("forged"), 2u);
  // Cut short, empty, oversized, garbage.
  victim.receive(genuine.substr(0, genuine.size() / 2), g.net.now());
  victim.receive("", g.net.now());
  victim.receive(std::string(70000, 'x'), g.net.now());
  EXPECT_GE(victim.stats().dropped.at("malformed"), 2u);
  EXPECT_GE(victim.stats().dropped.at("oversized"), 1u);
  // And the session goes on, in step.
  g.run_until(2.0);
  EXPECT_EQ(g.nodes[1].session->steps(), 90u);
  EXPECT_EQ(victim.state_hash(), g.nodes[0].peer->state_hash());
}

namespace {
// A transport that keeps what it is given: messages sent, and the keep-alives for each long step.
struct Keeping : PeerTransport {
  std::vector<std::string> sent;
  std::vector<std::pair<std::vector<std::string>, double>> alive;
  void send(const std::string& bytes) override { sent.push_back(bytes); }
  void keep_alive(std::vector<std::string> sealed, double every) override { alive.emplace_back(std::move(sealed), every); }
};
}  // namespace

// A peer's thread is silent while it steps, and a step longer than silence_seconds (a large
// garment on a slow machine, a sanitizer build) made the others take it for gone. Before such a
// step it leaves its transport heartbeats to send during it, each sealed with its own number (a
// copy would be dropped as a replay), and takes them back after.
TEST(Peers, AStepLongerThanAHeartbeatLeavesHeartbeatsToSendWhileItRuns) {
  using kiji::detail::PeerWire;
  using kiji::detail::WireVerdict;
  Session session{plugins()};
  host_garment(session);
  Keeping transport;
  PeerOptions o;
  o.key = kKey;
  o.host = true;
  double clock = 0;
  o.clock = [&] { return clock += 0.25; };  // each reading a quarter of a second on: long steps
  Peer peer(session, transport, o);
  for (int k = 0; k < 12; ++k) peer.tick(clock);
  ASSERT_GE(session.steps(), 4u);
  // A step's keep-alives, then none once it is done, for each step after the first measured one.
  ASSERT_GE(transport.alive.size(), 4u);
  PeerWire other(kKey, 999);
  std::set<std::uint64_t> numbers;
  for (std::size_t k = 0; k < transport.alive.size(); ++k) {
    const auto& [sealed, every] = transport.alive[k];
    if (k % 2 == 1) {
      EXPECT_TRUE(sealed.empty()) << "taken back after the step";
      continue;
    }
    EXPECT_NEAR(every, o.silence_seconds / 3, 1e-12);
    EXPECT_GE(sealed.size(), 2u);
    for (const std::string& m : sealed) {
      kiji::detail::PeerEnvelope env;
      ASSERT_EQ(other.open(m, env), WireVerdict::Ok) << "a keep-alive another peer would not take";
      EXPECT_EQ(env.type, kiji::detail::kHeartbeat);
      EXPECT_EQ(env.sender, peer.id());
      EXPECT_TRUE(numbers.insert(env.seq).second) << "two keep-alives with one number";
    }
  }
}

// A burst of repaired chunks can arrive shuffled by hundreds of messages: each is taken once, and
// only a copy, or a message older than the replay window, is dropped as a replay.
TEST(Peers, MessagesReorderedByHundredsAreTakenOnceAndCopiesAreReplays) {
  using kiji::detail::PeerWire;
  using kiji::detail::WireVerdict;
  PeerWire sender(kKey, 7), receiver(kKey, 8);
  std::vector<std::string> sent;
  for (int k = 0; k < 2600; ++k) sent.push_back(sender.seal(1, 0, "chunk " + std::to_string(k)));
  kiji::detail::PeerEnvelope out;
  ASSERT_EQ(receiver.open(sent[1199], out), WireVerdict::Ok);
  // The 700 before it, last first: 700 messages late, each once.
  for (int k = 1198; k >= 499; --k) ASSERT_EQ(receiver.open(sent[k], out), WireVerdict::Ok) << "message " << k;
  EXPECT_EQ(out.body, "chunk 499");
  for (int k : {1199, 1198, 800, 499}) EXPECT_EQ(receiver.open(sent[k], out), WireVerdict::Replayed) << k;
  EXPECT_EQ(receiver.open(sent[100], out), WireVerdict::Replayed) << "older than the window: cannot be told from a replay";
  // Onwards past the window's end and around it, with gaps filled in late: none is taken for another.
  for (int k = 1200; k < 2600; k += 2) ASSERT_EQ(receiver.open(sent[k], out), WireVerdict::Ok) << k;
  for (int k = 2599; k > 2600 - 1000; k -= 2) ASSERT_EQ(receiver.open(sent[k], out), WireVerdict::Ok) << k;
  for (int k = 2000; k < 2600; ++k) ASSERT_EQ(receiver.open(sent[k], out), WireVerdict::Replayed) << k;
}

TEST(Peers, ASharedSessionsClockIsThePeersAndBadOptionsAreRefused) {
  Session s(plugins());
  SimNetwork net(1, {});
  net.add_node();
  PeerOptions o;
  o.key = "short";
  EXPECT_THROW(Peer(s, net.port(0), o), InputError);
  o.key = kKey;
  o.host = true;
  {
    Peer p(s, net.port(0), o);
    EXPECT_TRUE(s.gated());
    EXPECT_THROW(s.step(), InputError) << "only the peer steps a shared session";
    s.add_garment(make_rectangle(0.2, 0.2, 3, 3));
    EXPECT_EQ(s.garment_count(), 0u) << "proposed, not yet applied";
    p.tick(0.0);
    p.tick(0.02);
    EXPECT_EQ(s.garment_count(), 1u) << "applied in its turn";
  }
  EXPECT_FALSE(s.gated()) << "the session is its user's again";
  s.step();
}

// A peer whose steps take longer than a frame (a large garment) must still hear the others and send
// between steps: catching up after a stall, a tick stops stepping once it has used a frame's time
// on the peer's clock, where without a clock it steps as far as it may.
TEST(Peers, APeerBehindItsClockStepsAFrameATimeSoItsMessagesAreNotHeldUp) {
  auto steps_in_one_tick_after_a_stall = [](bool with_clock) {
    // The clock moves 30 ms between readings: a step longer than a frame.
    LoneHost h(with_clock ? std::optional<double>(0.03) : std::nullopt);
    for (int ms = 0; ms <= 200; ++ms) h.peer->tick(ms * 0.001);
    const std::uint64_t before = h.session.steps();
    h.peer->tick(0.5);  // 300 ms stalled: 18 frames behind
    return h.session.steps() - before;
  };
  EXPECT_EQ(steps_in_one_tick_after_a_stall(true), 1u);
  EXPECT_GT(steps_in_one_tick_after_a_stall(false), 1u);
}

// The sequencer looks ahead lookahead_steps frames' worth of time: on a garment whose steps take
// three frames, an operation applies one step sooner than two steps ahead would make it (at 20,000
// vertices, 0.2 s sooner for every remote stroke and every join).
TEST(Peers, StepsSlowerThanAFrameLookAheadAsFarInTimeNotInSteps) {
  // The steps from an operation made on the host to the step it applied at, with the host's clock
  // moving `reading` seconds between readings (a step's wall time), or with no clock.
  auto steps_to_apply = [](std::optional<double> reading) {
    LoneHost h(reading);
    Session& s = h.session;
    Peer& p = *h.peer;
    int ms = 0;
    for (; ms <= 300; ++ms) p.tick(ms * 0.001);
    const std::uint64_t made = s.steps();
    s.set_simulating(false);
    for (; ms <= 1000 && s.simulating(); ++ms) p.tick(ms * 0.001);
    EXPECT_FALSE(s.simulating()) << "the pause was never applied";
    const Operation& last = s.journal().operations().back();
    EXPECT_TRUE(std::holds_alternative<op::SetSimulating>(last.data));
    return last.step - made;
  };
  EXPECT_EQ(steps_to_apply(std::nullopt), 3u) << "two steps announced free of orders, then the operation";
  EXPECT_EQ(steps_to_apply(0.001), 3u) << "steps faster than a frame: as before";
  EXPECT_EQ(steps_to_apply(0.05), 2u) << "steps of three frames: one step ahead covers two frames";
}

// A joiner that lost many of a large state's chunks asks for all of them in one round (requests
// of 200 chunks each), so it has the state one round trip later, not a round for every 200.
TEST(Peers, AJoinerAsksForEveryLostChunkOfALargeStateInOneRound) {
  // Messages arrive in the order they were sent, so that what stands between the joiner and the
  // state is the loss made here alone (reordering is MessagesReorderedByHundreds...'s test).
  SimNetwork::Faults in_order;
  in_order.min_delay = in_order.max_delay = 0.001;
  Group g(7, in_order, 2);
  {
    Session& s = *g.nodes[0].session;
    host_garment(s);
    Garment big = make_rectangle(1.0, 1.0, 130, 130);  // a snapshot of about 800 chunks
    big.transform(Eigen::Affine3d(Eigen::Translation3d(-0.5, 0.02, 1.0)));
    s.add_garment(big);
  }
  g.start(0);
  g.run_until(0.1);
  g.start(1);
  // Three of every four chunk-sized messages to the joiner are lost until it first asks again.
  std::size_t large = 0, dropped = 0;
  double first_request = -1, had_state = -1;
  while (g.net.now() < 3.0 && had_state < 0) {
    g.net.set_now(g.net.now() + 0.001);
    g.net.deliver([&](int node, const std::string& bytes) {
      if (node == 1 && first_request < 0 && bytes.size() > 900 && large++ % 4 != 0) {
        ++dropped;
        return;
      }
      g.nodes[node].peer->receive(bytes, g.net.now());
    });
    for (int i : {0, 1}) g.nodes[i].peer->tick(g.net.now());
    if (first_request < 0 && g.nodes[1].peer->stats().chunks_asked > 0) first_request = g.net.now();
    if (g.nodes[1].peer->joined()) had_state = g.net.now();
  }
  ASSERT_GT(dropped, 400u) << "the state was too small to need more than two requests of 200 chunks";
  ASSERT_GT(had_state, 0) << "the joiner never had the state";
  EXPECT_LT(had_state - first_request, 0.025) << "the lost chunks came in more than one round of requests";
  EXPECT_EQ(g.nodes[1].peer->stats().chunks_asked, dropped) << "the joiner asked for each lost chunk once";
  EXPECT_EQ(g.nodes[0].peer->stats().chunks_resent, dropped) << "each lost chunk was sent again once";
}
