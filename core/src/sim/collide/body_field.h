// A body's distance field: the distance from the body's surface at the centres of a grid's cells
// near it, and for each such cell the triangles near enough to touch cloth in it. Built
// once for a body (shared by every garment's solver while one holds it), so that a cloth vertex
// far from the body costs one look-up a substep and a vertex near it is tested exactly against
// the few triangles its cell lists, where gathering candidates from a tree every step cost the
// whole garment's boxes. Private to libkiji.
#pragma once

#include "kiji/body.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace kiji::solver_detail {

class BodyField {
 public:
  // A field of `body` that lists, for a point in any cell, every triangle within `reach` of it (the
  // one built for the body or a copy of it and still in use, if it reaches that far).
  static std::shared_ptr<const BodyField> of(const Body& body, double reach);
  BodyField(const Body& body, double reach);

  // The cell side (m) and how far from the surface the field reaches (m): beyond it a cell is far.
  double cell() const { return cell_; }
  double band() const { return band_; }
  // Half the cell's diagonal: how far a point of a cell can be from its centre.
  double cell_radius() const { return 0.5 * std::sqrt(3.0) * cell_; }

  // The cell holding p, or -1 when it is further than the band from the body.
  std::int64_t cell_of(const Vec3& p) const;
  // Unsigned distance from the cell's centre to the nearest triangle.
  float distance(std::int64_t cell) const { return distance_[cell]; }
  // The triangles whose boxes come within band() of the cell's centre (ascending by index): every
  // triangle within band() - cell_radius() of any point of the cell.
  const int* triangles(std::int64_t cell, int& count) const {
    count = list_begin_[cell + 1] - list_begin_[cell];
    return list_.data() + list_begin_[cell];
  }
  std::size_t cells_used() const { return distance_.size(); }

 private:
  static constexpr int kBlock = 4;  // cells a side of a block
  double cell_ = 0.005, band_ = 0.01;
  Vec3 origin_ = Vec3::Zero();
  int blocks_[3] = {0, 0, 0};
  std::vector<int> block_;  // per block of the grid: its first cell in the arrays below, or -1
  std::vector<float> distance_;
  std::vector<int> list_begin_, list_;
};

}  // namespace kiji::solver_detail
