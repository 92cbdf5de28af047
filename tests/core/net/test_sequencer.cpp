// The sequencer and its election (net/sequencer.h) on the simulated network: proposals from several
// origins, lost, repeated and reordered on the way, are each ordered once and in their origin's
// order; when the sequencer goes silent the live peer with the lowest id takes the role over with
// the next epoch and no proposal is lost; a peer follows a newer term, and of two sequencers of one
// term the higher id steps aside.
#include "net/ordered_log.h"
#include "net/sequencer.h"
#include "support/peer_sim.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <set>

using namespace kiji;
using namespace kiji::detail;
using test::SimNetwork;
using test::SimParts;

namespace {

// A peer reduced to what the sequencer works with: its log, the others as heard, its proposals
// (sent again until ordered) and the orders it applied, in order.
struct Node final : SequencerHost {
  PeerCore& core;
  Members members;
  OrderedLog log;
  Sequencer seq{core, log, members, *this};
  std::uint64_t clock = 0;
  struct Proposal {
    Propose msg;
    bool ordered = false;
    double sent = -1;
  };
  std::map<std::uint64_t, Proposal> pending;
  std::uint64_t next_pseq = 1;
  struct Applied {
    std::uint64_t gseq, exec_step;
    std::uint32_t origin;
    std::uint64_t pseq;
    std::string bytes;
  };
  std::vector<Applied> applied;
  double last_beat = -1;

  explicit Node(PeerCore& c) : core(c) {}

  std::uint64_t steps() const override { return clock; }
  Payload carry(const std::string& bytes) override {
    Payload p;
    p.bytes = bytes;
    return p;
  }
  void acknowledge(std::uint64_t pseq) override {
    if (auto it = pending.find(pseq); it != pending.end()) it->second.ordered = true;
  }
  void new_term() override {
    for (auto& [pseq, p] : pending) p.ordered = false;
  }
  void heartbeat() override {
    Heartbeat h;
    h.name = core.opt.name;
    h.sequencer = seq.is_self();
    h.joined = true;
    h.step = clock;
    h.received = log.received_through();
    h.horizon = seq.is_self() ? seq.announced() : log.horizon();
    h.next = seq.is_self() ? seq.next_number() : log.known_next();
    if (seq.is_self())
      for (const auto& [origin, pseq] : seq.ordered()) h.ordered.emplace_back(origin, pseq);
    core.send(kHeartbeat, encode(h));
    last_beat = core.now;
  }

  void propose(const std::string& what, std::uint64_t desired) {
    Proposal& p = pending[next_pseq];
    p.msg = {next_pseq++, desired, carry(what)};
    send_proposal(p);
  }
  void send_proposal(Proposal& p) {
    p.sent = core.now;
    if (seq.acting()) seq.on_propose(core.id, p.msg);
    else core.send(kPropose, encode(p.msg));
  }

  void receive(const PeerEnvelope& env) {
    Member& m = members.all[env.sender];
    m.heard = core.now;
    if (env.type == kHeartbeat || env.type == kOrder || env.type == kClaim) seq.on_newer_term(env.epoch);
    switch (env.type) {
      case kHeartbeat: {
        const Heartbeat h = decode_heartbeat(env.body);
        m.joined = h.joined;
        m.step = h.step;
        m.received = h.received;
        m.horizon = h.horizon;
        m.sequencer = h.sequencer;
        if (!h.sequencer || !seq.on_heartbeat(env.sender, env.epoch, h)) break;
        log.raise_horizon(h.horizon);
        log.know(h.next);
        for (const auto& [origin, pseq] : h.ordered)
          if (origin == core.id)
            for (auto& [s, p] : pending)
              if (s <= pseq) p.ordered = true;
        break;
      }
      case kPropose: seq.on_propose(env.sender, decode_propose(env.body)); break;
      case kOrder: {
        if (env.epoch < seq.epoch()) break;
        const Order o = decode_order(env.body);
        if (log.receive(o.gseq, {o.exec_step, o.origin, o.pseq, env.epoch, o.payload}) && o.origin == core.id)
          acknowledge(o.pseq);
        break;
      }
      case kNackOrder: {
        const NackOrder n = decode_nack_order(env.body);
        if (n.target != core.id && !(n.target == 0 && seq.is_self())) break;
        for (std::uint64_t g = n.from; g < n.to && g < n.from + OrderedLog::kMaxNackRange; ++g)
          if (const Ordered* o = log.find(g)) core.send(kOrder, encode_order(g, *o));
        break;
      }
      case kClaim:
        if (decode_claim(env.body).epoch > seq.epoch()) heartbeat();
        break;
    }
  }

  void tick(double started) {
    const bool acting = seq.acting();
    if (acting) seq.drop_silent();
    if (last_beat < 0 || core.now - last_beat >= (acting ? 0.01 : 0.02)) heartbeat();
    for (auto& [pseq, p] : pending)
      if (!p.ordered && core.now - p.sent > 0.1) send_proposal(p);
    if (const auto gap = log.gap(core.now)) core.send(kNackOrder, encode(*gap));
    if (!acting) seq.elect(started);
    while (const Ordered* next = log.next()) {
      (void)next;
      const std::uint64_t gseq = log.applied();
      const Ordered o = log.take_next();
      applied.push_back({gseq, o.exec_step, o.origin, o.pseq, o.payload.bytes});
      if (o.origin == core.id) pending.erase(o.pseq);
      log.applied(o);
    }
    if (seq.acting() && std::fmod(core.now + 1e-9, 0.01) < 0.001) {  // the shared clock: a step every 10 ms
      ++clock;
      seq.announce(clock, 2, 0);
    }
  }
};

struct Group {
  SimParts parts;
  std::vector<std::unique_ptr<Node>> nodes;
  Group(std::uint64_t seed, SimNetwork::Faults faults, int n) : parts(seed, faults, n, options()) {
    for (int i = 0; i < n; ++i) {
      nodes.push_back(std::make_unique<Node>(parts.core(i)));
      Node& node = *nodes.back();
      parts[i].epoch = [&node] { return node.seq.epoch(); };
      parts[i].receive = [&node](const PeerEnvelope& env) { node.receive(env); };
      parts[i].tick = [&node] { node.tick(0); };
    }
    nodes[0]->seq.start(0);
  }
  static PeerOptions options() {
    PeerOptions o;
    o.silence_seconds = 0.2;
    o.heartbeat_seconds = 0.02;
    return o;
  }
};

// Every live node applied the same orders; each proposal made is there once, in its origin's order.
void expect_one_order(const Group& g, const std::vector<int>& live,
                      const std::map<std::uint32_t, std::vector<std::string>>& proposed) {
  const auto& first = g.nodes[live[0]]->applied;
  for (int i : live) {
    const auto& a = g.nodes[i]->applied;
    ASSERT_EQ(a.size(), first.size()) << "node " << i;
    for (std::size_t k = 0; k < a.size(); ++k) {
      EXPECT_EQ(a[k].gseq, k);
      EXPECT_EQ(a[k].origin, first[k].origin);
      EXPECT_EQ(a[k].bytes, first[k].bytes) << "node " << i << ", order " << k;
    }
  }
  std::map<std::uint32_t, std::vector<std::string>> got;
  std::uint64_t last_step = 0;
  for (const auto& o : first) {
    EXPECT_GE(o.exec_step, last_step) << "orders apply at steps that never go back";
    last_step = o.exec_step;
    if (o.origin != 0) got[o.origin].push_back(o.bytes);
  }
  for (const auto& [origin, what] : proposed) EXPECT_EQ(got[origin], what) << "origin " << origin;
}

}  // namespace

TEST(Sequencer, EachOriginsProposalsAreOrderedOnceAndInTheirOwnOrder) {
  SimNetwork::Faults faults;
  faults.loss = 0.15;
  faults.duplicate = 0.1;
  faults.max_delay = 0.008;
  Group g(21, faults, 4);
  std::mt19937 rng(21);
  std::map<std::uint32_t, std::vector<std::string>> proposed;
  int made = 0;
  g.parts.run_until(1.5, [&] {
    if (g.parts.now() > 1.0 || rng() % 4 != 0) return;
    const int i = static_cast<int>(rng() % 4);
    const std::string what = "change " + std::to_string(made++) + " of node " + std::to_string(i);
    g.nodes[i]->propose(what, g.nodes[i]->clock + 1);
    proposed[100 + i].push_back(what);
  });
  ASSERT_GT(made, 150);
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(g.nodes[i]->pending.empty()) << "node " << i << " has a proposal not ordered";
  expect_one_order(g, {0, 1, 2, 3}, proposed);
  EXPECT_EQ(g.nodes[0]->seq.epoch(), 1u);
  EXPECT_EQ(g.nodes[3]->seq.holder(), 100u);
}

TEST(Sequencer, ASilentSequencerIsReplacedByTheLowestLiveIdAndNoProposalIsLost) {
  SimNetwork::Faults faults;
  faults.loss = 0.1;
  faults.max_delay = 0.004;
  Group g(22, faults, 4);
  std::mt19937 rng(22);
  std::map<std::uint32_t, std::vector<std::string>> proposed;
  int made = 0;
  g.parts.run_until(2.0, [&] {
    if (std::abs(g.parts.now() - 0.5) < 0.0005) g.parts.net().crash(0);
    if (g.parts.now() > 1.5 || rng() % 8 != 0) return;
    const int i = 1 + static_cast<int>(rng() % 3);
    const std::string what = "change " + std::to_string(made++);
    g.nodes[i]->propose(what, 0);
    proposed[100 + i].push_back(what);
  });
  for (int i : {1, 2, 3}) {
    EXPECT_EQ(g.nodes[i]->seq.holder(), 101u) << "node " << i << " follows the lowest live id";
    EXPECT_EQ(g.nodes[i]->seq.epoch(), 2u) << "node " << i;
    EXPECT_TRUE(g.nodes[i]->pending.empty()) << "node " << i << " has a proposal not ordered";
  }
  EXPECT_TRUE(g.nodes[1]->seq.acting());
  EXPECT_EQ(g.parts.core(1).stats.elections, 1u);
  EXPECT_EQ(g.parts.core(2).stats.elections, 0u);
  expect_one_order(g, {1, 2, 3}, proposed);
  // The new sequencer ordered the old one out.
  bool departed = false;
  for (const auto& o : g.nodes[1]->applied)
    if (o.origin == 0) {
      const PeerOp op = decode_peer_op(o.bytes);
      departed = departed || (op.kind == PeerOp::PeerLeft && op.peer == 100);
    }
  EXPECT_TRUE(departed);
  EXPECT_TRUE(g.nodes[1]->members.left.count(100)) << "and takes no proposal of it";
}

TEST(Sequencer, APeerFollowsANewerTermAndOfTwoSequencersOfOneTermTheHigherIdStepsAside) {
  SimParts parts(23, {}, 1);
  Node n(parts.core(0));  // id 100
  n.propose("mine", 0);
  n.pending.begin()->second.ordered = true;
  Heartbeat h;
  h.sequencer = true;
  h.next = 4;
  // A sequencer of term 1 with a lower id than none: followed.
  EXPECT_TRUE(n.seq.on_heartbeat(105, 1, h));
  EXPECT_EQ(n.seq.holder(), 105u);
  EXPECT_FALSE(n.pending.begin()->second.ordered) << "a new term: proposals go to its sequencer again";
  EXPECT_EQ(n.log.known_next(), 4u);
  // Orders of term 1 past the next term's start were lost with its sequencer.
  Ordered o;
  o.epoch = 1;
  for (std::uint64_t g = 2; g < 6; ++g) n.log.receive(g, o);
  h.next = 3;
  EXPECT_TRUE(n.seq.on_heartbeat(107, 2, h));
  EXPECT_EQ(n.seq.holder(), 107u);
  EXPECT_EQ(n.seq.epoch(), 2u);
  EXPECT_NE(n.log.find(2), nullptr);
  EXPECT_EQ(n.log.find(3), nullptr);
  EXPECT_EQ(n.log.find(5), nullptr);
  // A heartbeat of an older term is not followed.
  EXPECT_FALSE(n.seq.on_heartbeat(101, 1, h));
  EXPECT_EQ(n.seq.holder(), 107u);
  // This peer a sequencer of term 2 too: it steps aside for a lower id, not for a higher one.
  Node m(parts.core(0));
  m.seq.start(0);
  EXPECT_FALSE(m.seq.on_heartbeat(105, 1, h)) << "id 105 is higher than 100";
  EXPECT_TRUE(m.seq.acting());
  Node low(parts.core(0));
  low.core.id = 100;
  low.seq.start(0);
  EXPECT_TRUE(low.seq.on_heartbeat(99, 1, h));
  EXPECT_EQ(low.seq.holder(), 99u);
  EXPECT_FALSE(low.seq.acting());
  // A message of a newer term makes a sequencer step down.
  m.seq.on_newer_term(3);
  EXPECT_FALSE(m.seq.acting());
  EXPECT_EQ(m.seq.holder(), 0u);
}
