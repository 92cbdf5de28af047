#include "net/peer_messages.h"

#include <zlib.h>

namespace kiji::detail {

namespace {
constexpr std::size_t kMaxName = 64;
constexpr std::size_t kMaxOrigins = 64;
constexpr std::size_t kMaxTargets = 64;

void done(ByteReader& r) {
  if (!r.at_end()) r.fail(std::to_string(r.left()) + " bytes are left over");
}
}  // namespace

void write_payload(ByteWriter& w, const Payload& p) {
  w.u8(p.blob);
  if (p.blob) {
    w.u64(p.hash);
    w.u32(p.size);
  } else {
    w.str(p.bytes);
  }
}

Payload read_payload(ByteReader& r) {
  Payload p;
  p.blob = r.boolean("the payload's kind");
  if (p.blob) {
    p.hash = r.u64();
    p.size = r.u32();
    if (p.size > kMaxBlobBytes) r.fail("a blob of " + std::to_string(p.size) + " bytes");
  } else {
    p.bytes = r.str(r.left(), "the payload");
  }
  return p;
}

std::string encode(const Heartbeat& h) {
  ByteWriter w;
  w.str(h.name);
  w.u8(std::uint8_t(h.sequencer) | std::uint8_t(h.joined) << 1);
  w.u64(h.step);
  w.u64(h.received);
  w.u64(h.horizon);
  w.u64(h.next);
  w.u64(h.stop);
  w.u32(static_cast<std::uint32_t>(h.ordered.size()));
  for (const auto& [origin, pseq] : h.ordered) {
    w.u32(origin);
    w.u64(pseq);
  }
  return w.take();
}

Heartbeat decode_heartbeat(std::string_view body) {
  ByteReader r(body, "heartbeat");
  Heartbeat h;
  h.name = r.str(kMaxName, "the name");
  const std::uint8_t flags = r.u8();
  if (flags > 3) r.fail("unknown flags");
  h.sequencer = flags & 1;
  h.joined = flags & 2;
  h.step = r.u64();
  h.received = r.u64();
  h.horizon = r.u64();
  h.next = r.u64();
  h.stop = r.u64();
  const std::size_t n = r.count(kMaxOrigins, 12, "the number of origins");
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t origin = r.u32();
    h.ordered.emplace_back(origin, r.u64());
  }
  done(r);
  return h;
}

std::string encode(const Propose& p) {
  ByteWriter w;
  w.u64(p.pseq);
  w.u64(p.desired_step);
  write_payload(w, p.payload);
  return w.take();
}

Propose decode_propose(std::string_view body) {
  ByteReader r(body, "proposal");
  Propose p;
  p.pseq = r.u64();
  p.desired_step = r.u64();
  p.payload = read_payload(r);
  done(r);
  return p;
}

std::string encode(const Order& o) {
  ByteWriter w;
  w.u64(o.gseq);
  w.u64(o.exec_step);
  w.u32(o.origin);
  w.u64(o.pseq);
  write_payload(w, o.payload);
  return w.take();
}

Order decode_order(std::string_view body) {
  ByteReader r(body, "order");
  Order o;
  o.gseq = r.u64();
  o.exec_step = r.u64();
  o.origin = r.u32();
  o.pseq = r.u64();
  o.payload = read_payload(r);
  done(r);
  return o;
}

std::string encode(const NackOrder& n) {
  ByteWriter w;
  w.u64(n.from);
  w.u64(n.to);
  w.u32(n.target);
  return w.take();
}

NackOrder decode_nack_order(std::string_view body) {
  ByteReader r(body, "order request");
  NackOrder n;
  n.from = r.u64();
  n.to = r.u64();
  n.target = r.u32();
  if (n.to < n.from) r.fail("the range is backwards");
  done(r);
  return n;
}

std::string encode(const BlobChunk& c) {
  ByteWriter w;
  w.u64(c.hash);
  w.u32(c.size);
  w.u32(c.index);
  w.u32(c.count);
  w.str(c.data);
  return w.take();
}

BlobChunk decode_blob_chunk(std::string_view body) {
  ByteReader r(body, "blob chunk");
  BlobChunk c;
  c.hash = r.u64();
  c.size = r.u32();
  c.index = r.u32();
  c.count = r.u32();
  c.data = r.str(kBlobChunkBytes, "the chunk");
  if (c.size > kMaxBlobBytes) r.fail("a blob of " + std::to_string(c.size) + " bytes");
  if (c.count != (c.size + kBlobChunkBytes - 1) / kBlobChunkBytes || c.index >= c.count)
    r.fail("the chunk's index or count does not fit the blob's size");
  const std::size_t expected = c.index + 1 < c.count ? kBlobChunkBytes : c.size - std::size_t(c.index) * kBlobChunkBytes;
  if (c.data.size() != expected) r.fail("the chunk is not as long as its place in the blob says");
  done(r);
  return c;
}

std::string encode(const BlobNack& n) {
  ByteWriter w;
  w.u64(n.hash);
  w.u32(static_cast<std::uint32_t>(n.missing.size()));
  for (std::uint32_t i : n.missing) w.u32(i);
  return w.take();
}

BlobNack decode_blob_nack(std::string_view body) {
  ByteReader r(body, "chunk request");
  BlobNack n;
  n.hash = r.u64();
  const std::size_t k = r.count(kMaxNackedChunks, 4, "the number of chunks");
  for (std::size_t i = 0; i < k; ++i) n.missing.push_back(r.u32());
  done(r);
  return n;
}

std::string encode(const HashReport& h) {
  ByteWriter w;
  w.u64(h.step);
  w.u64(h.hash);
  return w.take();
}

HashReport decode_hash(std::string_view body) {
  ByteReader r(body, "state hash");
  HashReport h;
  h.step = r.u64();
  h.hash = r.u64();
  done(r);
  return h;
}

std::string encode_presence(const PeerPresence& p) {
  ByteWriter w;
  w.vec3(p.pointer);
  w.f64(p.orientation.w());
  w.f64(p.orientation.x());
  w.f64(p.orientation.y());
  w.f64(p.orientation.z());
  w.u32(p.buttons);
  w.vec3(p.eye);
  w.vec3(p.target);
  w.str(p.tool);
  return w.take();
}

PeerPresence decode_presence(std::string_view body) {
  ByteReader r(body, "presence");
  PeerPresence p;
  p.pointer = r.vec3("the pointer");
  const double qw = r.finite("the orientation"), qx = r.finite("the orientation"), qy = r.finite("the orientation"),
               qz = r.finite("the orientation");
  p.orientation = Eigen::Quaterniond(qw, qx, qy, qz);
  p.buttons = r.u32();
  p.eye = r.vec3("the eye");
  p.target = r.vec3("the target");
  p.tool = r.str(kMaxName, "the tool");
  done(r);
  return p;
}

std::string encode(const Claim& c) {
  ByteWriter w;
  w.u64(c.epoch);
  w.u64(c.received);
  return w.take();
}

Claim decode_claim(std::string_view body) {
  ByteReader r(body, "claim");
  Claim c;
  c.epoch = r.u64();
  c.received = r.u64();
  done(r);
  return c;
}

std::string encode(const StateOffer& s) {
  ByteWriter w;
  w.u32(s.target);
  w.u64(s.gseq);
  w.u64(s.hash);
  w.u32(s.size);
  return w.take();
}

StateOffer decode_state_offer(std::string_view body) {
  ByteReader r(body, "state offer");
  StateOffer s;
  s.target = r.u32();
  s.gseq = r.u64();
  s.hash = r.u64();
  s.size = r.u32();
  if (s.size > kMaxBlobBytes) r.fail("a state of " + std::to_string(s.size) + " bytes");
  done(r);
  return s;
}

std::string encode_name(const std::string& name) {
  ByteWriter w;
  w.str(name.substr(0, kMaxName));
  return w.take();
}

std::string decode_name(std::string_view body) {
  ByteReader r(body, "join");
  std::string name = r.str(kMaxName, "the name");
  done(r);
  return name;
}

std::string encode(const PeerOp& op) {
  ByteWriter w;
  w.u8(op.kind);
  switch (op.kind) {
    case PeerOp::Session: w.bytes(op.operation); break;
    case PeerOp::Lease:
      w.u32(op.garment);
      w.vec3(op.center);
      w.f64(op.radius);
      w.f64(op.seconds);
      break;
    case PeerOp::Release: break;
    case PeerOp::Checkpoint:
      w.u32(static_cast<std::uint32_t>(op.targets.size()));
      for (std::uint32_t t : op.targets) w.u32(t);
      break;
    case PeerOp::PeerLeft: w.u32(op.peer); break;
  }
  return w.take();
}

PeerOp decode_peer_op(std::string_view bytes) {
  ByteReader r(bytes, "ordered operation");
  PeerOp op;
  const std::uint8_t kind = r.u8();
  if (kind > PeerOp::PeerLeft) r.fail("unknown kind");
  op.kind = static_cast<PeerOp::Kind>(kind);
  switch (op.kind) {
    case PeerOp::Session: op.operation = std::string(r.bytes(r.left(), "the operation")); break;
    case PeerOp::Lease:
      op.garment = r.u32();
      op.center = r.vec3("the lease's centre");
      op.radius = r.finite("the lease's radius");
      op.seconds = r.finite("the lease's time");
      if (!(op.radius > 0 && op.radius <= 10) || !(op.seconds > 0 && op.seconds <= 3600))
        r.fail("a lease's radius or time is out of range");
      break;
    case PeerOp::Release: break;
    case PeerOp::Checkpoint: {
      const std::size_t n = r.count(kMaxTargets, 4, "the number of targets");
      for (std::size_t i = 0; i < n; ++i) op.targets.push_back(r.u32());
      break;
    }
    case PeerOp::PeerLeft: op.peer = r.u32(); break;
  }
  done(r);
  return op;
}

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
