// Payloads too large for one message (a garment, a snapshot) go as blobs: deflated, named by their
// hash, and sent in chunks of kBlobChunkBytes, a burst at a time between the peer's other work. A
// receiver gathers the chunks it wants, asks again for those that stopped coming (every one missing
// in one round of requests), and checks the whole against its hash. Internal to the core.
#pragma once

#include "net/peer_core.h"
#include "net/peer_messages.h"

#include <cstdint>
#include <deque>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace kiji::detail {

class ChunkedTransfer {
 public:
  // Larger ordered payloads go as blobs.
  static constexpr std::size_t kInlinePayload = 900;
  // Chunks handed to the transport at once at most.
  static constexpr std::size_t kChunkBurst = 4096;
  // Requests for one blob's missing chunks at once.
  static constexpr int kMaxNacksARound = 16;

  explicit ChunkedTransfer(PeerCore& core) : core_(core) {}

  // The bytes as a payload: inline, or (larger than kInlinePayload) a blob this peer publishes.
  Payload carry(const std::string& bytes);
  // Offers `packed` (deflated) under its hash, and queues all its chunks to go out.
  void publish(std::uint64_t hash, const std::string& packed);
  // This peer needs the blob: it gathers its chunks from now on.
  void want(std::uint64_t hash, std::uint32_t size);
  // The bytes of a payload, inflated into `inflated` for a blob; null while the blob is coming.
  const std::string* bytes(const Payload& p, std::string& inflated) const;
  // A blob's deflated bytes, once all of it is here (null before).
  const std::string* complete(std::uint64_t hash) const;

  void on_chunk(const BlobChunk& c);
  // A request for chunks: answered by whoever published the blob, or by the sequencer.
  void on_nack(const BlobNack& n, bool sequencer);
  // Sends the chunks queued, a burst at most.
  void send_chunks();
  // Asks for the chunks of each wanted blob that stopped coming.
  void ask_for_missing();

 private:
  struct Blob {
    std::uint32_t size = 0, count = 0, got = 0;
    std::vector<std::string> chunks;
    std::vector<char> have;
    std::string data;
    bool complete = false, mine = false;
    double last_chunk = -1, asked = -1;
  };
  PeerCore& core_;
  std::map<std::uint64_t, Blob> blobs_;
  std::deque<std::pair<std::uint64_t, std::uint32_t>> outgoing_;
  std::set<std::pair<std::uint64_t, std::uint32_t>> queued_;  // what outgoing_ holds
};

}  // namespace kiji::detail
