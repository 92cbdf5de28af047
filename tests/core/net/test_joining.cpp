// Joining (net/joining.h) on the simulated network: a joiner asks until it is offered the state
// shipped at its checkpoint, gathers it through a lossy network and has exactly what was shipped;
// requests within a few milliseconds share one checkpoint; a join waits for strokes in progress (up
// to two seconds); the sequencer offers a state again until its peer is in, and its clock waits at
// the checkpoint meanwhile.
#include "net/joining.h"
#include "support/peer_sim.h"

#include <gtest/gtest.h>

#include <random>

using namespace kiji;
using namespace kiji::detail;
using test::SimNetwork;
using test::SimParts;

namespace {

std::string noise(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::string s(n, '\0');
  for (char& c : s) c = static_cast<char>(rng());
  return s;
}

// Node 0 is the sequencer, at step 40, with a state to ship; the others join. A checkpoint is
// ordered and applied at once (its number counts up from 10).
struct Joins {
  SimParts parts;
  std::vector<Members> members;
  std::vector<std::unique_ptr<ChunkedTransfer>> transfer;
  std::vector<std::unique_ptr<Joining>> joining;
  std::vector<bool> joined;
  std::vector<std::uint64_t> loaded_at;  // the checkpoint each joiner loaded
  std::vector<Snapshot> loaded;
  std::vector<std::vector<std::uint32_t>> checkpoints;  // the targets of each, in order
  Snapshot state{noise(150'000, 1), "the leases"};
  bool strokes = false;
  std::size_t offers_sent = 0;

  Joins(SimNetwork::Faults faults, int n)
      : parts(31, faults, n), members(n), joined(n, false), loaded_at(n, 0), loaded(n) {
    joined[0] = true;
    for (int i = 0; i < n; ++i) {
      transfer.push_back(std::make_unique<ChunkedTransfer>(parts.core(i)));
      joining.push_back(std::make_unique<Joining>(parts.core(i), members[i], *transfer.back()));
    }
    parts[0].receive = [this](const PeerEnvelope& env) {
      Member& m = members[0].all[env.sender];
      m.heard = parts.now();
      if (env.type == kJoin) {
        m.name = decode_name(env.body);
        m.joined = false;
        joining[0]->on_request(env.sender, true);
      }
      if (env.type == kHeartbeat) {
        const Heartbeat h = decode_heartbeat(env.body);
        m.joined = h.joined;
        m.received = h.received;
      }
      if (env.type == kBlobNack) transfer[0]->on_nack(decode_blob_nack(env.body), true);
    };
    parts[0].tick = [this] {
      if (joining[0]->checkpoint_due(strokes)) {
        const std::vector<std::uint32_t> targets = joining[0]->gather();
        const std::uint64_t gseq = 10 + checkpoints.size();
        checkpoints.push_back(targets);
        joining[0]->checkpoint_applied(targets);
        joining[0]->ship(gseq, targets, 40, state);
      }
      joining[0]->offer_again();
      transfer[0]->send_chunks();
    };
    for (int i = 1; i < n; ++i) {
      parts[i].receive = [this, i](const PeerEnvelope& env) {
        if (env.type == kState) {
          ++offers_sent;
          joining[i]->on_offer(decode_state_offer(env.body), joined[i]);
        }
        if (env.type == kBlobChunk) transfer[i]->on_chunk(decode_blob_chunk(env.body));
      };
      parts[i].tick = [this, i] {
        transfer[i]->ask_for_missing();
        if (!joined[i]) {
          joining[i]->ask();
          if (auto offered = joining[i]->take()) {
            loaded_at[i] = offered->first;
            loaded[i] = std::move(offered->second);
            joining[i]->forget_offer();
            joined[i] = true;
          }
        }
        if (std::fmod(parts.now() + 1e-9, 0.02) < 0.001) {
          Heartbeat h;
          h.joined = joined[i];
          h.received = joined[i] ? loaded_at[i] + 1 : 0;
          parts.core(i).send(kHeartbeat, encode(h));
        }
      };
    }
  }
};

}  // namespace

TEST(Joining, AJoinerGetsTheStateShippedAtItsCheckpointThroughALossyNetwork) {
  SimNetwork::Faults faults;
  faults.loss = 0.2;
  faults.duplicate = 0.05;
  faults.max_delay = 0.005;
  Joins j(faults, 2);
  ASSERT_TRUE(j.parts.run_while_not([&] { return j.joined[1]; }, 2.0)) << "the joiner never had the state";
  ASSERT_EQ(j.checkpoints.size(), 1u);
  EXPECT_EQ(j.checkpoints[0], std::vector<std::uint32_t>{101});
  EXPECT_EQ(j.loaded_at[1], 10u);
  EXPECT_EQ(j.loaded[1].state, j.state.state) << "exactly the state shipped";
  EXPECT_EQ(j.loaded[1].leases, j.state.leases);
  EXPECT_GT(j.parts.core(1).stats.chunks_asked, 0u) << "lost chunks were asked for";
  EXPECT_EQ(j.joining[0]->slowest(50), 40u) << "the clock waits at the checkpoint until the peer is in";
  // Once its heartbeat says it is in, the state is offered no more and the clock goes on.
  j.parts.run_until(j.parts.now() + 0.2);
  const std::size_t offers = j.offers_sent;
  j.parts.run_until(j.parts.now() + 0.3);
  EXPECT_EQ(j.offers_sent, offers);
  EXPECT_EQ(j.joining[0]->slowest(50), 50u);
  EXPECT_EQ(j.checkpoints.size(), 1u) << "a peer in asks no more";
}

TEST(Joining, PeersAskingWithinAFewMillisecondsShareOneCheckpoint) {
  SimNetwork::Faults in_order;
  in_order.min_delay = in_order.max_delay = 0.001;
  Joins j(in_order, 5);
  std::vector<bool> started = {true, true, true, true, false};
  for (int i = 1; i < 5; ++i) {
    auto tick = j.parts[i].tick;
    j.parts[i].tick = [&, tick, i] {
      if (i == 4 && j.parts.now() >= 0.5) started[4] = true;
      if (started[i]) tick();
    };
  }
  ASSERT_TRUE(j.parts.run_while_not([&] { return j.joined[1] && j.joined[2] && j.joined[3] && j.joined[4]; }, 2.0));
  ASSERT_EQ(j.checkpoints.size(), 2u);
  EXPECT_EQ(j.checkpoints[0], (std::vector<std::uint32_t>{101, 102, 103})) << "one checkpoint for three";
  EXPECT_EQ(j.checkpoints[1], std::vector<std::uint32_t>{104}) << "a later one its own";
  for (int i = 1; i < 4; ++i) EXPECT_EQ(j.loaded_at[i], 10u);
  EXPECT_EQ(j.loaded_at[4], 11u);
}

TEST(Joining, AJoinWaitsForStrokesInProgressButNotForMoreThanTwoSeconds) {
  SimNetwork::Faults in_order;
  in_order.min_delay = in_order.max_delay = 0.001;
  Joins j(in_order, 2);
  j.strokes = true;
  j.parts.run_until(1.9);
  EXPECT_TRUE(j.checkpoints.empty()) << "a checkpoint would cancel the strokes in progress";
  ASSERT_TRUE(j.parts.run_while_not([&] { return j.joined[1]; }, 0.5));
  EXPECT_GE(j.parts.now(), 2.0);
  // Without strokes, 20 ms after the first request.
  Joins k(in_order, 2);
  k.parts.run_until(0.05);
  EXPECT_EQ(k.checkpoints.size(), 1u);
}

TEST(Joining, AnOfferForAnotherPeerOrOfAnOlderCheckpointIsNotTaken) {
  SimParts parts(32, {}, 2);
  Members members;
  ChunkedTransfer transfer(parts.core(1));
  Joining joiner(parts.core(1), members, transfer);  // id 101
  const std::string packed = deflate_bytes(encode(Snapshot{"state at 12", "leases"}));
  joiner.on_offer({102, 12, hash_bytes(packed), static_cast<std::uint32_t>(packed.size())}, false);
  transfer.publish(hash_bytes(packed), packed);
  EXPECT_FALSE(joiner.take()) << "for another peer";
  joiner.on_offer({101, 12, hash_bytes(packed), static_cast<std::uint32_t>(packed.size())}, true);
  EXPECT_FALSE(joiner.take()) << "this peer is in already";
  joiner.on_offer({101, 12, hash_bytes(packed), static_cast<std::uint32_t>(packed.size())}, false);
  joiner.on_offer({101, 11, 77, 100}, false);
  auto offered = joiner.take();
  ASSERT_TRUE(offered) << "the offer of checkpoint 12 stands";
  EXPECT_EQ(offered->first, 12u);
  EXPECT_EQ(offered->second.state, "state at 12");
  joiner.forget_offer();
  EXPECT_FALSE(joiner.take());
}
