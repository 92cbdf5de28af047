#include "net/sequencer.h"

#include <algorithm>

namespace kiji::detail {

void Sequencer::start(std::uint64_t steps) {
  holder_ = core_.id;
  epoch_ = 1;
  announced_ = steps;
  last_exec_ = steps;
}

void Sequencer::on_propose(std::uint32_t origin, const Propose& p) {
  if (!acting() || members_.left.count(origin)) return;
  const std::uint64_t hw = ordered_hw_[origin];
  if (p.pseq <= hw) return;  // ordered already (its order went out; the origin will see it)
  waiting_[origin][p.pseq] = p;
  auto& queue = waiting_[origin];
  while (!queue.empty() && queue.begin()->first == ordered_hw_[origin] + 1) {
    assign(origin, queue.begin()->second);
    queue.erase(queue.begin());
  }
}

void Sequencer::assign(std::uint32_t origin, const Propose& p) {
  Ordered o;
  o.exec_step = std::max({p.desired_step, announced_ + 1, last_exec_});
  o.origin = origin;
  o.pseq = p.pseq;
  o.epoch = epoch_;
  o.payload = p.payload;
  last_exec_ = o.exec_step;
  const std::uint64_t gseq = next_gseq_++;
  ordered_hw_[origin] = p.pseq;
  log_.place(gseq, o);
  log_.set_known_next(next_gseq_);
  core_.send(kOrder, encode_order(gseq, o));
  if (origin == core_.id) host_.acknowledge(p.pseq);
}

void Sequencer::order_own(const PeerOp& op) {
  Propose p;
  p.pseq = ordered_hw_[0] + 1;
  p.desired_step = 0;
  p.payload = host_.carry(encode(op));
  assign(0, p);  // origin 0: the sequencer's own bookkeeping, not a user's
}

void Sequencer::order_departure(std::uint32_t peer) {
  waiting_.erase(peer);  // proposals it sent before: not to be ordered if it comes back
  members_.left.insert(peer);
  PeerOp op;
  op.kind = PeerOp::PeerLeft;
  op.peer = peer;
  order_own(op);
}

void Sequencer::drop_silent() {
  for (auto& [pid, m] : members_.all) {
    if (members_.left.count(pid) || !m.joined || m.heard < 0) continue;
    if (core_.now - m.heard > core_.opt.silence_seconds) order_departure(pid);
  }
}

void Sequencer::announce(std::uint64_t steps, int lookahead, std::uint64_t stop_at) {
  announced_ = std::max(announced_, steps + static_cast<std::uint64_t>(lookahead));
  if (stop_at) announced_ = std::min(announced_, std::max(stop_at, last_exec_));
}

void Sequencer::on_newer_term(std::uint64_t epoch) {
  // A newer term: its sequencer (or its claimant) is the one to follow.
  if (epoch > epoch_ && acting()) {
    holder_ = 0;
    waiting_.clear();
  }
}

bool Sequencer::on_heartbeat(std::uint32_t sender, std::uint64_t epoch, const Heartbeat& h) {
  if (epoch > epoch_ || (epoch == epoch_ && holder_ == 0) || (epoch == epoch_ && holder_ == core_.id && sender < core_.id))
    adopt(sender, epoch, h.next);
  return sender == holder_ && epoch == epoch_;
}

void Sequencer::adopt(std::uint32_t sequencer, std::uint64_t epoch, std::uint64_t next) {
  const bool new_term = epoch != epoch_;
  holder_ = sequencer;
  epoch_ = epoch;
  claiming_ = false;
  if (!new_term) return;
  // Orders of an older term past the new sequencer's start were lost with it; proposals not yet
  // applied go to the new one (which drops what it has ordered already).
  log_.drop_older_terms(next, epoch);
  log_.set_known_next(next);
  host_.new_term();
}

void Sequencer::elect(double started) {
  const double now = core_.now, silence = core_.opt.silence_seconds;
  const auto s = members_.all.find(holder_);
  const double heard = s == members_.all.end() ? started : s->second.heard;
  if (now - heard <= silence) {
    claiming_ = false;
    return;
  }
  auto live = [&](std::uint32_t pid) {
    auto m = members_.all.find(pid);
    return pid != holder_ && !members_.left.count(pid) && m != members_.all.end() && m->second.joined &&
           now - m->second.heard <= silence;
  };
  std::uint32_t candidate = core_.id;
  for (const auto& [pid, m] : members_.all)
    if (live(pid) && pid < candidate) candidate = pid;
  if (candidate != core_.id) return;
  if (!claiming_) {
    claiming_ = true;
    claim_epoch_ = epoch_ + 1;
    claim_started_ = now;
    core_.send(kClaim, encode(Claim{claim_epoch_, log_.received_through()}));
    return;
  }
  if (now - claim_started_ < 3 * core_.opt.heartbeat_seconds) return;
  // Gather: whoever received more, asked for the rest.
  std::uint64_t most = log_.received_through();
  std::uint32_t richest = core_.id;
  for (const auto& [pid, m] : members_.all)
    if (live(pid) && m.heard >= claim_started_ && m.received > most) most = m.received, richest = pid;
  if (richest != core_.id && now - claim_started_ < 2 * silence) {
    if (log_.may_ask(now)) {
      const std::uint64_t through = log_.received_through();
      core_.send(kNackOrder, encode(NackOrder{through, std::min(most, through + OrderedLog::kMaxNackRange), richest}));
      log_.asked(now);
    }
    return;
  }
  become_sequencer();
}

void Sequencer::become_sequencer() {
  const std::uint32_t old = holder_;
  epoch_ = claim_epoch_;
  holder_ = core_.id;
  claiming_ = false;
  ++core_.stats.elections;
  next_gseq_ = log_.received_through();
  log_.drop_from(next_gseq_);
  log_.set_known_next(next_gseq_);
  // Orders to come apply after any step a peer may have reached.
  announced_ = std::max(log_.horizon(), host_.steps());
  for (const auto& [pid, m] : members_.all) announced_ = std::max({announced_, m.horizon, m.step});
  last_exec_ = announced_;
  ordered_hw_.clear();
  for (const auto* orders : {&log_.kept(), &log_.waiting()})
    for (const auto& [g, o] : *orders) ordered_hw_[o.origin] = std::max(ordered_hw_[o.origin], o.pseq);
  host_.new_term();
  host_.heartbeat();
  if (old != 0 && old != core_.id && !members_.left.count(old)) order_departure(old);
}

}  // namespace kiji::detail
