// Chunked transfer (net/chunked_transfer.h) on the simulated network: a blob crosses a network that
// loses, repeats and reorders messages whole, its lost chunks asked for again; a chunk that is not
// what its sender meant starts the blob again; only the blob's publisher or the sequencer answers
// requests for chunks.
#include "net/chunked_transfer.h"
#include "support/peer_sim.h"

#include <gtest/gtest.h>

#include <random>

using namespace kiji;
using namespace kiji::detail;
using test::SimNetwork;
using test::SimParts;

namespace {

// Bytes that deflate little: a blob of many chunks.
std::string noise(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::string s(n, '\0');
  for (char& c : s) c = static_cast<char>(rng());
  return s;
}

// Each node's transfer on the network: chunks and requests go to it, and each tick it asks for
// what stopped coming and sends what is queued.
struct Transfers {
  SimParts parts;
  std::vector<std::unique_ptr<ChunkedTransfer>> at;
  std::vector<bool> sequencer;

  Transfers(std::uint64_t seed, SimNetwork::Faults faults, int n) : parts(seed, faults, n), sequencer(n, false) {
    for (int i = 0; i < n; ++i) {
      at.push_back(std::make_unique<ChunkedTransfer>(parts.core(i)));
      ChunkedTransfer& t = *at.back();
      parts[i].receive = [&t, this, i](const PeerEnvelope& env) {
        if (env.type == kBlobChunk) t.on_chunk(decode_blob_chunk(env.body));
        if (env.type == kBlobNack) t.on_nack(decode_blob_nack(env.body), sequencer[i]);
      };
      parts[i].tick = [&t] {
        t.ask_for_missing();
        t.send_chunks();
      };
    }
  }
};

}  // namespace

TEST(ChunkedTransfer, SmallBytesGoInlineAndLargeOnesAsABlobThatInflatesToThem) {
  SimParts parts(1, {}, 1);
  ChunkedTransfer t(parts.core(0));
  const Payload small = t.carry("a few bytes");
  EXPECT_FALSE(small.blob);
  std::string inflated;
  EXPECT_EQ(*t.bytes(small, inflated), "a few bytes");
  const std::string large = noise(5000, 1) + std::string(20000, 'x');
  const Payload blob = t.carry(large);
  ASSERT_TRUE(blob.blob);
  EXPECT_LT(blob.size, large.size()) << "deflated";
  ASSERT_NE(t.complete(blob.hash), nullptr);
  EXPECT_EQ(hash_bytes(*t.complete(blob.hash)), blob.hash);
  EXPECT_EQ(*t.bytes(blob, inflated), large);
  Payload unknown = blob;
  unknown.hash ^= 1;
  EXPECT_EQ(t.bytes(unknown, inflated), nullptr) << "a blob not here yet";
}

TEST(ChunkedTransfer, ABlobCrossesALossyReorderingNetworkWholeItsLostChunksAskedForAgain) {
  SimNetwork::Faults faults;
  faults.loss = 0.2;
  faults.duplicate = 0.05;
  faults.max_delay = 0.006;
  Transfers n(3, faults, 3);
  const std::string packed = noise(300'000, 2);  // 300 chunks
  const std::uint64_t hash = hash_bytes(packed);
  n.at[0]->publish(hash, packed);
  n.at[1]->want(hash, static_cast<std::uint32_t>(packed.size()));
  n.at[2]->want(hash, static_cast<std::uint32_t>(packed.size()));
  ASSERT_TRUE(n.parts.run_while_not([&] { return n.at[1]->complete(hash) && n.at[2]->complete(hash); }, 2.0))
      << "the blob did not arrive whole within 2 s";
  EXPECT_EQ(*n.at[1]->complete(hash), packed);
  EXPECT_EQ(*n.at[2]->complete(hash), packed);
  for (int i : {1, 2}) {
    const PeerStats& s = n.parts.core(i).stats;
    EXPECT_GT(s.chunks_asked, 30u) << "about a fifth of 300 chunks was lost on the way to node " << i;
    EXPECT_LT(s.chunks_asked, 150u) << "node " << i << " asked only for what it lacked";
  }
  EXPECT_GT(n.parts.core(0).stats.chunks_resent, 0u);
  EXPECT_EQ(n.parts.core(1).stats.chunks_resent, 0u) << "a receiver does not answer requests";
}

TEST(ChunkedTransfer, AChunkThatIsNotWhatItsSenderMeantStartsTheBlobAgain) {
  SimNetwork::Faults in_order;
  in_order.min_delay = in_order.max_delay = 0.001;
  Transfers n(4, in_order, 3);
  const std::string packed = noise(4500, 3);  // 5 chunks
  const std::uint64_t hash = hash_bytes(packed);
  n.at[1]->want(hash, static_cast<std::uint32_t>(packed.size()));
  // Node 2, a member of the session, sends every chunk first, one of them wrong.
  std::string wrong = packed;
  wrong[2100] ^= 1;
  for (std::uint32_t i = 0; i < 5; ++i) {
    BlobChunk c{hash, static_cast<std::uint32_t>(packed.size()), i, 5,
                wrong.substr(std::size_t(i) * kBlobChunkBytes, kBlobChunkBytes)};
    n.parts.core(2).send(kBlobChunk, encode(c));
  }
  n.parts.run_until(0.01);
  EXPECT_EQ(n.at[1]->complete(hash), nullptr);
  EXPECT_EQ(n.parts.core(1).stats.dropped.at("blob hash"), 1u);
  // The publisher has it right: asked again, it sends every chunk, and the blob is whole.
  n.at[0]->publish(hash, packed);
  ASSERT_TRUE(n.parts.run_while_not([&] { return n.at[1]->complete(hash) != nullptr; }, 1.0));
  EXPECT_EQ(*n.at[1]->complete(hash), packed);
}

TEST(ChunkedTransfer, OnlyThePublisherOrTheSequencerAnswersARequestForChunks) {
  SimNetwork::Faults in_order;
  in_order.min_delay = in_order.max_delay = 0.001;
  Transfers n(5, in_order, 3);
  const std::string packed = noise(2500, 4);
  const std::uint64_t hash = hash_bytes(packed);
  n.at[0]->publish(hash, packed);
  n.at[1]->want(hash, 2500);
  ASSERT_TRUE(n.parts.run_while_not([&] { return n.at[1]->complete(hash) != nullptr; }, 1.0));
  // Node 1 holds the blob, which it did not publish: a request is not its to answer...
  const BlobNack ask{hash, {0, 1, 2}};
  n.at[1]->on_nack(ask, false);
  n.at[1]->send_chunks();
  EXPECT_EQ(n.parts.core(1).stats.chunks_resent, 0u);
  // ...unless it is the sequencer. Chunks past the blob's end are not sent.
  n.at[1]->on_nack({hash, {0, 1, 2, 3, 400}}, true);
  EXPECT_EQ(n.parts.core(1).stats.chunks_resent, 3u);
  // A chunk asked for again while it waits its turn is queued once.
  n.at[1]->on_nack(ask, true);
  EXPECT_EQ(n.parts.core(1).stats.chunks_resent, 3u);
  const std::uint64_t sent = n.parts.core(1).stats.sent;
  n.at[1]->send_chunks();
  EXPECT_EQ(n.parts.core(1).stats.sent - sent, 3u);
}
