// The hash audit: every few steps each peer hashes its state and reports it; a peer whose hash
// differs from the sequencer's at the same step records the divergence and asks to be healed (sent
// the sequencer's state), at most once a second. The reports also say whether all live peers agree
// (at the shared stop, again and again, since a report can be lost). Internal to the core.
#pragma once

#include "net/peer_core.h"
#include "net/peer_messages.h"

#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <vector>

namespace kiji::detail {

class HashAudit {
 public:
  HashAudit(PeerCore& core, const Session& session, const Members& members)
      : core_(core), session_(session), members_(members) {}

  // Hashes this peer's state at the session's step, reports it, and compares it with the
  // sequencer's (once this peer has the shared state).
  void record(bool joined, std::uint32_t sequencer);
  void on_report(std::uint32_t from, const HashReport& h, bool joined, std::uint32_t sequencer);
  // At the shared stop: reports this peer's hash there, again every 0.1 s.
  void report_at_stop(bool joined, std::uint32_t sequencer);

  // Whether this peer and every live peer reported the same hash for `step`.
  bool agree_at(std::uint64_t step) const;
  // Whether every live peer reported, for the latest step all reported, this peer's hash.
  bool converged() const;
  // Whether a peer's hash equals this peer's at the latest step both hashed (unset: none yet).
  std::optional<bool> agrees_with(std::uint32_t peer) const;
  const std::vector<PeerDivergence>& divergences() const { return divergences_; }

 private:
  void compare(std::uint64_t step, bool joined, std::uint32_t sequencer);
  // The hash a peer reported for a step (null if none is kept).
  const std::uint64_t* reported(std::uint32_t peer, std::uint64_t step) const;

  PeerCore& core_;
  const Session& session_;
  const Members& members_;
  std::map<std::uint64_t, std::uint64_t> own_, reference_;  // by step: this peer's, the sequencer's
  std::map<std::uint32_t, std::map<std::uint64_t, std::uint64_t>> reports_;  // each peer's latest
  std::vector<PeerDivergence> divergences_;
  double heal_asked_ = -1;
  std::uint64_t final_step_ = std::numeric_limits<std::uint64_t>::max();
  double final_sent_ = -1;
};

}  // namespace kiji::detail
