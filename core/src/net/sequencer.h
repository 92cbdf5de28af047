// The sequencer: a role one peer holds under an epoch (a fencing token). It gives each proposal its
// place in the one order (gseq) and the step it applies at, each origin's proposals in their own
// order and once; it orders its own bookkeeping too (a peer left, a checkpoint). When it goes
// silent, the live peer with the lowest id claims the role with the next epoch, gathers every order
// any live peer received, and takes over; a peer hearing a newer term follows it. Internal to the
// core.
#pragma once

#include "net/ordered_log.h"
#include "net/peer_core.h"
#include "net/peer_messages.h"

#include <cstdint>
#include <map>

namespace kiji::detail {

// What the sequencer asks of the peer it runs in.
class SequencerHost {
 public:
  virtual ~SequencerHost() = default;
  // The session's clock, in steps.
  virtual std::uint64_t steps() const = 0;
  // Bytes as an ordered payload: inline, or a blob sent in chunks.
  virtual Payload carry(const std::string& bytes) = 0;
  // This peer's proposal `pseq` has its place in the order.
  virtual void acknowledge(std::uint64_t pseq) = 0;
  // A new term: this peer's proposals not yet applied go to its sequencer again.
  virtual void new_term() = 0;
  virtual void heartbeat() = 0;
};

class Sequencer {
 public:
  Sequencer(PeerCore& core, OrderedLog& log, Members& members, SequencerHost& host)
      : core_(core), log_(log), members_(members), host_(host) {}

  // The peer that holds the role (0: none known), and its term.
  std::uint32_t holder() const { return holder_; }
  std::uint64_t epoch() const { return epoch_; }
  // This peer holds the role (or is claiming it).
  bool is_self() const { return holder_ == core_.id; }
  // This peer holds the role and acts in it.
  bool acting() const { return holder_ == core_.id && !claiming_; }
  // This peer claims the role (its sequencer went silent).
  bool claiming() const { return claiming_; }
  // This peer starts the shared session: the first sequencer, epoch 1, at the session's step.
  void start(std::uint64_t steps);

  // --- the role
  void on_propose(std::uint32_t origin, const Propose& p);
  // Orders the sequencer's own bookkeeping (origin 0).
  void order_own(const PeerOp& op);
  // A peer is gone (it said goodbye, went silent, or was the sequencer): ordered out.
  void order_departure(std::uint32_t peer);
  // Joined peers gone silent leave the order (their strokes end, their leases go).
  void drop_silent();
  // The step every order to come applies after, the number the next order gets, the step of the
  // latest order, and each origin's last proposal ordered.
  std::uint64_t announced() const { return announced_; }
  std::uint64_t next_number() const { return next_gseq_; }
  std::uint64_t last_exec() const { return last_exec_; }
  const std::map<std::uint32_t, std::uint64_t>& ordered() const { return ordered_hw_; }
  // The clock stepped to `steps`: orders to come apply at least `lookahead` steps later (not past
  // the stop, `stop_at`, unless ordered there already).
  void announce(std::uint64_t steps, int lookahead, std::uint64_t stop_at);

  // --- following, and taking over
  // A message of a newer term than this peer's: a sequencer of an older one steps down.
  void on_newer_term(std::uint64_t epoch);
  // A heartbeat of a sequencer (or of a peer that says it is one): followed if its term is newer,
  // or the same with no sequencer known, or the same and its id lower than this sequencer's.
  // Returns whether it is this peer's sequencer's, of its term.
  bool on_heartbeat(std::uint32_t sender, std::uint64_t epoch, const Heartbeat& h);
  // The sequencer is silent (unheard since `started` when never heard): the live peer with the
  // lowest id claims the role, gathers what others received, and takes it over.
  void elect(double started);

 private:
  void assign(std::uint32_t origin, const Propose& p);
  void adopt(std::uint32_t sequencer, std::uint64_t epoch, std::uint64_t next);
  void become_sequencer();

  PeerCore& core_;
  OrderedLog& log_;
  Members& members_;
  SequencerHost& host_;
  std::uint32_t holder_ = 0;
  std::uint64_t epoch_ = 0;
  // the role
  std::uint64_t next_gseq_ = 0;
  std::uint64_t announced_ = 0;  // the largest horizon announced
  std::uint64_t last_exec_ = 0;
  std::map<std::uint32_t, std::uint64_t> ordered_hw_;
  std::map<std::uint32_t, std::map<std::uint64_t, Propose>> waiting_;  // out of turn, by origin
  // taking the role over
  bool claiming_ = false;
  std::uint64_t claim_epoch_ = 0;
  double claim_started_ = 0;
};

}  // namespace kiji::detail
