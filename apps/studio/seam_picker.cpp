#include "seam_picker.h"

#include <algorithm>

namespace kiji::studio {

namespace {

// Arc-length shares along a polyline of positions, from 0 to 1.
std::vector<double> shares(const std::vector<Vec3>& p) {
  std::vector<double> t(p.size(), 0.0);
  for (std::size_t i = 1; i < p.size(); ++i) t[i] = t[i - 1] + (p[i] - p[i - 1]).norm();
  if (t.back() > 0)
    for (double& x : t) x /= t.back();
  return t;
}

Vec3 at_share(const std::vector<Vec3>& p, const std::vector<double>& t, double s) {
  for (std::size_t i = 1; i < p.size(); ++i)
    if (s <= t[i] || i + 1 == p.size()) {
      const double span = t[i] - t[i - 1];
      const double f = span > 0 ? std::clamp((s - t[i - 1]) / span, 0.0, 1.0) : 0.0;
      return (1 - f) * p[i - 1] + f * p[i];
    }
  return p.front();
}

bool in_order_on_border(const std::vector<std::uint32_t>& side, const GarmentShape& s) {
  if (side.size() < 2) return false;
  for (std::size_t i = 0; i < side.size(); ++i) {
    if (!s.on_border(side[i])) return false;
    if (i == 0) continue;
    const auto& loop = s.loops[s.loop_of[side[i]]];
    const int n = int(loop.size());
    const int a = s.place_in_loop[side[i - 1]], b = s.place_in_loop[side[i]];
    if (s.loop_of[side[i - 1]] != s.loop_of[side[i]] || ((a + 1) % n != b && (b + 1) % n != a)) return false;
  }
  return true;
}

}  // namespace

bool SeamPicker::press(int garment, std::uint32_t v, const GarmentShape& shape) {
  if (!shape.on_border(v)) return false;
  if (stage_ == Stage::Ready) return false;
  if (stage_ == Stage::Second && garment != garment_) return false;
  garment_ = garment;
  stretch_ = {v};
  direction_ = 0;
  return true;
}

void SeamPicker::drag(std::uint32_t w, const GarmentShape& shape) {
  if (stretch_.empty() || w == stretch_.back() || !shape.on_border(w)) return;
  const std::uint32_t from = stretch_.front();
  if (shape.loop_of[w] != shape.loop_of[from]) return;
  const std::size_t n = shape.loops[shape.loop_of[from]].size();
  if (w == from) {
    stretch_ = {from};
    direction_ = 0;
    return;
  }
  const auto forward = shape.along(from, w, true), backward = shape.along(from, w, false);
  int way = direction_;
  // The way the drag went; the other once the drag has come more than half way round the loop.
  if (way == 0) way = forward.size() <= backward.size() ? 1 : -1;
  else if ((way > 0 ? forward : backward).size() > n / 2 + 1) way = -way;
  stretch_ = way > 0 ? forward : backward;
  direction_ = stretch_.size() > 1 ? way : 0;
}

void SeamPicker::release(const GarmentFrame& g, const GarmentShape& shape) {
  if (stretch_.empty()) return;
  std::vector<std::uint32_t> side = stretch_.size() >= 2 ? stretch_ : shape.side_of(stretch_.front());
  stretch_.clear();
  direction_ = 0;
  if (side.size() < 2) return;
  if (stage_ == Stage::First) {
    first_ = std::move(side);
    stage_ = Stage::Second;
    return;
  }
  second_ = std::move(side);
  stage_ = Stage::Ready;
  one_piece_ = shape.piece_of_border[first_.front()] == shape.piece_of_border[second_.front()];
  if (one_piece_) {
    // stitch() closes a seam whose sides run opposite ways round their loops.
    flipped_ = shape.runs_with_loop(first_) == shape.runs_with_loop(second_);
    return;
  }
  auto at = [&](std::uint32_t v) { return shape.position(g, v); };
  const double straight = (at(first_.front()) - at(second_.front())).norm() + (at(first_.back()) - at(second_.back())).norm();
  const double crossed = (at(first_.front()) - at(second_.back())).norm() + (at(first_.back()) - at(second_.front())).norm();
  flipped_ = crossed < straight;
}

bool SeamPicker::flip() {
  if (stage_ != Stage::Ready || one_piece_) return false;
  flipped_ = !flipped_;
  return true;
}

void SeamPicker::clear() {
  *this = SeamPicker();
}

std::vector<std::uint32_t> SeamPicker::second() const {
  std::vector<std::uint32_t> out = second_;
  if (flipped_) std::reverse(out.begin(), out.end());
  return out;
}

std::vector<SeamPicker::Pair> SeamPicker::pairs(const GarmentFrame& g, const GarmentShape& shape) const {
  if (stage_ != Stage::Ready) return {};
  std::vector<Vec3> a, b;
  for (std::uint32_t v : first_) a.push_back(shape.position(g, v));
  for (std::uint32_t v : second()) b.push_back(shape.position(g, v));
  const auto ta = shares(a), tb = shares(b);
  std::vector<Pair> out;
  // Each vertex of either side with the point at the same share of the other.
  for (std::size_t i = 0; i < a.size(); ++i) out.push_back({a[i], at_share(b, tb, ta[i])});
  for (std::size_t j = 0; j < b.size(); ++j) {
    const bool matched = std::any_of(ta.begin(), ta.end(), [&](double t) { return std::abs(t - tb[j]) < 1e-3; });
    if (!matched) out.push_back({at_share(a, ta, tb[j]), b[j]});
  }
  return out;
}

void SeamPicker::check(const GarmentShape* shape) {
  if (stage_ == Stage::First && stretch_.empty()) return;
  if (!shape) {
    clear();
    return;
  }
  const bool ok = (first_.empty() || in_order_on_border(first_, *shape)) &&
                  (second_.empty() || in_order_on_border(second_, *shape)) &&
                  std::all_of(stretch_.begin(), stretch_.end(), [&](std::uint32_t v) { return shape->on_border(v); });
  if (!ok) clear();
}

QString SeamPicker::hint() const {
  switch (stage_) {
    case Stage::First:
      return "Sew: press on a border and drag along it to pick the seam's first side (a click takes the side "
             "between corners)";
    case Stage::Second:
      return "Sew: now the second side, the same way (Esc: start again)";
    case Stage::Ready:
      return QString(one_piece_ ? "Sew: %1 and %2 border vertices will be joined (within one piece, the only way round "
                                  "that does not twist it). Click or Enter: sew; Esc: cancel"
                                : "Sew: %1 and %2 border vertices will be joined. Click or Enter: sew; right button or R: "
                                  "the other way round; Esc: cancel")
          .arg(first_.size())
          .arg(second_.size());
  }
  return {};
}

}  // namespace kiji::studio
