#include "net/hash_audit.h"

namespace kiji::detail {

void HashAudit::record(bool joined, std::uint32_t sequencer) {
  const std::uint64_t h = session_state_hash(session_);
  own_[session_.steps()] = h;
  while (own_.size() > 64) own_.erase(own_.begin());
  core_.send(kHash, encode(HashReport{session_.steps(), h}));
  compare(session_.steps(), joined, sequencer);
}

void HashAudit::on_report(std::uint32_t from, const HashReport& h, bool joined, std::uint32_t sequencer) {
  auto& theirs = reports_[from];
  theirs[h.step] = h.hash;
  while (theirs.size() > 16) theirs.erase(theirs.begin());
  if (from == sequencer) {
    reference_[h.step] = h.hash;
    while (reference_.size() > 64) reference_.erase(reference_.begin());
    compare(h.step, joined, sequencer);
  }
}

void HashAudit::compare(std::uint64_t step, bool joined, std::uint32_t sequencer) {
  auto own = own_.find(step);
  auto ref = reference_.find(step);
  if (own == own_.end() || ref == reference_.end() || !joined) return;
  if (own->second == ref->second) return;
  divergences_.push_back({step, own->second, ref->second, sequencer});
  reference_.erase(ref);
  if (heal_asked_ < 0 || core_.now - heal_asked_ > 1.0) {
    heal_asked_ = core_.now;
    ++core_.stats.heals;
    core_.send(kHeal, std::string());
  }
}

void HashAudit::report_at_stop(bool joined, std::uint32_t sequencer) {
  const std::uint64_t step = session_.steps();
  if (final_step_ == step && core_.now - final_sent_ <= 0.1) return;
  final_step_ = step;
  final_sent_ = core_.now;
  auto own = own_.find(step);
  if (own == own_.end()) record(joined, sequencer);
  else core_.send(kHash, encode(HashReport{step, own->second}));
}

const std::uint64_t* HashAudit::reported(std::uint32_t peer, std::uint64_t step) const {
  const auto theirs = reports_.find(peer);
  if (theirs == reports_.end()) return nullptr;
  const auto h = theirs->second.find(step);
  return h != theirs->second.end() ? &h->second : nullptr;
}

bool HashAudit::agree_at(std::uint64_t step) const {
  const auto own = own_.find(step);
  if (own == own_.end()) return false;
  for (const auto& [pid, m] : members_.all) {
    if (!members_.live(pid, m, core_.now, core_.opt.silence_seconds)) continue;
    const std::uint64_t* h = reported(pid, step);
    if (!h || *h != own->second) return false;
  }
  return true;
}

bool HashAudit::converged() const {
  for (auto own = own_.rbegin(); own != own_.rend(); ++own) {
    bool all = true, same = true;
    for (const auto& [pid, m] : members_.all) {
      if (!members_.live(pid, m, core_.now, core_.opt.silence_seconds)) continue;
      const std::uint64_t* h = reported(pid, own->first);
      if (!h) {
        all = false;
        break;
      }
      same = same && *h == own->second;
    }
    if (all) return same;
  }
  return false;
}

std::optional<bool> HashAudit::agrees_with(std::uint32_t peer) const {
  for (auto own = own_.rbegin(); own != own_.rend(); ++own)
    if (const std::uint64_t* h = reported(peer, own->first)) return *h == own->second;
  return std::nullopt;
}

}  // namespace kiji::detail
