#include "sim/collide/body_field.h"

#include "base/geometry.h"
#include "kiji/codec.h"
#include "base/parallel.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>

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

BodyField::BodyField(const Body& body, double reach) {
  const auto& V = body.vertices();
  const auto& T = body.triangles();
  Box3 bounds = body.bounds();
  // Cells of 5 mm (a body of 1.7 m takes some 10^6 of them near its surface); coarser for a large
  // body, so that none takes more than about a million: a field is built whenever a session gets a
  // body.
  const double area_guess = 2.0 * (bounds.sizes().x() * bounds.sizes().y() + bounds.sizes().y() * bounds.sizes().z() +
                                   bounds.sizes().x() * bounds.sizes().z());
  // The band: 1 cm, or what a thicker cloth needs (its reach, and the farthest a point of a cell is
  // from its centre).
  band_ = std::max(0.01, reach);
  cell_ = std::max(0.005, std::cbrt(area_guess * 2 * band_ / 1e6));
  band_ = std::max(band_, reach + cell_radius());
  origin_ = bounds.min() - Vec3::Constant(band_ + cell_);
  const double block_side = kBlock * cell_;
  for (int a = 0; a < 3; ++a)
    blocks_[a] = static_cast<int>(std::ceil((bounds.sizes()[a] + 2 * (band_ + cell_)) / block_side)) + 1;
  const std::size_t nblocks = std::size_t(blocks_[0]) * blocks_[1] * blocks_[2];
  // Each triangle's box grown by the band, in blocks: which blocks hold cells near the body, and the
  // triangles each of them needs (a count, then the lists).
  std::vector<int> tri_count(nblocks + 1, 0);
  auto block_range = [&](int t, int lo[3], int hi[3]) {
    Box3 b;
    for (int k = 0; k < 3; ++k) b.extend(V[T[t][k]]);
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::max(0, static_cast<int>(floor_of((b.min()[a] - band_ - origin_[a]) / block_side)));
      hi[a] = std::min(blocks_[a] - 1, static_cast<int>(floor_of((b.max()[a] + band_ - origin_[a]) / block_side)));
    }
  };
  auto block_index = [&](int x, int y, int z) { return (std::size_t(z) * blocks_[1] + y) * blocks_[0] + x; };
  std::vector<char> degenerate(T.size());
  for (std::size_t t = 0; t < T.size(); ++t) {
    degenerate[t] = (V[T[t][1]] - V[T[t][0]]).cross(V[T[t][2]] - V[T[t][0]]).squaredNorm() == 0;
    if (degenerate[t]) continue;
    int lo[3], hi[3];
    block_range(static_cast<int>(t), lo, hi);
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y)
        for (int x = lo[0]; x <= hi[0]; ++x) ++tri_count[block_index(x, y, z) + 1];
  }
  for (std::size_t b = 0; b < nblocks; ++b) tri_count[b + 1] += tri_count[b];
  std::vector<int> block_tris(tri_count[nblocks]);
  {
    std::vector<int> fill(tri_count.begin(), tri_count.end() - 1);
    for (std::size_t t = 0; t < T.size(); ++t) {
      if (degenerate[t]) continue;
      int lo[3], hi[3];
      block_range(static_cast<int>(t), lo, hi);
      for (int z = lo[2]; z <= hi[2]; ++z)
        for (int y = lo[1]; y <= hi[1]; ++y)
          for (int x = lo[0]; x <= hi[0]; ++x) block_tris[fill[block_index(x, y, z)]++] = static_cast<int>(t);
    }
  }
  // The blocks with triangles near them get cells, in block order.
  block_.assign(nblocks, -1);
  std::vector<std::size_t> used;
  for (std::size_t b = 0; b < nblocks; ++b)
    if (tri_count[b + 1] > tri_count[b]) {
      block_[b] = static_cast<int>(used.size() * kBlock * kBlock * kBlock);
      used.push_back(b);
    }
  constexpr int kCells = kBlock * kBlock * kBlock;
  const std::size_t ncells = used.size() * kCells;
  distance_.assign(ncells, std::numeric_limits<float>::infinity());
  // Each block on its own (in parallel), each cell's list and distance from the triangles near the
  // block; the blocks joined in order, so that the field is the same for any number of threads.
  std::vector<Box3> boxes(T.size());
  for (std::size_t t = 0; t < T.size(); ++t)
    for (int k = 0; k < 3; ++k) boxes[t].extend(V[T[t][k]]);
  std::vector<std::vector<int>> lists(used.size()), counts(used.size());
  parallel::for_range(static_cast<int>(used.size()), 1, [&](int b0, int b1) {
    for (int k = b0; k < b1; ++k) {
      const std::size_t b = used[k];
      const int bx = static_cast<int>(b % blocks_[0]), by = static_cast<int>((b / blocks_[0]) % blocks_[1]),
                bz = static_cast<int>(b / (std::size_t(blocks_[0]) * blocks_[1]));
      const int* tris = block_tris.data() + tri_count[b];
      const int nt = tri_count[b + 1] - tri_count[b];
      std::vector<int>& list = lists[k];
      std::vector<int>& count = counts[k];
      count.assign(kCells, 0);
      for (int c = 0; c < kCells; ++c) {
        const int cx = c % kBlock, cy = (c / kBlock) % kBlock, cz = c / (kBlock * kBlock);
        const Vec3 centre = origin_ + cell_ * Vec3(bx * kBlock + cx + 0.5, by * kBlock + cy + 0.5, bz * kBlock + cz + 0.5);
        // The triangles whose boxes come within the band of the centre (a superset of those within
        // the band of it), and the nearest of them exactly.
        const std::size_t before = list.size();
        for (int q = 0; q < nt; ++q) {
          const Box3& tb = boxes[tris[q]];
          if ((centre - centre.cwiseMax(tb.min()).cwiseMin(tb.max())).squaredNorm() <= band_ * band_)
            list.push_back(tris[q]);
        }
        double best = std::numeric_limits<double>::infinity();
        for (std::size_t q = before; q < list.size(); ++q) {
          const auto& f = T[list[q]];
          best = std::min(best, (centre - geom::closest_on_triangle(centre, V[f[0]], V[f[1]], V[f[2]]).point).norm());
        }
        if (!(best <= band_)) {
          list.resize(before);
          continue;
        }
        distance_[block_[b] + c] = static_cast<float>(best);
        count[c] = static_cast<int>(list.size() - before);
      }
    }
  });
  list_begin_.assign(ncells + 1, 0);
  std::size_t at = 0;
  for (std::size_t k = 0; k < used.size(); ++k) {
    for (int c = 0; c < kCells; ++c) list_begin_[k * kCells + c + 1] = list_begin_[k * kCells + c] + counts[k][c];
    at += lists[k].size();
  }
  list_.reserve(at);
  for (const auto& l : lists) list_.insert(list_.end(), l.begin(), l.end());
}

std::int64_t BodyField::cell_of(const Vec3& p) const {
  const double inv = 1.0 / cell_;
  std::int64_t c[3];
  for (int a = 0; a < 3; ++a) {
    // Compared as a double before any conversion: a point far off (or not finite) has a cell
    // index no integer holds.
    const double g = (p[a] - origin_[a]) * inv;
    if (!(g >= 0 && g < double(blocks_[a]) * kBlock)) return -1;
    c[a] = static_cast<std::int64_t>(g);
  }
  const std::size_t b = (std::size_t(c[2] / kBlock) * blocks_[1] + std::size_t(c[1] / kBlock)) * blocks_[0] +
                        std::size_t(c[0] / kBlock);
  const int first = block_[b];
  if (first < 0) return -1;
  const std::int64_t cell = first + (c[2] % kBlock) * kBlock * kBlock + (c[1] % kBlock) * kBlock + c[0] % kBlock;
  return distance_[cell] <= band_ ? cell : -1;
}

}  // namespace kiji::solver_detail
