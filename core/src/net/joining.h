// Joining: a peer without the shared state asks to join (a peer whose hash disagreed asks to be
// healed the same way); the sequencer gathers the requests of a few milliseconds into one ordered
// checkpoint, ships its state at that checkpoint as a blob, and offers it to each peer until it is
// in. The joiner gathers the blob's chunks and loads the state. Internal to the core.
#pragma once

#include "net/chunked_transfer.h"
#include "net/peer_core.h"
#include "net/peer_messages.h"

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace kiji::detail {

// What a joiner is sent: the session's state and the lease table, at an ordered checkpoint.
struct Snapshot {
  std::string state;   // Session::encode_state()
  std::string leases;  // LeaseTable::encode()
};
std::string encode(const Snapshot& s);
Snapshot decode_snapshot(std::string_view bytes);

class Joining {
 public:
  // How long a join may wait for the strokes in progress to end (seconds).
  static constexpr double kWaitForStrokes = 2.0;

  Joining(PeerCore& core, const Members& members, ChunkedTransfer& transfer)
      : core_(core), members_(members), transfer_(transfer) {}

  // --- the sequencer's side
  // A peer asks for the state (to join, or to be healed); `acting`: this peer is the sequencer.
  void on_request(std::uint32_t peer, bool acting);
  // Whether to order a checkpoint for the peers that asked: a few milliseconds after the first
  // asked, once no stroke is in progress (a checkpoint cancels them), or after kWaitForStrokes.
  bool checkpoint_due(bool strokes_in_progress) const;
  // The peers a checkpoint is ordered for now (they ask in vain until it is applied).
  std::vector<std::uint32_t> gather();
  void checkpoint_applied(const std::vector<std::uint32_t>& targets);
  // Ships the state taken at checkpoint `gseq` (at the session's step `step`) to its peers.
  void ship(std::uint64_t gseq, const std::vector<std::uint32_t>& targets, std::uint64_t step,
            const Snapshot& snapshot);
  // Offers again each state shipped, until its peer is in or gone.
  void offer_again();
  // The shared clock waits at a checkpoint for the peers being given its state: `steps`, or less.
  std::uint64_t slowest(std::uint64_t steps) const;

  // --- the joiner's side
  // Asks to join, every 30 ms.
  void ask();
  void on_offer(const StateOffer& s, bool joined);
  // The state offered is loaded, or is not the one to load (a new checkpoint is for this peer).
  void forget_offer() { have_offer_ = false; }
  // The state offered, once all its chunks are here, and the checkpoint it was taken at.
  std::optional<std::pair<std::uint64_t, Snapshot>> take();

 private:
  PeerCore& core_;
  const Members& members_;
  ChunkedTransfer& transfer_;
  // the sequencer's
  std::set<std::uint32_t> checkpoint_for_;  // peers a checkpoint is ordered for and not yet applied
  std::set<std::uint32_t> joins_;           // peers asking, gathered for one checkpoint
  double first_join_ = -1;
  struct Shipped {
    StateOffer offer;
    std::uint64_t step = 0;  // the checkpoint's step: the shared clock waits there for the peer
    double sent = -1;
  };
  std::map<std::uint32_t, Shipped> offers_;  // states shipped, until their peers have joined
  // the joiner's
  bool have_offer_ = false;
  StateOffer offer_;
  double join_asked_ = -1;
};

}  // namespace kiji::detail
