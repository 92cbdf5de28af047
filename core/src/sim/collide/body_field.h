// A body's distance field: the distance from the body's surface at the centres of a grid's cells
// near it, and for each such cell the triangles near enough to touch cloth in it. Made once for a
// body (shared by every garment's solver while one holds it), so that a cloth vertex far from the
// body costs one look-up a substep and a vertex near it is tested exactly against the few
// triangles its cell lists, where gathering candidates from a tree every step cost the whole
// garment's boxes. A block of cells is filled in when a point first falls in it: a garment touches
// a small part of a body, and filling all of it cost a second a body (ten under the sanitizers).
// Private to libkiji.
#pragma once

#include "kiji/body.h"

#include <array>
#include <atomic>
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
  ~BodyField();
  BodyField(const BodyField&) = delete;
  BodyField& operator=(const BodyField&) = delete;

  // The cell side (m) and how far from the surface the field reaches (m): beyond it a cell is far.
  double cell() const { return cell_; }
  double band() const { return band_; }
  // Half the cell's diagonal: how far a point of a cell can be from its centre.
  double cell_radius() const { return 0.5 * std::sqrt(3.0) * cell_; }

  // The cell holding p, or -1 when it is further than the band from the body. Safe from any number
  // of threads at once; the cell's block is filled in by the first to ask, the same whoever that is.
  std::int64_t cell_of(const Vec3& p) const {
    double at_least;
    return cell_of(p, at_least);
  }
  // The same, and at least how far p is from the body: the band where the whole block is far from
  // it, less than that where only the cell is, the cell's distance less its radius where it is near.
  std::int64_t cell_of(const Vec3& p, double& at_least) const;
  // Unsigned distance from the cell's centre to the nearest triangle.
  float distance(std::int64_t cell) const { return block(cell)->distance[cell % kCells]; }
  // How far the surface near the cell turns: the smallest cosine between the normals of two
  // triangles, each behind the other (a convex turn), within turn_reach() of any point of the cell
  // (1 where it is flat or hollow).
  float turn(std::int64_t cell) const { return block(cell)->turn[cell % kCells]; }
  double turn_reach() const { return band_ + 0.5 * cell_ - cell_radius(); }
  // The triangles whose boxes come within band() of the cell's centre (ascending by index): every
  // triangle within band() - cell_radius() of any point of the cell.
  const int* triangles(std::int64_t cell, int& count) const {
    const Block* b = block(cell);
    const int c = static_cast<int>(cell % kCells);
    count = b->begin[c + 1] - b->begin[c];
    return b->list.data() + b->begin[c];
  }
  // Blocks near the body, and how many of them have been filled in so far.
  std::size_t blocks_near() const { return near_.size(); }
  std::size_t blocks_filled() const { return filled_.load(std::memory_order_relaxed); }

 private:
  static constexpr int kBlock = 4;  // cells a side of a block
  static constexpr int kCells = kBlock * kBlock * kBlock;
  struct Block {
    float distance[kCells];
    float turn[kCells];
    int begin[kCells + 1];
    std::vector<int> list;
  };
  const Block* block(std::int64_t cell) const { return blocks_[cell / kCells].load(std::memory_order_acquire); }
  const Block* fill(int slot) const;

  std::vector<Vec3> vertices_;
  std::vector<std::array<int, 3>> triangles_;
  std::vector<Box3> boxes_;  // each triangle's
  double cell_ = 0.005, band_ = 0.01;
  Vec3 origin_ = Vec3::Zero();
  int grid_[3] = {0, 0, 0};  // blocks a side
  std::vector<int> slot_;    // per block of the grid: its place among the blocks near the body, or -1
  std::vector<std::size_t> near_;  // per such block: its grid index
  std::vector<int> near_begin_, near_tris_;  // per such block: the triangles whose grown boxes reach it
  // Per block near the body: its cells once filled in (null before), and whether one is filling it.
  std::unique_ptr<std::atomic<const Block*>[]> blocks_;
  std::unique_ptr<std::atomic<bool>[]> claimed_;
  mutable std::atomic<std::size_t> filled_{0};
};

}  // namespace kiji::solver_detail
