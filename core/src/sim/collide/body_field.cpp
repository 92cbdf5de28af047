#include "sim/collide/body_field.h"

#include "base/geometry.h"
#include "kiji/codec.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <thread>

namespace kiji::solver_detail {

namespace {

// The fields built last, kept while a solver holds them and the last two besides, found by the
// body's triangles, so that a new session on the same body (a test, each peer's copy decoded from
// the wire, a script that loads the body again) does not build it again.
struct Cache {
  std::mutex mutex;
  std::map<std::uint64_t, std::weak_ptr<const BodyField>> fields;
  std::shared_ptr<const BodyField> recent[2];
};

std::uint64_t content_key(const Body& body) {
  const auto& V = body.vertices();
  const auto& T = body.triangles();
  const std::uint64_t h = hash_bytes(std::string_view(reinterpret_cast<const char*>(V.data()), V.size() * sizeof(V[0])));
  return hash_bytes(std::string_view(reinterpret_cast<const char*>(T.data()), T.size() * sizeof(T[0])), h);
}

Cache& cache() {
  static Cache c;
  return c;
}

inline std::int64_t floor_of(double x) {
  const std::int64_t f = static_cast<std::int64_t>(x);
  return f - (static_cast<double>(f) > x);
}

}  // namespace

std::shared_ptr<const BodyField> BodyField::of(const Body& body, double reach) {
  Cache& c = cache();
  const std::uint64_t key = content_key(body);
  {
    std::lock_guard<std::mutex> lock(c.mutex);
    auto it = c.fields.find(key);
    if (it != c.fields.end())
      if (auto field = it->second.lock(); field && reach + field->cell_radius() <= field->band()) return field;
  }
  auto field = std::make_shared<const BodyField>(body, reach);
  std::lock_guard<std::mutex> lock(c.mutex);
  c.fields[key] = field;
  c.recent[1] = c.recent[0];
  c.recent[0] = field;
  for (auto it = c.fields.begin(); it != c.fields.end();) it = it->second.expired() ? c.fields.erase(it) : std::next(it);
  return field;
}

BodyField::BodyField(const Body& body, double reach) : vertices_(body.vertices()), triangles_(body.triangles()) {
  const auto& V = vertices_;
  const auto& T = triangles_;
  Box3 bounds = body.bounds();
  // Cells of 5 mm (a body of 1.7 m has some 10^6 of them near its surface); coarser for a large
  // body, so that none has more than about a million.
  const double area_guess = 2.0 * (bounds.sizes().x() * bounds.sizes().y() + bounds.sizes().y() * bounds.sizes().z() +
                                   bounds.sizes().x() * bounds.sizes().z());
  // The band: 1 cm, or what a thicker cloth needs (its reach, and the farthest a point of a cell is
  // from its centre).
  cell_ = std::max(0.005, std::cbrt(area_guess * 2 * std::max(0.01, reach) / 1e6));
  // And coarser still where the grid's blocks (a few bytes each, near the body or not) would pass
  // a few million: a long, thin body, or one of absurd size from a damaged file.
  auto blocks_a_side = [&](int a) {
    return std::ceil((bounds.sizes()[a] + 2 * (band_ + cell_)) / (kBlock * cell_)) + 1;
  };
  for (int k = 0; k < 2100; ++k) {
    band_ = std::max({0.01, reach, reach + cell_radius()});
    if (blocks_a_side(0) * blocks_a_side(1) * blocks_a_side(2) <= 4e6) break;
    cell_ *= 2;
  }
  origin_ = bounds.min() - Vec3::Constant(band_ + cell_);
  const double block_side = kBlock * cell_;
  for (int a = 0; a < 3; ++a) grid_[a] = static_cast<int>(blocks_a_side(a));
  const std::size_t nblocks = std::size_t(grid_[0]) * grid_[1] * grid_[2];
  // Each triangle's box grown by the band, in blocks: which blocks hold cells near the body, and the
  // triangles each of them needs (a count, then the lists).
  boxes_.resize(T.size());
  std::vector<char> degenerate(T.size());
  for (std::size_t t = 0; t < T.size(); ++t) {
    for (int k = 0; k < 3; ++k) boxes_[t].extend(V[T[t][k]]);
    degenerate[t] = (V[T[t][1]] - V[T[t][0]]).cross(V[T[t][2]] - V[T[t][0]]).squaredNorm() == 0;
  }
  auto block_range = [&](std::size_t t, int lo[3], int hi[3]) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::max(0, static_cast<int>(floor_of((boxes_[t].min()[a] - band_ - origin_[a]) / block_side)));
      hi[a] = std::min(grid_[a] - 1, static_cast<int>(floor_of((boxes_[t].max()[a] + band_ - origin_[a]) / block_side)));
    }
  };
  // Calls visit(block, t) for every block within the band of every triangle t that is not degenerate.
  auto each_block_near = [&](auto visit) {
    for (std::size_t t = 0; t < T.size(); ++t) {
      if (degenerate[t]) continue;
      int lo[3], hi[3];
      block_range(t, lo, hi);
      for (int z = lo[2]; z <= hi[2]; ++z)
        for (int y = lo[1]; y <= hi[1]; ++y)
          for (int x = lo[0]; x <= hi[0]; ++x) visit((std::size_t(z) * grid_[1] + y) * grid_[0] + x, static_cast<int>(t));
    }
  };
  std::vector<int> tri_count(nblocks + 1, 0);
  each_block_near([&](std::size_t b, int) { ++tri_count[b + 1]; });
  slot_.assign(nblocks, -1);
  for (std::size_t b = 0; b < nblocks; ++b)
    if (tri_count[b + 1] > 0) {
      slot_[b] = static_cast<int>(near_.size());
      near_.push_back(b);
    }
  near_begin_.assign(near_.size() + 1, 0);
  for (std::size_t k = 0; k < near_.size(); ++k) near_begin_[k + 1] = near_begin_[k] + tri_count[near_[k] + 1];
  near_tris_.resize(near_begin_.back());
  std::vector<int> fill(near_begin_.begin(), near_begin_.end() - 1);
  each_block_near([&](std::size_t b, int t) { near_tris_[fill[slot_[b]]++] = t; });
  blocks_ = std::make_unique<std::atomic<const Block*>[]>(near_.size());
  claimed_ = std::make_unique<std::atomic<bool>[]>(near_.size());
  for (std::size_t k = 0; k < near_.size(); ++k) {
    blocks_[k].store(nullptr, std::memory_order_relaxed);
    claimed_[k].store(false, std::memory_order_relaxed);
  }
}

BodyField::~BodyField() {
  for (std::size_t k = 0; k < near_.size(); ++k) delete blocks_[k].load(std::memory_order_acquire);
}

const BodyField::Block* BodyField::fill(int slot) const {
  // One thread fills a block; another asking for it meanwhile waits for it (a block takes some
  // microseconds). What a block holds depends only on the body, so it is the same whoever fills it.
  if (claimed_[slot].exchange(true, std::memory_order_acq_rel)) {
    const Block* done;
    while (!(done = blocks_[slot].load(std::memory_order_acquire))) std::this_thread::yield();
    return done;
  }
  const auto& V = vertices_;
  const auto& T = triangles_;
  const std::size_t b = near_[slot];
  const int bx = static_cast<int>(b % grid_[0]), by = static_cast<int>((b / grid_[0]) % grid_[1]),
            bz = static_cast<int>(b / (std::size_t(grid_[0]) * grid_[1]));
  const int* tris = near_tris_.data() + near_begin_[slot];
  const int nt = near_begin_[slot + 1] - near_begin_[slot];
  auto block = std::make_unique<Block>();
  block->begin[0] = 0;
  // Each triangle's unit normal and centre, once for the block (none for a degenerate one).
  std::vector<Vec3> tri_normal(nt), tri_centre(nt);
  std::vector<char> has_normal(nt);
  for (int q = 0; q < nt; ++q) {
    const auto& f = T[tris[q]];
    const Vec3 n = (V[f[1]] - V[f[0]]).cross(V[f[2]] - V[f[0]]);
    has_normal[q] = n.squaredNorm() > 0;
    if (has_normal[q]) tri_normal[q] = n.normalized();
    tri_centre[q] = (V[f[0]] + V[f[1]] + V[f[2]]) / 3;
  }
  std::vector<Vec3> normals, centres;
  // The turn over the triangles within half a cell beyond the band: the block's list holds every
  // triangle within the band of the block, and a cell's centre is half a cell inside it.
  const double turn_radius = band_ + 0.5 * cell_;
  for (int c = 0; c < kCells; ++c) {
    const int cx = c % kBlock, cy = (c / kBlock) % kBlock, cz = c / (kBlock * kBlock);
    const Vec3 centre = origin_ + cell_ * Vec3(bx * kBlock + cx + 0.5, by * kBlock + cy + 0.5, bz * kBlock + cz + 0.5);
    // The triangles whose boxes come within the band of the centre (a superset of those within the
    // band of it) and the nearest of them exactly; those within the turn's radius, for the turn.
    // One exact distance a triangle serves both.
    std::vector<int>& list = block->list;
    const std::size_t before = list.size();
    double best = std::numeric_limits<double>::infinity();
    normals.clear();
    centres.clear();
    for (int q = 0; q < nt; ++q) {
      const Box3& tb = boxes_[tris[q]];
      const double box2 = (centre - centre.cwiseMax(tb.min()).cwiseMin(tb.max())).squaredNorm();
      if (box2 > turn_radius * turn_radius) continue;
      const auto& f = T[tris[q]];
      const double d = (centre - geom::closest_on_triangle(centre, V[f[0]], V[f[1]], V[f[2]]).point).norm();
      if (box2 <= band_ * band_) {
        list.push_back(tris[q]);
        best = std::min(best, d);
      }
      if (d > turn_radius || !has_normal[q]) continue;
      normals.push_back(tri_normal[q]);
      centres.push_back(tri_centre[q]);
    }
    // Over convex turns only: a straight edge over a hollow (the neck into the shoulders) stays out
    // of it.
    double turn = 1;
    for (std::size_t a = 0; a < normals.size(); ++a)
      for (std::size_t b = a + 1; b < normals.size(); ++b) {
        const double cosine = normals[a].dot(normals[b]);
        if (cosine >= turn) continue;  // would not lower it
        const Vec3 ab = centres[b] - centres[a];
        if (ab.dot(normals[a]) > 0 && ab.dot(normals[b]) < 0) continue;  // each in front of the other
        turn = cosine;
      }
    block->turn[c] = static_cast<float>(turn);
    if (!(best <= band_)) list.resize(before);
    block->distance[c] = best <= band_ ? static_cast<float>(best) : std::numeric_limits<float>::infinity();
    block->begin[c + 1] = static_cast<int>(list.size());
  }
  block->list.shrink_to_fit();
  const Block* done = block.release();
  blocks_[slot].store(done, std::memory_order_release);
  filled_.fetch_add(1, std::memory_order_relaxed);
  return done;
}

std::int64_t BodyField::cell_of(const Vec3& p, double& at_least) const {
  at_least = band_;
  const double inv = 1.0 / cell_;
  std::int64_t c[3];
  for (int a = 0; a < 3; ++a) {
    // Compared as a double before any conversion: a point far off (or not finite) has a cell
    // index no integer holds.
    const double g = (p[a] - origin_[a]) * inv;
    if (!(g >= 0 && g < double(grid_[a]) * kBlock)) return -1;
    c[a] = static_cast<std::int64_t>(g);
  }
  const std::size_t b = (std::size_t(c[2] / kBlock) * grid_[1] + std::size_t(c[1] / kBlock)) * grid_[0] +
                        std::size_t(c[0] / kBlock);
  const int slot = slot_[b];
  if (slot < 0) return -1;
  const Block* block = blocks_[slot].load(std::memory_order_acquire);
  if (!block) block = fill(slot);
  const int in = static_cast<int>((c[2] % kBlock) * kBlock * kBlock + (c[1] % kBlock) * kBlock + c[0] % kBlock);
  const double d = block->distance[in];
  at_least = std::max(0.0, std::min(d, band_) - cell_radius());
  return d <= band_ ? std::int64_t(slot) * kCells + in : -1;
}

}  // namespace kiji::solver_detail
