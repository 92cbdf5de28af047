// Leases (net/lease_table.h): a tool event leases the cloth around its hit, and another user's
// stroke, edit, undo or lease there is refused with a reason that names the holder; leases end at
// their step and travel in a snapshot. On the simulated network, peers applying the same ordered
// operations grant and refuse the very same.
#include "kiji/error.h"
#include "kiji/pattern.h"
#include "kiji/session.h"
#include "net/lease_table.h"
#include "net/ordered_log.h"
#include "support/peer_sim.h"

#include <gtest/gtest.h>

#include <set>

using namespace kiji;
using namespace kiji::detail;
using test::SimNetwork;
using test::SimParts;

namespace {

// A cloth 0.6 m square standing in the z = 0 plane, its corner at (-0.3, 0.5, 0), without gravity
// (so that it stays where the strokes aim).
void add_cloth(Session& s) {
  Garment g = make_rectangle(0.6, 0.6, 9, 9);
  g.transform(Eigen::Affine3d(Eigen::Translation3d(-0.3, 0.5, 0)));
  s.add_garment(g);
  SolverParams p;
  p.gravity = Vec3::Zero();
  s.set_solver_params(p);
}

// A session, its lease table (leasing 6 cm around a hit for 1.5 s) and the refusals it said.
struct Table {
  Session session;
  std::vector<std::pair<UserId, std::string>> refused;
  LeaseTable leases{session, 0.06, 1.5, [](UserId u) { return "peer " + std::to_string(u); },
                    [this](UserId u, const std::string& why) { refused.emplace_back(u, why); }};
  Table() { add_cloth(session); }
};

Operation tool(UserId user, Phase phase, const Vec3& at) {
  ToolEvent e;
  e.phase = phase;
  e.position = at;
  return {0, user, op::ToolInput{"pinch", {}, e}};
}

const Vec3 kCorner(-0.3, 0.5, 0), kFar(0.3, 1.1, 0);

}  // namespace

TEST(LeaseTable, AToolEventLeasesTheClothAroundItsHitAndAnotherUsersStrokeThereIsRefused) {
  Table t;
  Operation a = tool(1, Phase::Begin, kCorner);
  EXPECT_TRUE(t.leases.admit(1, a));
  const auto held = t.leases.infos();
  ASSERT_EQ(held.size(), 1u);
  EXPECT_EQ(held[0].holder, 1u);
  EXPECT_EQ(held[0].expires, 90u) << "1.5 s at 60 steps a second";
  EXPECT_FALSE(held[0].vertices.empty()) << "the cloth within 6 cm of the corner";
  Operation b = tool(2, Phase::Begin, kCorner + Vec3(0.02, 0.02, 0));
  EXPECT_FALSE(t.leases.admit(2, b));
  ASSERT_EQ(t.refused.size(), 1u);
  EXPECT_EQ(t.refused[0].first, 2u);
  EXPECT_EQ(t.refused[0].second, "the 'pinch' stroke was refused: peer 1 is working there (their lease ends at step 90)");
  // The rest of the refused stroke is dropped without a word, even far away; a new stroke there is not.
  Operation move = tool(2, Phase::Move, kFar), cancel = tool(2, Phase::Cancel, kFar);
  EXPECT_FALSE(t.leases.admit(2, move));
  EXPECT_FALSE(t.leases.admit(2, cancel));
  Operation elsewhere = tool(2, Phase::Begin, kFar);
  EXPECT_TRUE(t.leases.admit(2, elsewhere));
  EXPECT_EQ(t.refused.size(), 1u);
  EXPECT_EQ(t.leases.infos().size(), 2u);
  // A user's own lease never stands in its way.
  Operation again = tool(1, Phase::Move, kCorner);
  EXPECT_TRUE(t.leases.admit(1, again));
}

TEST(LeaseTable, AnEditUndoOrRedoOfClothAnotherUserHoldsIsRefused) {
  Table t;
  Operation a = tool(1, Phase::Begin, kCorner);
  ASSERT_TRUE(t.leases.admit(1, a));
  Operation edit{0, 2, op::SetGarment{0, nullptr}}, remove{0, 2, op::RemoveGarment{0}}, undo{0, 2, op::Undo{}},
      redo{0, 2, op::Redo{}}, pause{0, 2, op::SetSimulating{false}};
  EXPECT_FALSE(t.leases.admit(2, edit));
  EXPECT_FALSE(t.leases.admit(2, remove));
  EXPECT_FALSE(t.leases.admit(2, undo));
  EXPECT_FALSE(t.leases.admit(2, redo));
  EXPECT_TRUE(t.leases.admit(2, pause)) << "a setting is no edit of cloth";
  ASSERT_EQ(t.refused.size(), 4u);
  EXPECT_EQ(t.refused[0].second, "an edit of garment 0 was refused: peer 1 is working there (their lease ends at step 90)");
  EXPECT_EQ(t.refused[1].second.rfind("removing of garment 0 was refused: peer 1", 0), 0u);
  EXPECT_EQ(t.refused[2].second.rfind("undo of garment 0 was refused", 0), 0u);
  EXPECT_EQ(t.refused[3].second.rfind("redo of garment 0 was refused", 0), 0u);
  Operation own{0, 1, op::Undo{}};
  EXPECT_TRUE(t.leases.admit(1, own));
}

TEST(LeaseTable, ALeaseAskedForOutrightIsGrantedOrRefusedSayingWhy) {
  Table t;
  t.leases.lease(1, 0, kCorner, 0.05, 2.0);
  ASSERT_EQ(t.leases.infos().size(), 1u);
  EXPECT_EQ(t.leases.infos()[0].expires, 120u);
  t.leases.lease(2, 0, kCorner + Vec3(0.03, 0, 0), 0.05, 1.0);
  t.leases.lease(2, 5, kCorner, 0.05, 1.0);
  ASSERT_EQ(t.refused.size(), 2u);
  EXPECT_EQ(t.refused[0].second, "the lease was refused: peer 1 holds cloth there");
  EXPECT_EQ(t.refused[1].second, "a lease on garment 5, which does not exist");
  t.leases.release(1);
  t.leases.lease(2, 0, kCorner, 0.05, 1.0);
  EXPECT_EQ(t.refused.size(), 2u) << "free once released";
  t.leases.forget(2);
  EXPECT_TRUE(t.leases.infos().empty());
}

TEST(LeaseTable, LeasesEndAtTheirStepAndTravelInASnapshot) {
  Table t;
  Operation a = tool(1, Phase::Begin, kCorner), b = tool(2, Phase::Begin, kFar);
  ASSERT_TRUE(t.leases.admit(1, a));
  for (int i = 0; i < 30; ++i) t.session.step();
  ASSERT_TRUE(t.leases.admit(2, b));
  const std::string bytes = t.leases.encode();
  Table other;
  other.leases.decode(bytes);
  EXPECT_EQ(other.leases.encode(), bytes);
  EXPECT_EQ(other.leases.infos().size(), 2u);
  // Cut short or with a byte more, a snapshot's table is refused, saying so.
  try {
    other.leases.decode(bytes.substr(0, bytes.size() - 1));
    ADD_FAILURE() << "a table cut short was read";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("the leases of a snapshot is malformed at byte ", 0), 0u) << e.what();
  }
  EXPECT_THROW(other.leases.decode(bytes + "x"), InputError);
  EXPECT_EQ(other.leases.encode(), bytes) << "a table refused leaves the one there";
  for (int i = 0; i < 60; ++i) t.session.step();
  t.leases.expire();
  ASSERT_EQ(t.leases.infos().size(), 1u) << "user 1's ended at step 90";
  EXPECT_EQ(t.leases.infos()[0].holder, 2u);
}

// A sequencer orders the strokes and leases of three users, on a network that loses and reorders:
// each peer applies the order into its own table, and every peer grants and refuses the same.
TEST(LeaseTable, PeersApplyingTheSameOrderGrantAndRefuseTheSame) {
  SimNetwork::Faults faults;
  faults.loss = 0.2;
  faults.max_delay = 0.005;
  SimParts parts(13, faults, 3);
  std::vector<std::unique_ptr<Table>> tables;
  std::vector<OrderedLog> logs(3);
  std::vector<std::vector<std::string>> after(3);  // each table's bytes after each order
  for (int i = 0; i < 3; ++i) tables.push_back(std::make_unique<Table>());
  auto apply = [&](int i, const Ordered& o) {
    const PeerOp pop = decode_peer_op(o.payload.bytes);
    LeaseTable& t = tables[i]->leases;
    if (pop.kind == PeerOp::Session) {
      Operation op = decode_operation(pop.operation);
      t.admit(o.origin, op);
    }
    if (pop.kind == PeerOp::Lease) t.lease(o.origin, pop.garment, pop.center, pop.radius, pop.seconds);
    if (pop.kind == PeerOp::Release) t.release(o.origin);
    if (pop.kind == PeerOp::PeerLeft) t.forget(pop.peer);
    after[i].push_back(t.encode());
  };
  std::vector<std::pair<UserId, PeerOp>> ops;
  auto stroke = [&](UserId user, Phase phase, const Vec3& at) {
    PeerOp pop;
    pop.operation = encode_operation(tool(user, phase, at));
    ops.emplace_back(user, pop);
  };
  stroke(1, Phase::Begin, kCorner);
  stroke(2, Phase::Begin, kCorner + Vec3(0.01, 0, 0));
  stroke(1, Phase::Move, kCorner + Vec3(0.05, 0.05, 0));
  stroke(2, Phase::Move, kCorner);
  stroke(3, Phase::Begin, kFar);
  PeerOp lease;
  lease.kind = PeerOp::Lease;
  lease.center = kCorner + Vec3(0.3, 0.3, 0);  // the middle, which no stroke touched
  lease.radius = 0.05;
  lease.seconds = 1;
  ops.emplace_back(3, lease);
  ops.emplace_back(2, lease);
  PeerOp release;
  release.kind = PeerOp::Release;
  ops.emplace_back(1, release);
  stroke(2, Phase::Begin, kCorner);
  PeerOp left;
  left.kind = PeerOp::PeerLeft;
  left.peer = 3;
  ops.emplace_back(0, left);
  stroke(1, Phase::Begin, kFar);

  for (int i = 1; i < 3; ++i) {
    parts[i].receive = [&, i](const PeerEnvelope& env) {
      if (env.type == kOrder) {
        const Order o = decode_order(env.body);
        logs[i].receive(o.gseq, {o.exec_step, o.origin, o.pseq, env.epoch, o.payload});
      }
      if (env.type == kHeartbeat) logs[i].know(decode_heartbeat(env.body).next);
    };
    parts[i].tick = [&, i] {
      if (const auto gap = logs[i].gap(parts.now())) parts.core(i).send(kNackOrder, encode(*gap));
      while (logs[i].next()) {
        const Ordered o = logs[i].take_next();
        apply(i, o);
        logs[i].applied(o);
      }
    };
  }
  parts[0].receive = [&](const PeerEnvelope& env) {
    if (env.type != kNackOrder) return;
    const NackOrder n = decode_nack_order(env.body);
    for (std::uint64_t g = n.from; g < n.to; ++g)
      if (const Ordered* o = logs[0].find(g)) parts.core(0).send(kOrder, encode_order(g, *o));
  };
  std::size_t next = 0;
  parts[0].tick = [&] {
    if (next < ops.size()) {
      Ordered o;
      o.origin = ops[next].first;
      o.pseq = next + 1;
      o.payload.bytes = encode(ops[next].second);
      logs[0].place(next, o);
      logs[0].set_known_next(next + 1);
      parts.core(0).send(kOrder, encode_order(next, o));
      apply(0, logs[0].take_next());
      logs[0].applied(o);
      ++next;
    }
    Heartbeat h;
    h.next = logs[0].known_next();
    parts.core(0).send(kHeartbeat, encode(h));
  };
  ASSERT_TRUE(parts.run_while_not([&] { return after[1].size() == ops.size() && after[2].size() == ops.size(); }, 2.0));
  for (int i : {1, 2}) {
    EXPECT_EQ(after[i], after[0]) << "peer " << i << "'s table, order by order";
    EXPECT_EQ(tables[i]->refused, tables[0]->refused) << "peer " << i;
  }
  // What was decided: user 2's stroke at user 1's corner refused (and its move dropped), the second
  // lease on user 3's cloth refused, the corner free after user 1's release, user 3's leases gone.
  ASSERT_EQ(tables[0]->refused.size(), 2u);
  EXPECT_EQ(tables[0]->refused[0].first, 2u);
  EXPECT_EQ(tables[0]->refused[1].second, "the lease was refused: peer 3 holds cloth there");
  std::set<UserId> holders;
  for (const LeaseInfo& l : tables[0]->leases.infos()) holders.insert(l.holder);
  EXPECT_EQ(holders, (std::set<UserId>{1, 2}));
}
