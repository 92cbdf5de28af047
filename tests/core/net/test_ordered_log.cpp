// The ordered log (net/ordered_log.h): orders arriving out of turn and twice are kept once and
// applied in turn; on the simulated network a follower that lost orders asks for each gap and is
// answered from the sequencer's log, and ends with every order, in order.
#include "net/ordered_log.h"
#include "support/peer_sim.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace kiji;
using namespace kiji::detail;
using test::SimNetwork;
using test::SimParts;

namespace {

Ordered order(std::uint64_t exec_step, std::uint64_t pseq, std::uint64_t epoch = 1) {
  Ordered o;
  o.exec_step = exec_step;
  o.origin = 7;
  o.pseq = pseq;
  o.epoch = epoch;
  o.payload.bytes = "operation " + std::to_string(pseq);
  return o;
}

}  // namespace

TEST(OrderedLog, OrdersOutOfTurnAndTwiceAreKeptOnceAndAppliedInTurn) {
  OrderedLog log;
  EXPECT_TRUE(log.receive(2, order(5, 3)));
  EXPECT_TRUE(log.receive(0, order(4, 1)));
  EXPECT_FALSE(log.receive(0, order(4, 99))) << "a copy";
  EXPECT_EQ(log.received_through(), 1u) << "order 1 is missing";
  EXPECT_EQ(log.known_next(), 3u) << "orders up to 2 exist";
  ASSERT_NE(log.next(), nullptr);
  EXPECT_EQ(log.next()->pseq, 1u) << "the first copy was kept";
  const Ordered first = log.take_next();
  log.applied(first);
  EXPECT_EQ(log.applied(), 1u);
  EXPECT_EQ(log.next(), nullptr) << "order 1 has not come";
  EXPECT_FALSE(log.receive(0, order(4, 1))) << "applied already";
  ASSERT_NE(log.find(0), nullptr) << "kept to repair others";
  EXPECT_TRUE(log.receive(1, order(4, 2)));
  EXPECT_EQ(log.received_through(), 3u);
  for (std::uint64_t pseq : {2u, 3u}) {
    ASSERT_NE(log.next(), nullptr);
    const Ordered o = log.take_next();
    EXPECT_EQ(o.pseq, pseq);
    log.applied(o);
  }
  EXPECT_EQ(log.applied(), 3u);
}

TEST(OrderedLog, ANewTermOrAStateLoadedDropsWhatItReplaces) {
  OrderedLog log;
  for (std::uint64_t g = 0; g < 6; ++g) log.receive(g, order(10 + g, g + 1, g < 4 ? 1 : 2));
  // A new sequencer starting at 3 of term 2: term 1's orders from 3 on were lost with the old one.
  log.drop_older_terms(3, 2);
  EXPECT_NE(log.find(2), nullptr);
  EXPECT_EQ(log.find(3), nullptr);
  EXPECT_NE(log.find(4), nullptr) << "term 2's own";
  // This peer takes the role at 5: what it received from there on goes.
  log.drop_from(5);
  EXPECT_EQ(log.find(5), nullptr);
  // A state taken at order 3 is loaded: the next to apply is 4, and nothing older is kept.
  log.applied(log.take_next());
  log.start_after(3);
  EXPECT_EQ(log.applied(), 4u);
  EXPECT_EQ(log.find(0), nullptr);
  EXPECT_EQ(log.find(2), nullptr);
  ASSERT_NE(log.next(), nullptr);
  EXPECT_EQ(log.next()->pseq, 5u);
}

TEST(OrderedLog, AppliedOrdersAreKeptUpToALimit) {
  OrderedLog log;
  const std::uint64_t n = OrderedLog::kKeepApplied + 10;
  for (std::uint64_t g = 0; g < n; ++g) {
    log.receive(g, order(g, g + 1));
    log.applied(log.take_next());
  }
  EXPECT_EQ(log.kept().size(), OrderedLog::kKeepApplied);
  EXPECT_EQ(log.find(9), nullptr);
  EXPECT_NE(log.find(10), nullptr);
}

// A sequencer sends 400 orders once each, under loss; it says how many exist in its heartbeats. The
// follower asks for every gap (at most 64 orders a request, one request every 30 ms) and the
// sequencer answers from its log: the follower applies all of them, in order.
TEST(OrderedLog, AFollowerAsksForEachGapAndIsAnsweredFromTheSequencersLog) {
  SimNetwork::Faults faults;
  faults.loss = 0.3;
  faults.duplicate = 0.1;
  faults.max_delay = 0.008;
  SimParts parts(9, faults, 2);
  OrderedLog seq, follower;
  std::vector<std::uint64_t> applied;
  std::size_t requests = 0;
  parts[0].receive = [&](const PeerEnvelope& env) {
    if (env.type != kNackOrder) return;
    const NackOrder n = decode_nack_order(env.body);
    ++requests;
    for (std::uint64_t g = n.from; g < n.to && g < n.from + OrderedLog::kMaxNackRange; ++g)
      if (const Ordered* o = seq.find(g)) parts.core(0).send(kOrder, encode_order(g, *o));
  };
  parts[1].receive = [&](const PeerEnvelope& env) {
    if (env.type == kOrder) {
      const Order o = decode_order(env.body);
      follower.receive(o.gseq, {o.exec_step, o.origin, o.pseq, env.epoch, o.payload});
    }
    if (env.type == kHeartbeat) follower.know(decode_heartbeat(env.body).next);
  };
  parts[1].tick = [&] {
    if (const auto gap = follower.gap(parts.now())) parts.core(1).send(kNackOrder, encode(*gap));
    while (follower.next()) {
      const Ordered o = follower.take_next();
      applied.push_back(o.pseq);
      follower.applied(o);
    }
  };
  std::uint64_t next = 0;
  parts[0].tick = [&] {
    for (int k = 0; k < 2 && next < 400; ++k, ++next) {  // two orders a millisecond
      seq.place(next, order(next, next + 1));
      seq.set_known_next(next + 1);
      parts.core(0).send(kOrder, encode_order(next, *seq.find(next)));
    }
    if (std::fmod(parts.now(), 0.02) < 0.001) {
      Heartbeat h;
      h.next = seq.known_next();
      parts.core(0).send(kHeartbeat, encode(h));
    }
  };
  ASSERT_TRUE(parts.run_while_not([&] { return applied.size() == 400; }, 3.0))
      << applied.size() << " of 400 orders applied";
  for (std::uint64_t i = 0; i < 400; ++i) ASSERT_EQ(applied[i], i + 1) << "in order";
  EXPECT_EQ(follower.received_through(), 400u);
  EXPECT_GT(requests, 3u) << "lost orders were asked for";
  EXPECT_LT(requests, 200u) << "at most one request every 30 ms";
}
