#include "net/joining.h"

#include "base/archive.h"

namespace kiji::detail {

template <class A>
void fields(A& a, Field<A, Snapshot>& s) {
  a.bytes(s.state, kToTheEnd, "the session's state");
  a.bytes(s.leases, kToTheEnd, "the leases");
  a.end();
}

std::string encode(const Snapshot& s) { return write_form(s); }
Snapshot decode_snapshot(std::string_view bytes) { return read_form<Snapshot>(bytes, "snapshot"); }

void Joining::on_request(std::uint32_t peer, bool acting) {
  if (acting && !checkpoint_for_.count(peer) && !offers_.count(peer)) {
    if (joins_.empty()) first_join_ = core_.now;
    joins_.insert(peer);
  }
}

bool Joining::checkpoint_due(bool strokes_in_progress) const {
  const double waited = core_.now - first_join_;
  return !joins_.empty() && waited >= 0.02 && (!strokes_in_progress || waited >= kWaitForStrokes);
}

std::vector<std::uint32_t> Joining::gather() {
  std::vector<std::uint32_t> targets(joins_.begin(), joins_.end());
  checkpoint_for_.insert(joins_.begin(), joins_.end());
  joins_.clear();
  return targets;
}

void Joining::checkpoint_applied(const std::vector<std::uint32_t>& targets) {
  for (std::uint32_t t : targets) checkpoint_for_.erase(t);
}

void Joining::ship(std::uint64_t gseq, const std::vector<std::uint32_t>& targets, std::uint64_t step,
                   const Snapshot& snapshot) {
  const std::string packed = deflate_bytes(encode(snapshot));
  const std::uint64_t hash = hash_bytes(packed);
  transfer_.publish(hash, packed);
  for (std::uint32_t t : targets) {
    StateOffer s{t, gseq, hash, static_cast<std::uint32_t>(packed.size())};
    offers_[t] = {s, step, core_.now};
    core_.send(kState, encode(s));
  }
  transfer_.send_chunks();  // now, not after this peer's own rebuild and next step
}

void Joining::offer_again() {
  for (auto it = offers_.begin(); it != offers_.end();) {
    auto m = members_.all.find(it->first);
    const bool gone = members_.left.count(it->first) ||
                      (m != members_.all.end() && core_.now - m->second.heard > core_.opt.silence_seconds);
    if (gone || (m != members_.all.end() && m->second.joined && m->second.received > it->second.offer.gseq)) {
      it = offers_.erase(it);
      continue;
    }
    if (core_.now - it->second.sent > 0.05) {
      core_.send(kState, encode(it->second.offer));
      it->second.sent = core_.now;
    }
    ++it;
  }
}

std::uint64_t Joining::slowest(std::uint64_t steps) const {
  for (const auto& [pid, shipped] : offers_) steps = std::min(steps, shipped.step);
  return steps;
}

void Joining::ask() {
  if (join_asked_ < 0 || core_.now - join_asked_ > 0.03) {
    core_.send(kJoin, encode_name(core_.opt.name));
    join_asked_ = core_.now;
  }
}

void Joining::on_offer(const StateOffer& s, bool joined) {
  if (s.target == core_.id && !joined && (!have_offer_ || s.gseq >= offer_.gseq)) {
    offer_ = s;
    have_offer_ = true;
    transfer_.want(s.hash, s.size);
  }
}

std::optional<std::pair<std::uint64_t, Snapshot>> Joining::take() {
  if (!have_offer_) return std::nullopt;
  const std::string* packed = transfer_.complete(offer_.hash);
  if (!packed) return std::nullopt;
  Snapshot snapshot = decode_snapshot(inflate_bytes(*packed));
  return std::make_pair(offer_.gseq, std::move(snapshot));
}

}  // namespace kiji::detail
