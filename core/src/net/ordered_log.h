// The order, as every peer keeps it: the operations the sequencer has numbered (gseq), those
// received and not yet applied and those applied (kept a while, to repair others' gaps); how many
// are known to exist, which step no order to come applies at or before (the horizon), and where the
// shared clock stops. Orders arrive out of turn and twice; a gap is asked for again. Internal to the
// core.
#pragma once

#include "net/peer_messages.h"

#include <cstdint>
#include <map>
#include <optional>

namespace kiji::detail {

// An operation with its place: the step it applies at, who proposed it (and their number for it),
// and the sequencer's term that numbered it.
struct Ordered {
  std::uint64_t exec_step = 0;
  std::uint32_t origin = 0;
  std::uint64_t pseq = 0;
  std::uint64_t epoch = 0;
  Payload payload;
};

// The message that carries an order.
std::string encode_order(std::uint64_t gseq, const Ordered& o);

class OrderedLog {
 public:
  // Orders applied and kept to repair others' gaps.
  static constexpr std::size_t kKeepApplied = 8192;
  // Orders one request asks for at most.
  static constexpr std::size_t kMaxNackRange = 64;

  // The number of the next order to apply.
  std::uint64_t applied() const { return applied_; }
  // The first number not received since the last applied: every order below it is here.
  std::uint64_t received_through() const;
  // Orders below this number exist.
  std::uint64_t known_next() const { return known_next_; }
  void set_known_next(std::uint64_t next) { known_next_ = next; }
  void know(std::uint64_t next) { known_next_ = std::max(known_next_, next); }
  // No order to come applies at or before this step (the sequencer's word).
  std::uint64_t horizon() const { return horizon_; }
  void raise_horizon(std::uint64_t h) { horizon_ = std::max(horizon_, h); }
  // The shared clock stops here, as the sequencer last said (0: never, or not said).
  std::uint64_t stop() const { return stop_; }
  void set_stop(std::uint64_t stop) { stop_ = stop; }

  // An order as received: false (and nothing kept) if it was applied or is here already.
  bool receive(std::uint64_t gseq, const Ordered& o);
  // An order the sequencer gives its place (this peer's own numbering: it is here at once).
  void place(std::uint64_t gseq, const Ordered& o) { waiting_[gseq] = o; }
  // The order received or applied with this number (null if neither).
  const Ordered* find(std::uint64_t gseq) const;
  // The next order to apply, if it is here.
  const Ordered* next() const;
  // Takes the next order out to apply it; applied(o) then keeps it and moves on.
  Ordered take_next();
  void applied(const Ordered& o);

  // The orders received and not yet applied, by number.
  const std::map<std::uint64_t, Ordered>& waiting() const { return waiting_; }
  const std::map<std::uint64_t, Ordered>& kept() const { return applied_log_; }
  // A new term starting at `next`: orders of an older term from there were lost with their sequencer.
  void drop_older_terms(std::uint64_t next, std::uint64_t epoch);
  // Every order received from `next` on goes (this peer numbers from there now).
  void drop_from(std::uint64_t next);
  // The state at order `gseq` was loaded: the next to apply is the one after it.
  void start_after(std::uint64_t gseq);

  // The orders known to exist and not received, when it is time to ask for them again (a request
  // every 30 ms at most, shared with other requests for orders: may_ask, asked).
  std::optional<NackOrder> gap(double now);
  bool may_ask(double now) const { return last_nack_ < 0 || now - last_nack_ > 0.03; }
  void asked(double now) { last_nack_ = now; }

 private:
  std::map<std::uint64_t, Ordered> waiting_;      // received, not yet applied
  std::map<std::uint64_t, Ordered> applied_log_;  // applied, kept to repair others
  std::uint64_t applied_ = 0;
  std::uint64_t known_next_ = 0;
  std::uint64_t horizon_ = 0;
  std::uint64_t stop_ = 0;
  double last_nack_ = -1;
};

}  // namespace kiji::detail
