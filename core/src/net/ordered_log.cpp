#include "net/ordered_log.h"

#include <algorithm>

namespace kiji::detail {

std::string encode_order(std::uint64_t gseq, const Ordered& o) {
  return encode(Order{gseq, o.exec_step, o.origin, o.pseq, o.payload});
}

std::uint64_t OrderedLog::received_through() const {
  std::uint64_t g = applied_;
  while (waiting_.count(g)) ++g;
  return g;
}

bool OrderedLog::receive(std::uint64_t gseq, const Ordered& o) {
  if (gseq < applied_ || waiting_.count(gseq)) return false;
  waiting_[gseq] = o;
  know(gseq + 1);
  return true;
}

const Ordered* OrderedLog::find(std::uint64_t gseq) const {
  auto it = waiting_.find(gseq);
  if (it != waiting_.end()) return &it->second;
  auto a = applied_log_.find(gseq);
  return a != applied_log_.end() ? &a->second : nullptr;
}

const Ordered* OrderedLog::next() const {
  auto it = waiting_.find(applied_);
  return it != waiting_.end() ? &it->second : nullptr;
}

Ordered OrderedLog::take_next() {
  auto it = waiting_.find(applied_);
  const Ordered o = it->second;
  waiting_.erase(it);
  return o;
}

void OrderedLog::applied(const Ordered& o) {
  applied_log_[applied_] = o;
  while (applied_log_.size() > kKeepApplied) applied_log_.erase(applied_log_.begin());
  ++applied_;
}

void OrderedLog::drop_older_terms(std::uint64_t next, std::uint64_t epoch) {
  for (auto it = waiting_.lower_bound(next); it != waiting_.end();)
    it = it->second.epoch < epoch ? waiting_.erase(it) : std::next(it);
}

void OrderedLog::drop_from(std::uint64_t next) {
  for (auto it = waiting_.lower_bound(next); it != waiting_.end();) it = waiting_.erase(it);
}

void OrderedLog::start_after(std::uint64_t gseq) {
  applied_ = gseq + 1;
  for (auto o = waiting_.begin(); o != waiting_.end() && o->first <= gseq;) o = waiting_.erase(o);
  applied_log_.clear();
}

std::optional<NackOrder> OrderedLog::gap(double now) {
  const std::uint64_t through = received_through();
  if (through >= known_next_ || !may_ask(now)) return std::nullopt;
  asked(now);
  return NackOrder{through, std::min(known_next_, through + kMaxNackRange), 0};
}

}  // namespace kiji::detail
