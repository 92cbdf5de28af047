// The bodies of the peer protocol's messages and of the operations it orders, in Kiji's binary form:
// each type's fields are described once (peer_messages.cpp, over base/archive.h) and both its
// encoder and its decoder are that description; each decoder checks every length against the bytes
// there and fixed limits. The envelope around them is peer_wire.h. Internal to the core.
#pragma once

#include "kiji/operation.h"
#include "kiji/peer.h"

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace kiji::detail {

enum PeerMessage : std::uint8_t {
  kHeartbeat = 1,   // who I am, my clock, what I received; the sequencer's horizon and next number
  kPropose = 2,     // an operation of my user's, for the sequencer to order
  kOrder = 3,       // the sequencer's: an operation's place in the order and the step it applies at
  kNackOrder = 4,   // I am missing these orders
  kBlobChunk = 5,   // a chunk of a large payload (a garment, a body, a snapshot)
  kBlobNack = 6,    // I am missing these chunks
  kHash = 7,        // my state's hash at a step
  kJoin = 8,        // I want to join: give me the state
  kPresence = 9,    // my pointer and viewpoint
  kClaim = 10,      // the sequencer is silent: I take its role with this epoch
  kLeave = 11,      // goodbye
  kState = 12,      // the sequencer's: the snapshot for a joiner is this blob
  kHeal = 13,       // my state's hash differs from the sequencer's: send me the state
};

// A payload carried in a message, or (too large) a reference to a blob sent in chunks.
struct Payload {
  bool blob = false;
  std::string bytes;        // inline
  std::uint64_t hash = 0;   // blob
  std::uint32_t size = 0;
};

struct Heartbeat {
  std::string name;
  bool sequencer = false, joined = false;
  std::uint64_t step = 0;
  std::uint64_t received = 0;   // orders received without a gap: the next number missing
  std::uint64_t horizon = 0;    // sequencer: no order to come applies at or before this step
  std::uint64_t next = 0;       // sequencer: the number the next order gets
  std::uint64_t stop = 0;       // sequencer: the shared clock stops here (0: never)
  std::vector<std::pair<std::uint32_t, std::uint64_t>> ordered;  // sequencer: each origin's last ordered proposal
};
std::string encode(const Heartbeat& h);
Heartbeat decode_heartbeat(std::string_view body);

struct Propose {
  std::uint64_t pseq = 0;
  std::uint64_t desired_step = 0;
  Payload payload;
};
std::string encode(const Propose& p);
Propose decode_propose(std::string_view body);

struct Order {
  std::uint64_t gseq = 0;
  std::uint64_t exec_step = 0;
  std::uint32_t origin = 0;
  std::uint64_t pseq = 0;
  Payload payload;
};
std::string encode(const Order& o);
Order decode_order(std::string_view body);

struct NackOrder {
  std::uint64_t from = 0, to = 0;  // [from, to)
  std::uint32_t target = 0;        // who should answer (0: the sequencer)
};
std::string encode(const NackOrder& n);
NackOrder decode_nack_order(std::string_view body);

struct BlobChunk {
  std::uint64_t hash = 0;
  std::uint32_t size = 0, index = 0, count = 0;
  std::string data;
};
constexpr std::size_t kBlobChunkBytes = 1000;
constexpr std::uint32_t kMaxBlobBytes = 512u << 20;
std::string encode(const BlobChunk& c);
BlobChunk decode_blob_chunk(std::string_view body);

constexpr std::size_t kMaxNackedChunks = 200;  // chunks one request names
struct BlobNack {
  std::uint64_t hash = 0;
  std::vector<std::uint32_t> missing;  // at most kMaxNackedChunks
};
std::string encode(const BlobNack& n);
BlobNack decode_blob_nack(std::string_view body);

struct HashReport {
  std::uint64_t step = 0, hash = 0;
};
std::string encode(const HashReport& h);
HashReport decode_hash(std::string_view body);

std::string encode_presence(const PeerPresence& p);
PeerPresence decode_presence(std::string_view body);

struct Claim {
  std::uint64_t epoch = 0;
  std::uint64_t received = 0;
};
std::string encode(const Claim& c);
Claim decode_claim(std::string_view body);

struct StateOffer {
  std::uint32_t target = 0;     // the joiner (or healed peer) it is for
  std::uint64_t gseq = 0;       // the checkpoint it was taken at
  std::uint64_t hash = 0;       // the blob
  std::uint32_t size = 0;
};
std::string encode(const StateOffer& s);
StateOffer decode_state_offer(std::string_view body);

// The name of a peer that asks to join.
struct Join {
  std::string name;
};
std::string encode_name(const std::string& name);
std::string decode_name(std::string_view body);

// What the sequencer orders: a session operation, or one of the peers' own.
struct PeerOp {
  enum Kind : std::uint8_t { Session = 0, Lease = 1, Release = 2, Checkpoint = 3, PeerLeft = 4 } kind = Session;
  std::string operation;                // Session: encode_operation()
  std::uint32_t garment = 0;            // Lease
  Vec3 center{0, 0, 0};
  double radius = 0, seconds = 0;
  std::vector<std::uint32_t> targets;   // Checkpoint: the peers the state goes to
  std::uint32_t peer = 0;               // PeerLeft
};
std::string encode(const PeerOp& op);
PeerOp decode_peer_op(std::string_view bytes);

// Deflates and inflates blobs (snapshots); the size inflated is bounded by kMaxBlobBytes.
std::string deflate_bytes(std::string_view bytes);
std::string inflate_bytes(std::string_view bytes);

}  // namespace kiji::detail
