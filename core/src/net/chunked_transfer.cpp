#include "net/chunked_transfer.h"

namespace kiji::detail {

Payload ChunkedTransfer::carry(const std::string& bytes) {
  Payload p;
  if (bytes.size() <= kInlinePayload) {
    p.bytes = bytes;
    return p;
  }
  const std::string packed = deflate_bytes(bytes);
  p.blob = true;
  p.hash = hash_bytes(packed);
  p.size = static_cast<std::uint32_t>(packed.size());
  publish(p.hash, packed);
  return p;
}

void ChunkedTransfer::publish(std::uint64_t hash, const std::string& packed) {
  Blob& b = blobs_[hash];
  if (!b.complete) {
    b.size = static_cast<std::uint32_t>(packed.size());
    b.count = static_cast<std::uint32_t>((packed.size() + kBlobChunkBytes - 1) / kBlobChunkBytes);
    b.data = packed;
    b.complete = true;
  }
  b.mine = true;
  for (std::uint32_t i = 0; i < b.count; ++i)
    if (queued_.insert({hash, i}).second) outgoing_.emplace_back(hash, i);
}

void ChunkedTransfer::want(std::uint64_t hash, std::uint32_t size) {
  Blob& b = blobs_[hash];
  if (b.count != 0 || b.complete) return;
  b.size = size;
  b.count = static_cast<std::uint32_t>((size + kBlobChunkBytes - 1) / kBlobChunkBytes);
  b.chunks.assign(b.count, {});
  b.have.assign(b.count, 0);
  b.last_chunk = core_.now;
}

const std::string* ChunkedTransfer::bytes(const Payload& p, std::string& inflated) const {
  if (!p.blob) return &p.bytes;
  const std::string* packed = complete(p.hash);
  if (!packed) return nullptr;
  inflated = inflate_bytes(*packed);
  return &inflated;
}

const std::string* ChunkedTransfer::complete(std::uint64_t hash) const {
  auto it = blobs_.find(hash);
  return it != blobs_.end() && it->second.complete ? &it->second.data : nullptr;
}

void ChunkedTransfer::on_chunk(const BlobChunk& c) {
  Blob& b = blobs_[c.hash];
  if (b.complete) return;
  if (b.count == 0) {
    b.size = c.size;
    b.count = c.count;
    b.chunks.assign(b.count, {});
    b.have.assign(b.count, 0);
  }
  if (b.size != c.size || b.count != c.count || b.have[c.index]) return;
  b.chunks[c.index] = c.data;
  b.have[c.index] = 1;
  b.last_chunk = core_.now;
  if (++b.got < b.count) return;
  std::string data;
  data.reserve(b.size);
  for (const auto& chunk : b.chunks) data += chunk;
  if (hash_bytes(data) != c.hash) {  // a chunk was not what its sender meant: start again
    ++core_.stats.dropped["blob hash"];
    b = Blob{};
    return;
  }
  b.data = std::move(data);
  b.complete = true;
  b.chunks.clear();
  b.have.clear();
}

void ChunkedTransfer::on_nack(const BlobNack& n, bool sequencer) {
  auto it = blobs_.find(n.hash);
  if (it == blobs_.end() || !it->second.complete || (!it->second.mine && !sequencer)) return;
  // A chunk still waiting its turn is not queued twice: a receiver asks again while a burst is
  // under way, and duplicates would push the rest of the blob back.
  for (std::uint32_t i : n.missing)
    if (i < it->second.count && queued_.insert({n.hash, i}).second) {
      outgoing_.emplace_front(n.hash, i);
      ++core_.stats.resent;
      ++core_.stats.chunks_resent;
    }
}

void ChunkedTransfer::send_chunks() {
  for (std::size_t n = 0; n < kChunkBurst && !outgoing_.empty(); ++n) {
    const auto [hash, index] = outgoing_.front();
    outgoing_.pop_front();
    queued_.erase({hash, index});
    auto it = blobs_.find(hash);
    if (it == blobs_.end() || !it->second.complete) continue;
    const Blob& b = it->second;
    BlobChunk c;
    c.hash = hash;
    c.size = b.size;
    c.index = index;
    c.count = b.count;
    c.data = b.data.substr(std::size_t(index) * kBlobChunkBytes, kBlobChunkBytes);
    core_.send(kBlobChunk, encode(c));
  }
}

void ChunkedTransfer::ask_for_missing() {
  // Up to kMaxNacksARound messages of kMaxNackedChunks at once: a sender busy with a slow step
  // answers what it heard since, and a request for only the first 200 of a large snapshot's losses
  // made a round of repairs for every 200 (a step each).
  const double now = core_.now;
  for (auto& [hash, b] : blobs_) {
    if (b.complete || b.count == 0 || now - b.last_chunk < 0.03 || (b.asked >= 0 && now - b.asked < 0.03)) continue;
    BlobNack n;
    n.hash = hash;
    int messages = 0;
    for (std::uint32_t i = 0; i < b.count && messages < kMaxNacksARound; ++i) {
      if (!b.have[i]) n.missing.push_back(i);
      if (n.missing.size() == kMaxNackedChunks || (i + 1 == b.count && !n.missing.empty())) {
        core_.send(kBlobNack, encode(n));
        core_.stats.chunks_asked += n.missing.size();
        n.missing.clear();
        ++messages;
        ++core_.stats.nacks_sent;
      }
    }
    b.asked = now;
  }
}

}  // namespace kiji::detail
