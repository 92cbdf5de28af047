#include "frame_shapes.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

namespace kiji::studio {

namespace {

std::uint64_t key(std::uint32_t a, std::uint32_t b) { return (std::uint64_t(a) << 32) | b; }
std::uint64_t undirected(std::uint32_t a, std::uint32_t b) { return a < b ? key(a, b) : key(b, a); }

// Moller-Trumbore: the distance along the ray to the triangle, or a negative number.
double ray_triangle(const Vec3& o, const Vec3& d, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e1 = b - a, e2 = c - a, h = d.cross(e2);
  const double det = e1.dot(h);
  if (std::abs(det) < 1e-14) return -1;
  const double inv = 1.0 / det;
  const Vec3 s = o - a;
  const double u = inv * s.dot(h);
  if (u < 0 || u > 1) return -1;
  const Vec3 q = s.cross(e1);
  const double v = inv * d.dot(q);
  if (v < 0 || u + v > 1) return -1;
  return inv * e2.dot(q);
}

}  // namespace

GarmentShape::GarmentShape(const GarmentFrame& g) : topology(g.topology) {
  const GarmentTopology& t = *g.topology;
  std::uint32_t top = 0;
  for (std::uint32_t m : t.mesh_vertex) top = std::max(top, m + 1);
  render_of.assign(top, kNone);
  for (std::uint32_t r = 0; r < t.mesh_vertex.size(); ++r)
    if (render_of[t.mesh_vertex[r]] == kNone) render_of[t.mesh_vertex[r]] = r;
  const std::size_t triangles = t.triangles.size() / 3;

  // Directed mesh edges of the faces; one whose reverse no face has is a border edge.
  std::unordered_map<std::uint64_t, std::uint32_t> directed;  // -> the triangle
  directed.reserve(3 * triangles);
  for (std::uint32_t f = 0; f < triangles; ++f)
    for (int k = 0; k < 3; ++k)
      directed.emplace(key(t.mesh_vertex[t.triangles[3 * f + k]], t.mesh_vertex[t.triangles[3 * f + (k + 1) % 3]]), f);
  std::vector<std::uint32_t> next(top, kNone), border_triangle(top, kNone);
  std::vector<Vec2> uv_at(top, Vec2::Zero());
  for (const auto& [k, f] : directed) {
    const std::uint32_t a = std::uint32_t(k >> 32), b = std::uint32_t(k & 0xffffffffu);
    if (directed.count(key(b, a))) continue;
    next[a] = b;
    border_triangle[a] = f;
    for (int c = 0; c < 3; ++c) {
      const std::uint32_t r = t.triangles[3 * f + c];
      if (t.mesh_vertex[r] == a) uv_at[a] = Vec2(t.uv[2 * r], t.uv[2 * r + 1]);
    }
  }
  loop_of.assign(top, -1);
  place_in_loop.assign(top, -1);
  corner.assign(top, 0);
  for (std::uint32_t v = 0; v < top; ++v) {
    if (next[v] == kNone || loop_of[v] >= 0) continue;
    std::vector<std::uint32_t> loop;
    for (std::uint32_t c = v; c != kNone && loop_of[c] < 0; c = next[c]) {
      loop_of[c] = int(loops.size());
      place_in_loop[c] = int(loop.size());
      loop.push_back(c);
    }
    // Corners: where the border turns sharply in the flat pattern.
    const std::size_t n = loop.size();
    for (std::size_t i = 0; i < n && n >= 3; ++i) {
      const Vec2 a = uv_at[loop[(i + n - 1) % n]], b = uv_at[loop[i]], c = uv_at[loop[(i + 1) % n]];
      const Vec2 u = b - a, w = c - b;
      if (u.norm() > 0 && w.norm() > 0 && u.dot(w) / (u.norm() * w.norm()) < std::cos(40 * M_PI / 180)) corner[loop[i]] = 1;
    }
    loops.push_back(std::move(loop));
  }

  // Pieces: triangles joined by shared mesh edges.
  std::vector<std::uint32_t> parent(triangles);
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](std::uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  std::unordered_map<std::uint64_t, std::uint32_t> by_edge;  // mesh edge -> the first triangle with it
  by_edge.reserve(3 * triangles);
  // The render vertex of mesh vertex m in triangle f.
  auto render_in = [&](std::uint32_t f, std::uint32_t m) {
    for (int c = 0; c < 3; ++c)
      if (t.mesh_vertex[t.triangles[3 * f + c]] == m) return t.triangles[3 * f + c];
    return kNone;
  };
  for (std::uint32_t f = 0; f < triangles; ++f)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = t.mesh_vertex[t.triangles[3 * f + k]], b = t.mesh_vertex[t.triangles[3 * f + (k + 1) % 3]];
      auto [it, fresh] = by_edge.emplace(undirected(a, b), f);
      if (fresh) continue;
      parent[find(f)] = find(it->second);
      // The same mesh edge drawn with other render vertices on the two sides: the faces' uvs differ
      // there, as where two borders were sewn.
      const std::uint32_t g0 = it->second;
      if (render_in(f, a) != render_in(g0, a) || render_in(f, b) != render_in(g0, b))
        seams.insert(seams.end(), {render_in(f, a), render_in(f, b)});
    }
  piece_of_triangle.assign(triangles, -1);
  std::unordered_map<std::uint32_t, int> piece_of_root;
  for (std::uint32_t f = 0; f < triangles; ++f) {
    auto [it, fresh] = piece_of_root.emplace(find(f), pieces);
    if (fresh) {
      ++pieces;
      piece_vertex.push_back(t.mesh_vertex[t.triangles[3 * f]]);
    }
    piece_of_triangle[f] = it->second;
  }
  piece_of_border.assign(top, -1);
  for (std::uint32_t v = 0; v < top; ++v)
    if (border_triangle[v] != kNone) piece_of_border[v] = piece_of_triangle[border_triangle[v]];
}

bool GarmentShape::runs_with_loop(const std::vector<std::uint32_t>& side) const {
  if (side.size() < 2 || !on_border(side[0]) || !on_border(side[1])) return false;
  const int n = int(loops[loop_of[side[0]]].size());
  return (place_in_loop[side[0]] + 1) % n == place_in_loop[side[1]];
}

Vec3 GarmentShape::position(const GarmentFrame& g, std::uint32_t v) const {
  const std::uint32_t r = v < render_of.size() ? render_of[v] : kNone;
  if (r == kNone || 3 * std::size_t(r) + 2 >= g.positions.size()) return Vec3::Zero();
  return Vec3(g.positions[3 * r], g.positions[3 * r + 1], g.positions[3 * r + 2]);
}

std::vector<std::uint32_t> GarmentShape::along(std::uint32_t from, std::uint32_t to, bool forward) const {
  if (!on_border(from) || !on_border(to) || loop_of[from] != loop_of[to]) return {};
  const auto& loop = loops[loop_of[from]];
  const int n = int(loop.size());
  std::vector<std::uint32_t> out;
  for (int i = place_in_loop[from], k = 0; k <= n; i = (i + (forward ? 1 : n - 1)) % n, ++k) {
    out.push_back(loop[i]);
    if (loop[i] == to && k > 0) break;
    if (from == to) break;
  }
  return out;
}

std::vector<std::uint32_t> GarmentShape::side_of(std::uint32_t v) const {
  if (!on_border(v)) return {};
  const auto& loop = loops[loop_of[v]];
  const int n = int(loop.size());
  int corners = 0;
  for (std::uint32_t w : loop) corners += corner[w];
  if (corners < 2) return loop;
  // Back to the corner before v (v itself if it is one and the side runs on from it), then on to the next.
  int start = place_in_loop[v];
  if (corner[v]) {
    // A corner starts the side that follows it.
  } else {
    while (!corner[loop[start]]) start = (start + n - 1) % n;
  }
  std::vector<std::uint32_t> out{loop[start]};
  for (int i = (start + 1) % n; out.size() <= std::size_t(n); i = (i + 1) % n) {
    out.push_back(loop[i]);
    if (corner[loop[i]]) break;
  }
  return out;
}

std::vector<std::uint32_t> GarmentShape::piece_triangles(int piece) const {
  std::vector<std::uint32_t> out;
  const auto& t = topology->triangles;
  for (std::size_t f = 0; f < piece_of_triangle.size(); ++f)
    if (piece_of_triangle[f] == piece) out.insert(out.end(), {t[3 * f], t[3 * f + 1], t[3 * f + 2]});
  return out;
}

const GarmentShape* ShapeCache::get(const SceneFrame& frame, std::size_t garment) {
  if (garment >= frame.garments.size() || !frame.garments[garment].topology) return nullptr;
  if (shapes_.size() < frame.garments.size()) shapes_.resize(frame.garments.size());
  auto& s = shapes_[garment];
  if (!s || s->topology != frame.garments[garment].topology) s = std::make_shared<GarmentShape>(frame.garments[garment]);
  return s.get();
}

RayHit cast_ray(const SceneFrame& frame, const Vec3& o, const Vec3& d, bool body) {
  RayHit best;
  best.t = std::numeric_limits<double>::infinity();
  for (std::size_t gi = 0; gi < frame.garments.size(); ++gi) {
    const GarmentFrame& g = frame.garments[gi];
    if (!g.topology) continue;
    const auto& tri = g.topology->triangles;
    const float* p = g.positions.data();
    auto at = [&](std::uint32_t i) { return Vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]); };
    for (std::size_t k = 0; k + 2 < tri.size(); k += 3) {
      const double t = ray_triangle(o, d, at(tri[k]), at(tri[k + 1]), at(tri[k + 2]));
      if (t > 0 && t < best.t) best = {true, int(gi), k / 3, t, o + t * d};
    }
  }
  if (body && frame.body) {
    const auto& v = frame.body->vertices();
    for (std::size_t k = 0; k < frame.body->triangles().size(); ++k) {
      const auto& tr = frame.body->triangles()[k];
      const double t = ray_triangle(o, d, v[tr[0]], v[tr[1]], v[tr[2]]);
      if (t > 0 && t < best.t) best = {true, -1, k, t, o + t * d};
    }
  }
  return best;
}

}  // namespace kiji::studio
