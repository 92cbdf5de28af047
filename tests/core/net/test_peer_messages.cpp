// The bodies of the peer protocol's messages (net/peer_messages.h): those an earlier build saved
// (tests/fixtures/saved/) decode, and encode again to the same bytes, and this build writes each
// message as that build did; bytes cut short, left over or out of range are refused, saying which
// message, where and what.
#include "kiji/error.h"
#include "net/peer_messages.h"
#include "support/wire_samples.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

using namespace kiji;
using namespace kiji::detail;

namespace {

bool starts(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

// Decodes a saved message as the message its name says, and encodes what was read.
std::string reencode(const std::string& name, std::string_view bytes) {
  if (starts(name, "heartbeat")) return encode(decode_heartbeat(bytes));
  if (starts(name, "propose")) return encode(decode_propose(bytes));
  if (starts(name, "order")) return encode(decode_order(bytes));
  if (name == "nack_order") return encode(decode_nack_order(bytes));
  if (starts(name, "blob_chunk")) return encode(decode_blob_chunk(bytes));
  if (name == "blob_nack") return encode(decode_blob_nack(bytes));
  if (name == "hash") return encode(decode_hash(bytes));
  if (name == "presence") return encode_presence(decode_presence(bytes));
  if (name == "claim") return encode(decode_claim(bytes));
  if (name == "state_offer") return encode(decode_state_offer(bytes));
  if (name == "join") return encode_name(decode_name(bytes));
  if (starts(name, "peer_op_")) return encode(decode_peer_op(bytes));
  throw std::logic_error("no decoder for the saved message '" + name + "'");
}

// The message an InputError says (or a failure if there was none).
std::string refusal(const std::function<void()>& decode) {
  try {
    decode();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

}  // namespace

TEST(PeerMessages, MessagesSavedByAnEarlierBuildDecodeAndEncodeToTheSameBytes) {
  const auto saved = test::read_samples("peer_messages.txt");
  ASSERT_EQ(saved.size(), 20u);
  for (const auto& s : saved) EXPECT_EQ(reencode(s.name, s.bytes), s.bytes) << s.name;
}

TEST(PeerMessages, ThisBuildWritesEveryMessageAsTheEarlierBuildDid) {
  const auto saved = test::read_samples("peer_messages.txt");
  const auto now = test::peer_message_samples();
  ASSERT_EQ(now.size(), saved.size());
  for (std::size_t i = 0; i < now.size(); ++i) {
    EXPECT_EQ(now[i].name, saved[i].name);
    EXPECT_EQ(now[i].bytes, saved[i].bytes) << now[i].name;
  }
}

TEST(PeerMessages, AMessageCutShortOrWithBytesLeftOverIsRefused) {
  for (const auto& s : test::read_samples("peer_messages.txt")) {
    for (std::size_t n = 0; n < s.bytes.size(); ++n)
      EXPECT_THROW(reencode(s.name, std::string_view(s.bytes).substr(0, n)), InputError) << s.name << " cut at " << n;
    EXPECT_THROW(reencode(s.name, s.bytes + '\0'), InputError) << s.name << " and a byte more";
  }
  EXPECT_EQ(refusal([] { decode_claim(encode(Claim{3, 81}) + "xy"); }),
            "claim is malformed at byte 16: 2 bytes are left over");
  EXPECT_EQ(refusal([] { decode_hash(std::string(9, '\0')); }),
            "state hash is malformed at byte 8: ends early (8 bytes wanted, 1 left)");
}

TEST(PeerMessages, ValuesOutOfRangeAreRefusedSayingWhat) {
  EXPECT_EQ(refusal([] { decode_nack_order(encode(NackOrder{80, 70, 0})); }),
            "order request is malformed at byte 20: the range is backwards");

  Heartbeat h;
  h.name = std::string(65, 'n');
  EXPECT_EQ(refusal([&] { decode_heartbeat(encode(h)); }),
            "heartbeat is malformed at byte 4: the name is 65 bytes long, over the limit of 64");
  h.name = "ok";
  std::string flags = encode(h);
  flags[6] = 4;
  EXPECT_EQ(refusal([&] { decode_heartbeat(flags); }), "heartbeat is malformed at byte 7: unknown flags");
  h.ordered.assign(65, {1, 2});
  EXPECT_EQ(refusal([&] { decode_heartbeat(encode(h)); }),
            "heartbeat is malformed at byte 51: the number of origins is 65, over the limit of 64");
  h.ordered.assign(2, {1, 2});
  std::string short_list = encode(h);
  short_list.resize(short_list.size() - 12);
  EXPECT_EQ(refusal([&] { decode_heartbeat(short_list); }),
            "heartbeat is malformed at byte 51: the number of origins is 2, more than the 12 bytes left can hold");

  Propose p;
  std::string kind = encode(p);
  kind[16] = 2;
  EXPECT_EQ(refusal([&] { decode_propose(kind); }), "proposal is malformed at byte 17: the payload's kind is not 0 or 1");
  p.payload.blob = true;
  p.payload.size = kMaxBlobBytes + 1;
  EXPECT_EQ(refusal([&] { decode_propose(encode(p)); }),
            "proposal is malformed at byte 29: a blob of " + std::to_string(kMaxBlobBytes + 1) + " bytes");

  BlobChunk c;
  c.size = 2500;
  c.count = 3;
  c.index = 3;
  c.data = std::string(500, 'c');
  EXPECT_EQ(refusal([&] { decode_blob_chunk(encode(c)); }),
            "blob chunk is malformed at byte 524: the chunk's index or count does not fit the blob's size");
  c.index = 1;
  EXPECT_EQ(refusal([&] { decode_blob_chunk(encode(c)); }),
            "blob chunk is malformed at byte 524: the chunk is not as long as its place in the blob says");
  c.data = std::string(1001, 'c');
  EXPECT_EQ(refusal([&] { decode_blob_chunk(encode(c)); }),
            "blob chunk is malformed at byte 24: the chunk is 1001 bytes long, over the limit of 1000");

  BlobNack n;
  n.missing.assign(201, 0);
  EXPECT_EQ(refusal([&] { decode_blob_nack(encode(n)); }),
            "chunk request is malformed at byte 12: the number of chunks is 201, over the limit of 200");

  PeerPresence pr;
  pr.orientation = Eigen::Quaterniond(1, NAN, 0, 0);
  EXPECT_EQ(refusal([&] { decode_presence(encode_presence(pr)); }),
            "presence is malformed at byte 40: the orientation is not a finite number");
  pr.orientation = Eigen::Quaterniond::Identity();
  pr.eye = Vec3(0, INFINITY, 0);
  EXPECT_EQ(refusal([&] { decode_presence(encode_presence(pr)); }),
            "presence is malformed at byte 76: the eye is not a finite number");

  EXPECT_EQ(refusal([] { decode_state_offer(encode(StateOffer{1, 2, 3, kMaxBlobBytes + 1})); }),
            "state offer is malformed at byte 24: a state of " + std::to_string(kMaxBlobBytes + 1) + " bytes");
  EXPECT_EQ(refusal([] { decode_name(encode(Heartbeat{})); }), "join is malformed at byte 4: 45 bytes are left over");

  PeerOp lease;
  lease.kind = PeerOp::Lease;
  lease.radius = 0.06;
  lease.seconds = 0;
  EXPECT_EQ(refusal([&] { decode_peer_op(encode(lease)); }),
            "ordered operation is malformed at byte 45: a lease's radius or time is out of range");
  lease.seconds = 1;
  lease.center = Vec3(NAN, 0, 0);
  EXPECT_EQ(refusal([&] { decode_peer_op(encode(lease)); }),
            "ordered operation is malformed at byte 13: the lease's centre is not a finite number");
  EXPECT_EQ(refusal([] { decode_peer_op("\x05"); }), "ordered operation is malformed at byte 1: unknown kind");
  PeerOp checkpoint;
  checkpoint.kind = PeerOp::Checkpoint;
  checkpoint.targets.assign(65, 7);
  EXPECT_EQ(refusal([&] { decode_peer_op(encode(checkpoint)); }),
            "ordered operation is malformed at byte 5: the number of targets is 65, over the limit of 64");
  PeerOp session;
  std::string operation = encode(session);
  operation[1] = 9;
  EXPECT_EQ(refusal([&] { decode_peer_op(operation); }),
            "ordered operation is malformed at byte 9: the operation says 9 bytes, but 0 are left");
}

TEST(PeerMessages, ACompressedBlobInflatesToItsBytesAndABadOneIsRefused) {
  std::string bytes;
  for (int i = 0; i < 5000; ++i) bytes.push_back(static_cast<char>(i % 7));
  const std::string packed = deflate_bytes(bytes);
  EXPECT_LT(packed.size(), bytes.size() / 4);
  EXPECT_EQ(inflate_bytes(packed), bytes);
  std::string wrong = packed;
  wrong[0] = 1;  // a size it does not inflate to
  EXPECT_EQ(refusal([&] { inflate_bytes(wrong); }), "a compressed blob does not inflate to its size");
  std::string huge = packed;
  huge[7] = 1;
  EXPECT_EQ(refusal([&] { inflate_bytes(huge); }).rfind("compressed blob is malformed at byte 8: it inflates to ", 0), 0u);
}
