#include "net/peer_messages.h"

#include "base/archive.h"

#include <zlib.h>

namespace kiji::detail {

namespace {
constexpr std::size_t kMaxName = 64;
constexpr std::size_t kMaxOrigins = 64;
constexpr std::size_t kMaxTargets = 64;
}  // namespace

// Each message's fields, in the order they are on the wire; the encoders and decoders below are
// these and nothing else.

template <class A>
void fields(A& a, Field<A, Payload>& p) {
  a.boolean(p.blob, "the payload's kind");
  if (p.blob) {
    a.u64(p.hash);
    a.u32(p.size);
    a.require(p.size <= kMaxBlobBytes, [&] { return "a blob of " + std::to_string(p.size) + " bytes"; });
  } else {
    a.str(p.bytes, kToTheEnd, "the payload");
  }
}

template <class A>
void fields(A& a, Field<A, Heartbeat>& h) {
  a.str(h.name, kMaxName, "the name");
  a.flags("unknown flags", h.sequencer, h.joined);
  a.u64(h.step);
  a.u64(h.received);
  a.u64(h.horizon);
  a.u64(h.next);
  a.u64(h.stop);
  a.list(h.ordered, kMaxOrigins, 12, "the number of origins", [&](auto& o) {
    a.u32(o.first);
    a.u64(o.second);
  });
  a.end();
}

template <class A>
void fields(A& a, Field<A, Propose>& p) {
  a.u64(p.pseq);
  a.u64(p.desired_step);
  fields(a, p.payload);
  a.end();
}

template <class A>
void fields(A& a, Field<A, Order>& o) {
  a.u64(o.gseq);
  a.u64(o.exec_step);
  a.u32(o.origin);
  a.u64(o.pseq);
  fields(a, o.payload);
  a.end();
}

template <class A>
void fields(A& a, Field<A, NackOrder>& n) {
  a.u64(n.from);
  a.u64(n.to);
  a.u32(n.target);
  a.require(n.to >= n.from, "the range is backwards");
  a.end();
}

template <class A>
void fields(A& a, Field<A, BlobChunk>& c) {
  a.u64(c.hash);
  a.u32(c.size);
  a.u32(c.index);
  a.u32(c.count);
  a.str(c.data, kBlobChunkBytes, "the chunk");
  a.require(c.size <= kMaxBlobBytes, [&] { return "a blob of " + std::to_string(c.size) + " bytes"; });
  a.require(c.count == (c.size + kBlobChunkBytes - 1) / kBlobChunkBytes && c.index < c.count,
            "the chunk's index or count does not fit the blob's size");
  const std::size_t expected = c.index + 1 < c.count ? kBlobChunkBytes : c.size - std::size_t(c.index) * kBlobChunkBytes;
  a.require(c.data.size() == expected, "the chunk is not as long as its place in the blob says");
  a.end();
}

template <class A>
void fields(A& a, Field<A, BlobNack>& n) {
  a.u64(n.hash);
  a.list(n.missing, kMaxNackedChunks, 4, "the number of chunks", [&](auto& i) { a.u32(i); });
  a.end();
}

template <class A>
void fields(A& a, Field<A, HashReport>& h) {
  a.u64(h.step);
  a.u64(h.hash);
  a.end();
}

template <class A>
void fields(A& a, Field<A, PeerPresence>& p) {
  a.vec3(p.pointer, "the pointer");
  a.quaternion(p.orientation, "the orientation");
  a.u32(p.buttons);
  a.vec3(p.eye, "the eye");
  a.vec3(p.target, "the target");
  a.str(p.tool, kMaxName, "the tool");
  a.end();
}

template <class A>
void fields(A& a, Field<A, Claim>& c) {
  a.u64(c.epoch);
  a.u64(c.received);
  a.end();
}

template <class A>
void fields(A& a, Field<A, StateOffer>& s) {
  a.u32(s.target);
  a.u64(s.gseq);
  a.u64(s.hash);
  a.u32(s.size);
  a.require(s.size <= kMaxBlobBytes, [&] { return "a state of " + std::to_string(s.size) + " bytes"; });
  a.end();
}

template <class A>
void fields(A& a, Field<A, Join>& j) {
  a.str(j.name, kMaxName, "the name");
  a.end();
}

template <class A>
void fields(A& a, Field<A, PeerOp>& op) {
  a.enumeration(op.kind, PeerOp::PeerLeft, "unknown kind");
  switch (op.kind) {
    case PeerOp::Session: a.bytes(op.operation, kToTheEnd, "the operation"); break;
    case PeerOp::Lease:
      a.u32(op.garment);
      a.vec3(op.center, "the lease's centre");
      a.finite(op.radius, "the lease's radius");
      a.finite(op.seconds, "the lease's time");
      a.require(op.radius > 0 && op.radius <= 10 && op.seconds > 0 && op.seconds <= 3600,
                "a lease's radius or time is out of range");
      break;
    case PeerOp::Release: break;
    case PeerOp::Checkpoint: a.list(op.targets, kMaxTargets, 4, "the number of targets", [&](auto& t) { a.u32(t); }); break;
    case PeerOp::PeerLeft: a.u32(op.peer); break;
  }
  a.end();
}

std::string encode(const Heartbeat& h) { return write_form(h); }
Heartbeat decode_heartbeat(std::string_view body) { return read_form<Heartbeat>(body, "heartbeat"); }
std::string encode(const Propose& p) { return write_form(p); }
Propose decode_propose(std::string_view body) { return read_form<Propose>(body, "proposal"); }
std::string encode(const Order& o) { return write_form(o); }
Order decode_order(std::string_view body) { return read_form<Order>(body, "order"); }
std::string encode(const NackOrder& n) { return write_form(n); }
NackOrder decode_nack_order(std::string_view body) { return read_form<NackOrder>(body, "order request"); }
std::string encode(const BlobChunk& c) { return write_form(c); }
BlobChunk decode_blob_chunk(std::string_view body) { return read_form<BlobChunk>(body, "blob chunk"); }
std::string encode(const BlobNack& n) { return write_form(n); }
BlobNack decode_blob_nack(std::string_view body) { return read_form<BlobNack>(body, "chunk request"); }
std::string encode(const HashReport& h) { return write_form(h); }
HashReport decode_hash(std::string_view body) { return read_form<HashReport>(body, "state hash"); }
std::string encode_presence(const PeerPresence& p) { return write_form(p); }
PeerPresence decode_presence(std::string_view body) { return read_form<PeerPresence>(body, "presence"); }
std::string encode(const Claim& c) { return write_form(c); }
Claim decode_claim(std::string_view body) { return read_form<Claim>(body, "claim"); }
std::string encode(const StateOffer& s) { return write_form(s); }
StateOffer decode_state_offer(std::string_view body) { return read_form<StateOffer>(body, "state offer"); }
// A name too long for the message is cut, as a peer's name in the list of peers would be.
std::string encode_name(const std::string& name) { return write_form(Join{name.substr(0, kMaxName)}); }
std::string decode_name(std::string_view body) { return read_form<Join>(body, "join").name; }
std::string encode(const PeerOp& op) { return write_form(op); }
PeerOp decode_peer_op(std::string_view bytes) { return read_form<PeerOp>(bytes, "ordered operation"); }

std::string deflate_bytes(std::string_view bytes) {
  uLongf size = compressBound(static_cast<uLong>(bytes.size()));
  std::string out(8 + size, '\0');
  ByteWriter head;
  head.u64(bytes.size());
  const std::string h = head.take();
  std::copy(h.begin(), h.end(), out.begin());
  if (compress2(reinterpret_cast<Bytef*>(out.data() + 8), &size, reinterpret_cast<const Bytef*>(bytes.data()),
                static_cast<uLong>(bytes.size()), 1) != Z_OK)
    throw Error("deflating a snapshot failed");
  out.resize(8 + size);
  return out;
}

std::string inflate_bytes(std::string_view bytes) {
  ByteReader r(bytes, "compressed blob");
  const std::uint64_t size = r.u64();
  if (size > kMaxBlobBytes) r.fail("it inflates to " + std::to_string(size) + " bytes, over the limit");
  std::string out(static_cast<std::size_t>(size), '\0');
  uLongf got = static_cast<uLongf>(size);
  const std::string_view rest = r.take(r.left());
  if (uncompress(reinterpret_cast<Bytef*>(out.data()), &got, reinterpret_cast<const Bytef*>(rest.data()),
                 static_cast<uLong>(rest.size())) != Z_OK ||
      got != size)
    throw InputError("a compressed blob does not inflate to its size");
  return out;
}

}  // namespace kiji::detail
