// The knife along a drawn line: the line is followed over the surface from where it starts, face
// to face, so that it stays on the layer it began on where the cloth lies folded over itself. Where
// it crosses an edge a vertex is made; where the crossing is close to a vertex, that vertex is moved
// onto the line instead, so that no sliver triangle is made. The faces crossed are triangulated
// again with the line's pieces as edges (the triangulation that keeps the smallest angle largest),
// and the line is opened: each vertex on it is split between the faces on its two sides.
#include "kiji/topology.h"

#include "cloth/garment_soup.h"
#include "kiji/error.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

namespace kiji {

namespace {

using detail::commit;
using detail::edge_key;
using detail::EdgeData;
using detail::Index;
using detail::Soup;
using detail::VertexData;

// A crossing this close to a vertex, as a share of the edge, moves the vertex onto the line: nearer,
// the new triangles would have an edge under a third of the others' and angles of a few degrees.
constexpr double kMoveVertex = 0.3;
// A line that follows the pattern may go this far in the pattern between two points, or three times
// as far as between them on the cloth (folds bring the pattern's points nearer): more is a jump from
// one layer of a fold to another.
constexpr double kPatternJump = 0.02;
// Once vertices are on the line, a crossing this close to one that could not be moved (a pinned one,
// a border one off the border's line) goes through it.
constexpr double kThroughVertex = 0.12;
// A vertex moved onto the line keeps the smallest angle of each face around it at least this (in
// degrees), or what the face had if that was less.
constexpr double kSmallestAngle = 20;

struct Adjacency {
  std::unordered_map<std::uint64_t, std::array<int, 2>> faces;
  explicit Adjacency(const Soup& s) {
    faces.reserve(s.faces.size() * 2);
    for (int f = 0; f < int(s.faces.size()); ++f)
      for (int k = 0; k < 3; ++k) {
        auto [it, fresh] = faces.emplace(edge_key(s.faces[f][k], s.faces[f][(k + 1) % 3]), std::array<int, 2>{f, -1});
        if (!fresh) it->second[1] = f;
      }
  }
  int other(std::uint64_t key, int f) const {
    const auto it = faces.find(key);
    if (it == faces.end()) return -1;
    return it->second[0] == f ? it->second[1] : it->second[0];
  }
  bool border(std::uint64_t key) const {
    const auto it = faces.find(key);
    return it != faces.end() && it->second[1] < 0;
  }
};

Vec3 barycentric(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = (b - a).cross(c - a);
  const double d = n.squaredNorm();
  if (!(d > 0)) return Vec3(1.0 / 3, 1.0 / 3, 1.0 / 3);
  const double la = n.dot((c - b).cross(p - b)) / d;
  const double lb = n.dot((a - c).cross(p - c)) / d;
  return Vec3(la, lb, 1.0 - la - lb);
}

// Where the line crosses an edge (a < b), at the share t of the way from a to b, leaving face
// `from` for face `to` (-1: the border, where the line leaves the cloth).
struct Crossing {
  Index a = 0, b = 0;
  double t = 0;
  int from = -1, to = -1;
  Vec3 point = Vec3::Zero();
};

// A point of the line on the surface: its face, where on it, and the corner of the face opposite
// the edge it came in by (-1: none), which the walk does not leave by at once.
struct Cursor {
  int face = -1;
  Vec3 point = Vec3::Zero();
  int entered_opposite = -1;
};

class Walker {
 public:
  Walker(const Soup& s, const Adjacency& adj) : s_(s), adj_(adj) {}

  // Walks in the flat pattern from now on: faces at their uv, the cursor's point in uv (z = 0). The
  // crossings' points stay on the surface.
  void in_pattern() { pattern_ = true; }
  Vec3 corner(int face, int k) const {
    if (!pattern_) return pos(s_.faces[face][k]);
    const Vec2& uv = s_.uvs[face][k];
    return Vec3(uv.x(), uv.y(), 0);
  }

  // Walks from `c` towards `target` over the surface, appending the edges crossed, until the point
  // of the face under the target is reached, the surface turns back (a fold's crease: the line
  // stays on its layer), or the border is met. Returns false at the border.
  bool walk(Cursor& c, const Vec3& target, std::vector<Crossing>& out) {
    Cursor best = c;
    std::size_t best_size = out.size();
    double best_distance = (c.point - target).norm();
    int stalled = 0;
    for (std::size_t guard = 0; guard < 4 * s_.faces.size() + 16; ++guard) {
      const Vec3 p[3] = {corner(c.face, 0), corner(c.face, 1), corner(c.face, 2)};
      Vec3 n = (p[1] - p[0]).cross(p[2] - p[0]);
      if (!(n.norm() > 0)) return true;  // a collapsed face: the line ends on it
      n.normalize();
      const Vec3 onto = target - n * n.dot(target - c.point);
      const Vec3 lt = barycentric(onto, p[0], p[1], p[2]);
      const Vec3 lq = barycentric(c.point, p[0], p[1], p[2]).cwiseMax(0.0);
      if (lt.minCoeff() >= -1e-12) {
        c.point = onto;
        return true;
      }
      const Leave left = leave(c, lq, lt, out);
      if (left == Leave::Stopped) return true;  // only back the way it came: the surface folds back here
      if (left == Leave::Border) return false;
      // Circling a vertex or a crease without getting nearer: back to the nearest point reached.
      const double d = (c.point - target).norm();
      if (d < best_distance - 1e-12) {
        best_distance = d;
        best = c;
        best_size = out.size();
        stalled = 0;
      } else if (++stalled > 8) {
        out.resize(best_size);
        c = best;
        return true;
      }
    }
    out.resize(best_size);
    c = best;
    return true;
  }

  // Goes straight on over the surface from `c` along `direction` (turned into each face it enters),
  // appending the edges crossed, until the border (returns false), or a fold where the surface
  // turns back or a face is collapsed (returns true). This carries a stroke that left the cloth to
  // the border, where walking towards the pointer would stop on the first slope that turns away
  // from it (cloth draped over a body).
  bool run(Cursor& c, Vec3 direction, std::vector<Crossing>& out) {
    for (std::size_t guard = 0; guard < 4 * s_.faces.size() + 16; ++guard) {
      const auto& f = s_.faces[c.face];
      const Vec3 p[3] = {pos(f[0]), pos(f[1]), pos(f[2])};
      Vec3 n = (p[1] - p[0]).cross(p[2] - p[0]);
      if (!(n.norm() > 0)) return true;
      n.normalize();
      direction -= n * n.dot(direction);
      if (!(direction.norm() > 1e-12)) return true;
      direction.normalize();
      const double across = (p[1] - p[0]).norm() + (p[2] - p[1]).norm() + (p[0] - p[2]).norm();
      const Vec3 lt = barycentric(Vec3(c.point + 2 * across * direction), p[0], p[1], p[2]);
      const Vec3 lq = barycentric(c.point, p[0], p[1], p[2]).cwiseMax(0.0);
      const Leave left = leave(c, lq, lt, out);
      if (left == Leave::Stopped) return true;
      if (left == Leave::Border) return false;
    }
    return true;
  }

  // Follows the curve where the surface meets a plane (through c.point, with normal `normal`): the
  // sheet a stroke drawn in a view sweeps along the view's rays. It starts from c towards the stop
  // and goes face to face wherever the surface takes that curve (under a fold too: the line
  // stays on its layer), until it passes the half-plane {x : (x - end).dot(stop) >= 0}, where it
  // stops (true), or meets the border (false). A face the plane does not cross (the point is off
  // it by rounding) or one lying in the plane ends the sheet's part: the walk towards `end` goes on.
  bool sweep(Cursor& c, const Vec3& normal, const Vec3& end, const Vec3& stop, std::vector<Crossing>& out) {
    const Vec3 origin = c.point;
    // Where the plane crosses a face: the edges (an edge opposite corner k joins corners k+1 and
    // k+2) and the shares along them; a corner on the plane counts as on its positive side, so
    // that each crossing belongs to one edge and neighbouring faces agree.
    struct Section {
      int edges[2];
      double at[2];
      int found = 0;
    };
    auto section = [&](int face) {
      const auto& f = s_.faces[face];
      double d[3];
      for (int k = 0; k < 3; ++k) d[k] = (pos(f[k]) - origin).dot(normal);
      Section q;
      for (int k = 0; k < 3 && q.found < 2; ++k) {
        const double da = d[(k + 1) % 3], db = d[(k + 2) % 3];
        if ((da < 0) != (db < 0)) {
          q.edges[q.found] = k;
          q.at[q.found] = da / (da - db);
          ++q.found;
        }
      }
      return q;
    };
    auto point_on = [&](int face, const Section& q, int i) {
      const auto& f = s_.faces[face];
      const int k = q.edges[i];
      return Vec3((1 - q.at[i]) * pos(f[(k + 1) % 3]) + q.at[i] * pos(f[(k + 2) % 3]));
    };
    {
      // The way ahead (towards the stop, across the view: depth does not count): the cursor may be on
      // an edge or a corner (moved there by an earlier cut), and the section that leads forwards
      // from it may be in a face next to its own.
      const double tiny = 1e-9 * (1 + c.point.norm());
      std::vector<int> faces{c.face};
      for (std::size_t i = 0; i < faces.size() && faces.size() < 64; ++i) {
        const auto& f = s_.faces[faces[i]];
        for (int k = 0; k < 3; ++k) {
          const Vec3 a = pos(f[(k + 1) % 3]), b = pos(f[(k + 2) % 3]);
          const double t = std::clamp((c.point - a).dot(b - a) / std::max((b - a).squaredNorm(), 1e-300), 0.0, 1.0);
          if ((a + t * (b - a) - c.point).norm() > tiny) continue;
          const int next = adj_.other(edge_key(f[(k + 1) % 3], f[(k + 2) % 3]), faces[i]);
          if (next >= 0 && std::find(faces.begin(), faces.end(), next) == faces.end()) faces.push_back(next);
        }
      }
      double best = tiny;
      int best_face = -1, best_exit = 0;
      Section best_section;
      for (int face : faces) {
        const Section q = section(face);
        if (q.found < 2) continue;
        for (int i = 0; i < 2; ++i) {
          const double forward = (point_on(face, q, i) - c.point).dot(stop);
          if (forward > best) best = forward, best_face = face, best_exit = i, best_section = q;
        }
      }
      if (best_face < 0) return walk(c, end, out);
      if (best_face != c.face) {
        // Into a face next to the cursor's, through the edge or the corner it sits on: a crossing
        // there too, so that each piece of the line lies across the face the one before entered.
        const auto& f = s_.faces[c.face];
        int k = -1;
        double t = 0;
        for (int e = 0; e < 3 && k < 0; ++e)
          if (adj_.other(edge_key(f[(e + 1) % 3], f[(e + 2) % 3]), c.face) == best_face) {
            const Vec3 a = pos(f[(e + 1) % 3]), b = pos(f[(e + 2) % 3]);
            k = e;
            t = std::clamp((c.point - a).dot(b - a) / std::max((b - a).squaredNorm(), 1e-300), 0.0, 1.0);
          }
        if (k < 0) {  // through a corner: the crossing is at that vertex
          int nearest = 0;
          for (int e = 1; e < 3; ++e)
            if ((pos(f[e]) - c.point).squaredNorm() < (pos(f[nearest]) - c.point).squaredNorm()) nearest = e;
          k = (nearest + 2) % 3;  // the edge from f[nearest] to the next corner
          t = 0;
        }
        Crossing x;
        x.a = f[(k + 1) % 3];
        x.b = f[(k + 2) % 3];
        x.t = t;
        if (x.a > x.b) std::swap(x.a, x.b), x.t = 1.0 - x.t;
        x.point = c.point;
        x.from = c.face;
        x.to = best_face;
        out.push_back(x);
      }
      c.face = best_face;
      c.entered_opposite = best_section.edges[1 - best_exit];
    }
    for (std::size_t guard = 0; guard < 4 * s_.faces.size() + 16; ++guard) {
      const auto& f = s_.faces[c.face];
      const Section q = section(c.face);
      if (q.found < 2) return walk(c, end, out);
      const int exit = q.edges[0] == c.entered_opposite ? 1 : 0;
      if (q.edges[exit] == c.entered_opposite) return walk(c, end, out);
      const Vec3 x = point_on(c.face, q, exit);
      const double h0 = (c.point - end).dot(stop), h1 = (x - end).dot(stop);
      if (h1 >= 0) {  // the stop is in this face
        const double u = h0 >= 0 ? 0.0 : h0 / (h0 - h1);
        c.point = c.point + u * (x - c.point);
        return true;
      }
      const int k = q.edges[exit];
      Index a = f[(k + 1) % 3], b = f[(k + 2) % 3];
      double t = q.at[exit];
      if (a > b) std::swap(a, b), t = 1.0 - t;
      Crossing cross;
      cross.a = a;
      cross.b = b;
      cross.t = t;
      cross.point = x;
      cross.from = c.face;
      cross.to = adj_.other(edge_key(a, b), c.face);
      out.push_back(cross);
      if (cross.to < 0) return false;
      const auto& g = s_.faces[cross.to];
      int opposite = 0;
      while (g[opposite] == a || g[opposite] == b) ++opposite;
      c = Cursor{cross.to, x, opposite};
    }
    return true;
  }

 private:
  enum class Leave { Stopped, Border, Crossed };
  // Leaves c's face on the segment from barycentric lq towards lt (not by the edge it came in by):
  // appends the crossing and moves c into the next face.
  Leave leave(Cursor& c, const Vec3& lq, const Vec3& lt, std::vector<Crossing>& out) {
    const auto& f = s_.faces[c.face];
    int exit = -1;
    double exit_s = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k) {
      if (!(lt[k] < 0) || k == c.entered_opposite) continue;
      const double s = std::max(0.0, lq[k] / (lq[k] - lt[k]));
      if (s < exit_s) exit_s = s, exit = k;
    }
    if (exit < 0) return Leave::Stopped;
    const Vec3 lx = lq + exit_s * (lt - lq);
    Index a = f[(exit + 1) % 3], b = f[(exit + 2) % 3];
    const double wa = std::max(0.0, lx[(exit + 1) % 3]), wb = std::max(0.0, lx[(exit + 2) % 3]);
    double t = wa + wb > 0 ? wb / (wa + wb) : 0.5;
    if (a > b) std::swap(a, b), t = 1.0 - t;
    Crossing x;
    x.a = a;
    x.b = b;
    x.t = t;
    x.point = (1 - t) * pos(a) + t * pos(b);
    x.from = c.face;
    x.to = adj_.other(edge_key(a, b), c.face);
    out.push_back(x);
    if (x.to < 0) return Leave::Border;
    const auto& g = s_.faces[x.to];
    int opposite = 0;
    while (g[opposite] == a || g[opposite] == b) ++opposite;
    Vec3 at = x.point;
    if (pattern_) {  // the same share of the edge, at the uv it has in the face entered
      int ka = 0, kb = 0;
      while (g[ka] != a) ++ka;
      while (g[kb] != b) ++kb;
      at = (1 - t) * corner(x.to, ka) + t * corner(x.to, kb);
    }
    c = Cursor{x.to, at, opposite};
    return Leave::Crossed;
  }

  const Vec3& pos(Index v) const { return s_.vertices[v].position; }
  const Soup& s_;
  const Adjacency& adj_;
  bool pattern_ = false;
};

// The triangulation of a convex polygon (2D corners in order) that keeps its smallest angle
// largest; triangles as corner indices, in the polygon's order.
std::vector<std::array<int, 3>> best_triangulation(const std::vector<Vec2>& q) {
  const int n = int(q.size());
  std::vector<std::array<int, 3>> out;
  if (n < 3) return out;
  if (n == 3) return {{0, 1, 2}};
  auto angle = [&](int i, int j, int k) {  // at j
    const Vec2 u = q[i] - q[j], v = q[k] - q[j];
    const double nu = u.norm(), nv = v.norm();
    if (!(nu > 0 && nv > 0)) return 0.0;
    return std::acos(std::clamp(u.dot(v) / (nu * nv), -1.0, 1.0));
  };
  auto quality = [&](int i, int j, int k) {
    const double area = (q[j] - q[i]).x() * (q[k] - q[i]).y() - (q[j] - q[i]).y() * (q[k] - q[i]).x();
    if (!(std::abs(area) > 1e-18)) return 0.0;
    return std::min({angle(k, i, j), angle(i, j, k), angle(j, k, i)});
  };
  std::vector<double> best(n * n, std::numeric_limits<double>::infinity());
  std::vector<int> split(n * n, -1);
  for (int len = 2; len < n; ++len)
    for (int i = 0; i + len < n; ++i) {
      const int j = i + len;
      double b = -1;
      for (int k = i + 1; k < j; ++k) {
        double v = quality(i, k, j);
        if (k - i > 1) v = std::min(v, best[i * n + k]);
        if (j - k > 1) v = std::min(v, best[k * n + j]);
        if (v > b) b = v, split[i * n + j] = k;
      }
      best[i * n + j] = b;
    }
  std::vector<std::pair<int, int>> stack{{0, n - 1}};
  while (!stack.empty()) {
    const auto [i, j] = stack.back();
    stack.pop_back();
    if (j - i < 2) continue;
    const int k = split[i * n + j];
    out.push_back({i, k, j});
    stack.emplace_back(i, k);
    stack.emplace_back(k, j);
  }
  return out;
}

class Knife {
 public:
  // Seen: a closed line drawn in a view cuts round the cloth it encloses as seen (follow_seen).
  Knife(const Garment& g, const KnifeLine& line, bool seen = false)
      : g_(g), line_(line), s_(detail::to_soup(g)), adj_(s_), seen_(seen) {}

  // Cuts `target` (the garment read), or only follows the line when it is null.
  KnifeCut run(Garment* target) {
    const bool dry = !target;
    follow();
    if (!dry && !crossings_.empty()) {
      border_.assign(s_.vertices.size(), 0);
      for (const auto& [key, faces] : adj_.faces)
        if (faces[1] < 0) border_[key >> 32] = border_[key & 0xffffffffu] = 1;
      inc_ = s_.incidence();
      // Vertices near the line are moved onto it, and the line is followed again over the faces so
      // changed: it now goes through them.
      if (move_vertices_onto_line()) {
        crossings_.clear();
        followed_.clear();
        follow();
      }
    }
    KnifeCut out;
    out.line = followed_;
    if (dry || crossings_.empty()) {
      out.closed = closed_;
      return out;
    }
    resolve();
    out.closed = closed_;
    if (path_.size() < 2 && segments_.empty()) return out;
    rebuild_faces();
    open(out);
    detail::check_manifold(s_, "cut");
    commit(*target, s_, "cut");
    return out;
  }

 private:
  // --- 1. the line over the surface ---
  void follow() {
    if (seen_) return follow_seen();
    if (!line_.faces.empty()) return follow_pattern();
    const Mesh& m = g_.mesh();
    if (line_.start == Mesh::null_face() || line_.start.idx() >= m.number_of_faces() + m.number_of_removed_faces() ||
        m.is_removed(line_.start))
      throw InputError("cut: the line's start is not a face of garment '" + g_.name + "'");
    if (line_.points.empty()) throw InputError("cut: a line needs at least one point on the cloth");
    for (const Vec3& p : line_.points)
      if (!p.allFinite()) throw InputError("cut: a point of the line is not finite");
    int start = 0;
    for (Face f : m.faces()) {
      if (f == line_.start) break;
      ++start;
    }
    Walker walker(s_, adj_);
    Cursor c{start, line_.points.front(), -1};
    // Onto the start face first.
    {
      const auto& f = s_.faces[start];
      const Vec3 l = barycentric(c.point, pos(f[0]), pos(f[1]), pos(f[2])).cwiseMax(0.0);
      c.point = (l[0] * pos(f[0]) + l[1] * pos(f[1]) + l[2] * pos(f[2])) / l.sum();
    }
    // From the border: the line carried back from its start towards where the stroke came from.
    if (line_.from) {
      Cursor back = c;
      std::vector<Crossing> before;
      if (walker.walk(back, *line_.from, before)) {
        // Stopped on the cloth (a slope that turns away from the pointer): straight on the way it went.
        std::vector<Vec3> went{c.point};
        for (const Crossing& x : before) went.push_back(x.point);
        walker.run(back, heading(went, back.point, *line_.from - back.point), before);
      }
      for (auto it = before.rbegin(); it != before.rend(); ++it) {
        Crossing x = *it;
        std::swap(x.from, x.to);
        crossings_.push_back(x);
        followed_.push_back(x.point);
      }
    }
    followed_.push_back(c.point);
    bool on_cloth = true;
    for (std::size_t i = 1; i < line_.points.size() && on_cloth; ++i) on_cloth = step(walker, c, i);
    if (on_cloth && line_.to) {
      on_cloth = step(walker, c, *line_.to);
      if (on_cloth) on_cloth = run_on(walker, c, heading(followed_, c.point, *line_.to - c.point));
    }
    closed_ = line_.closed && on_cloth && !line_.from && !line_.to;
    if (closed_ && crossings_.size() >= 2) {
      // Back to where the line first crossed an edge; a crossing of that same point again is that one.
      const Crossing first_crossing = crossings_.front();
      if (swept()) step(walker, c, 0);
      step(walker, c, first_crossing.point);
      settle_closing(first_crossing);
    } else {
      closed_ = false;
    }
    if (!closed_ && !followed_.empty() && c.face >= 0 && on_cloth) followed_.push_back(c.point);
  }

  // The line walked back to its first crossing: a crossing of that same point again is that one.
  void settle_closing(const Crossing& first) {
    const double tiny = 1e-9 * (1.0 + first.point.norm());
    while (crossings_.size() > 2 && (crossings_.back().point - first.point).norm() < tiny) {
      crossings_.pop_back();
      followed_.pop_back();
    }
    if (crossings_.back().to != crossings_.front().from && crossings_.back().to == crossings_.front().to) {
      crossings_.erase(crossings_.begin());  // it came back on the other side of the first edge
      followed_.erase(followed_.begin() + (line_.from ? 0 : 1));
    }
    closed_ = crossings_.size() >= 3;
  }

  // A closed line drawn in a view, as what it encloses as seen: the cloth connected to the faces the
  // stroke touched whose vertices project inside the stroke (through the view's eye, or along its
  // rays where they are parallel), with any cloth it surrounds; the line is where that cloth's edges
  // cross the cone of rays through the stroke. One line only (closed, or border to border): no
  // crossings otherwise. The inside is found once; after vertices are moved onto the line, the
  // crossings are found again on the same sides.
  void follow_seen() {
    const std::size_t n = line_.points.size();
    if (n < 3 || line_.sweeps.size() != n || line_.faces.size() != n) return;
    if (inside_.empty() && !find_inside()) return;
    // The edges between the inside and the rest, two in each face with corners on both sides.
    auto mixed = [&](Index a, Index b) { return inside_[a] != inside_[b]; };
    std::vector<std::uint64_t> edges;
    for (const auto& [key, faces] : adj_.faces)
      if (mixed(Index(key >> 32), Index(key & 0xffffffffu))) edges.push_back(key);
    if (edges.empty()) return;
    std::sort(edges.begin(), edges.end());  // the map's order is not the same on every machine
    // Where the line ends at the border, it starts there.
    std::uint64_t start = edges.front();
    for (std::uint64_t key : edges)
      if (adj_.border(key)) {
        start = key;
        break;
      }
    auto other_mixed = [&](int face, std::uint64_t came) {
      const auto& f = s_.faces[face];
      for (int k = 0; k < 3; ++k) {
        const std::uint64_t key = edge_key(f[k], f[(k + 1) % 3]);
        if (key != came && mixed(f[k], f[(k + 1) % 3])) return key;
      }
      return came;
    };
    const auto& start_faces = adj_.faces.at(start);
    int from = start_faces[1] < 0 ? -1 : start_faces[0], to = start_faces[1] < 0 ? start_faces[0] : start_faces[1];
    std::uint64_t edge = start;
    std::size_t crossed = 0;
    bool closed = false;
    for (std::size_t guard = 0; guard <= edges.size(); ++guard) {
      crossings_.push_back(seen_crossing(edge, from, to));
      followed_.push_back(crossings_.back().point);
      ++crossed;
      if (to < 0) break;
      const std::uint64_t next = other_mixed(to, edge);
      if (next == edge) break;
      from = to;
      to = adj_.other(next, from);
      edge = next;
      if (edge == start) {
        closed = true;
        break;
      }
    }
    // Another line elsewhere (the inside meets the border twice, or a layer left out): not one cut.
    if (crossed != edges.size() || (!closed && !adj_.border(edge))) {
      crossings_.clear();
      followed_.clear();
      return;
    }
    closed_ = closed;
  }

  // The view: its eye where the rays meet (none where they are parallel), its axis, and the stroke
  // on a plane across it; then which vertices are inside.
  bool find_inside() {
    const std::size_t n = line_.points.size();
    Vec3 axis = Vec3::Zero();
    for (const Vec3& r : line_.sweeps) {
      if (!r.allFinite() || !(r.norm() > 0)) return false;
      axis += r.normalized();
    }
    if (!(axis.norm() > 0)) return false;
    axis_ = axis.normalized();
    Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
    Vec3 b = Vec3::Zero();
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3 r = line_.sweeps[i].normalized();
      const Eigen::Matrix3d across = Eigen::Matrix3d::Identity() - r * r.transpose();
      a += across;
      b += across * line_.points[i];
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(a);
    perspective_ = eig.eigenvalues()(0) > 1e-6 * eig.eigenvalues()(2);
    if (perspective_) {
      eye_ = a.ldlt().solve(b);
      for (const Vec3& q : line_.points)
        if (!((q - eye_).dot(axis_) > 0)) return false;
    }
    side_ = axis_.unitOrthogonal();
    up_ = axis_.cross(side_);
    loop_.clear();
    for (const Vec3& q : line_.points) loop_.push_back(seen_at(q));
    const Mesh& m = g_.mesh();
    std::vector<int> index(m.number_of_faces() + m.number_of_removed_faces(), -1);
    int i = 0;
    for (Face f : m.faces()) index[f.idx()] = i++;
    // The inside vertices of the faces the stroke touched, and what they reach inside.
    inside_.assign(s_.vertices.size(), 0);
    // As deep as the stroke was drawn, and as far again as the stroke is wide: the cap it encloses,
    // not cloth far behind it that the same rays meet (the back of a garment behind the head).
    Vec3 centre = Vec3::Zero();
    for (const Vec3& q : line_.points) centre += q / double(n);
    double wide = 0, nearest = std::numeric_limits<double>::infinity(), farthest = -nearest;
    for (const Vec3& q : line_.points) {
      wide = std::max(wide, (q - centre).norm());
      nearest = std::min(nearest, depth(q));
      farthest = std::max(farthest, depth(q));
    }
    std::vector<char> in_loop(s_.vertices.size(), 0);
    for (Index v = 0; v < s_.vertices.size(); ++v) {
      const Vec3& p = s_.vertices[v].position;
      in_loop[v] = s_.vertices[v].alive && depth(p) > nearest - wide && depth(p) < farthest + wide && encloses(p);
    }
    const auto inc = s_.incidence();
    std::vector<Index> todo;
    for (Face f : line_.faces)
      if (f != Mesh::null_face() && f.idx() < index.size() && index[f.idx()] >= 0)
        for (Index v : s_.faces[index[f.idx()]])
          if (in_loop[v] && !inside_[v]) inside_[v] = 1, todo.push_back(v);
    if (todo.empty()) return false;
    auto spread = [&](std::vector<char>& mark, auto&& may) {
      while (!todo.empty()) {
        const Index v = todo.back();
        todo.pop_back();
        for (Index f : inc[v])
          for (Index w : s_.faces[f])
            if (!mark[w] && may(w)) mark[w] = 1, todo.push_back(w);
      }
    };
    spread(inside_, [&](Index w) { return in_loop[w] != 0; });
    // Cloth the inside surrounds (no way to the border but through it) is inside too.
    std::vector<char> out(s_.vertices.size(), 0);
    std::vector<char> on_border(s_.vertices.size(), 0);
    for (const auto& [key, faces] : adj_.faces)
      if (faces[1] < 0) on_border[key >> 32] = on_border[key & 0xffffffffu] = 1;
    for (Index v = 0; v < s_.vertices.size(); ++v)
      if (on_border[v] && !inside_[v]) out[v] = 1, todo.push_back(v);
    spread(out, [&](Index w) { return !inside_[w]; });
    for (Index v = 0; v < s_.vertices.size(); ++v)
      if (s_.vertices[v].alive && !out[v] && !inc[v].empty()) inside_[v] = 1;
    // The line passes each vertex's ring once: where the sides change more than twice round a
    // vertex (an arm of the outside between two of the inside), the line would touch itself there
    // and open a sliver into a piece of its own. That ring goes inside.
    for (int round = 0; round < 16; ++round) {
      std::vector<Index> pinched;
      for (Index v = 0; v < s_.vertices.size(); ++v) {
        int changes = 0;
        for (Index f : inc[v]) {
          Index other[2], k = 0;
          for (Index w : s_.faces[f])
            if (w != v) other[k++] = w;
          changes += inside_[other[0]] != inside_[other[1]];
        }
        if (changes > 2) pinched.push_back(v);
      }
      if (pinched.empty()) break;
      for (Index v : pinched)
        for (Index f : inc[v])
          for (Index w : s_.faces[f]) inside_[w] = 1;
    }
    return true;
  }

  double depth(const Vec3& x) const { return (perspective_ ? Vec3(x - eye_) : x).dot(axis_); }

  // A point as seen: across the view's axis (divided by its depth, through an eye).
  Vec2 seen_at(const Vec3& x) const {
    const Vec3 d = perspective_ ? Vec3(x - eye_) : x;
    const double depth = perspective_ ? d.dot(axis_) : 1.0;
    return Vec2(d.dot(side_) / depth, d.dot(up_) / depth);
  }

  // Whether the stroke, as seen, goes round a point (its winding number is not zero).
  bool encloses(const Vec3& x) const {
    if (perspective_ && !((x - eye_).dot(axis_) > 1e-9)) return false;
    const Vec2 p = seen_at(x);
    int winding = 0;
    for (std::size_t i = 0; i < loop_.size(); ++i) {
      const Vec2& a = loop_[i];
      const Vec2& b = loop_[(i + 1) % loop_.size()];
      const double cross = (b.x() - a.x()) * (p.y() - a.y()) - (p.x() - a.x()) * (b.y() - a.y());
      if (a.y() <= p.y() && b.y() > p.y() && cross > 0) ++winding;
      if (a.y() > p.y() && b.y() <= p.y() && cross < 0) --winding;
    }
    return winding != 0;
  }

  // Where an edge between the inside and the rest meets the cone of rays through the stroke: on the
  // plane of the stroke's piece it crosses as seen, the one nearest its inside end; at the end
  // nearer the stroke where rounding leaves none (an end moved onto the line).
  Crossing seen_crossing(std::uint64_t key, int from, int to) const {
    Crossing x;
    x.a = Index(key >> 32);
    x.b = Index(key & 0xffffffffu);
    x.from = from;
    x.to = to;
    const Vec3 pa = pos(x.a), pb = pos(x.b);
    const std::size_t n = line_.points.size();
    double best = -1, nearest = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3& q0 = line_.points[i];
      const Vec3& q1 = line_.points[(i + 1) % n];
      const Vec3 normal = perspective_ ? Vec3((q0 - eye_).cross(q1 - eye_)) : Vec3((q1 - q0).cross(axis_));
      const Vec3 origin = perspective_ ? eye_ : q0;
      const double da = (pa - origin).dot(normal), db = (pb - origin).dot(normal);
      if ((da < 0) == (db < 0) || da == db) continue;
      const double t = da / (da - db);
      const Vec2 at = seen_at((1 - t) * pa + t * pb), s0 = seen_at(q0), s1 = seen_at(q1);
      const double along = (at - s0).dot(s1 - s0) / std::max((s1 - s0).squaredNorm(), 1e-300);
      if (along < -1e-9 || along > 1 + 1e-9) continue;
      const double from_inside = inside_[x.a] ? t : 1 - t;
      if (from_inside < nearest) nearest = from_inside, best = t;
    }
    if (best < 0) {
      auto off = [&](const Vec3& p) {
        double d = std::numeric_limits<double>::infinity();
        const Vec2 s = seen_at(p);
        for (std::size_t i = 0; i < n; ++i) {
          const Vec2 s0 = loop_[i], s1 = loop_[(i + 1) % n];
          const double u = std::clamp((s - s0).dot(s1 - s0) / std::max((s1 - s0).squaredNorm(), 1e-300), 0.0, 1.0);
          d = std::min(d, (s0 + u * (s1 - s0) - s).norm());
        }
        return d;
      };
      best = off(pa) <= off(pb) ? 0.0 : 1.0;
    }
    x.t = best;
    x.point = (1 - best) * pa + best * pb;
    return x;
  }

  // A line given by where its points lie on the cloth: straight in the pattern from point to point,
  // wherever folds have taken the cloth. The points' uv are read once, before vertices are moved
  // onto the line (their faces' uv move with them).
  void follow_pattern() {
    const Mesh& m = g_.mesh();
    if (pattern_at_.empty()) {
      if (line_.faces.size() != line_.points.size() || line_.weights.size() != line_.points.size())
        throw InputError("cut: a line that follows the pattern needs a face and weights for each of its points");
      if (line_.from || line_.to || !line_.sweeps.empty())
        throw InputError("cut: a line that follows the pattern lies on the cloth from end to end, with no view rays");
      std::vector<int> index(m.number_of_faces() + m.number_of_removed_faces(), -1);
      int i = 0;
      for (Face f : m.faces()) index[f.idx()] = i++;
      for (std::size_t k = 0; k < line_.faces.size(); ++k) {
        const Face f = line_.faces[k];
        const Vec3& w = line_.weights[k];
        if (f == Mesh::null_face() || f.idx() >= index.size() || index[f.idx()] < 0)
          throw InputError("cut: point " + std::to_string(k) + " of the line is on no face of garment '" + g_.name + "'");
        if (!w.allFinite() || w.minCoeff() < -1e-6 || std::abs(w.sum() - 1) > 1e-6)
          throw InputError("cut: point " + std::to_string(k) + " of the line has weights that are not a point of its face");
        const auto& uv = s_.uvs[index[f.idx()]];
        pattern_at_.emplace_back(index[f.idx()], Vec3(w[0] * uv[0].x() + w[1] * uv[1].x() + w[2] * uv[2].x(),
                                                      w[0] * uv[0].y() + w[1] * uv[1].y() + w[2] * uv[2].y(), 0));
      }
      // A stroke drawn over a fold touches its layers in turn: in the pattern its line jumps from
      // one layer's cloth to the other's, or crosses itself, and would cut out what lies between.
      for (std::size_t k = 0; k + 1 < pattern_at_.size(); ++k) {
        const double on_pattern = (pattern_at_[k + 1].second - pattern_at_[k].second).norm() * g_.pattern_scale();
        const double on_cloth = (line_.points[k + 1] - line_.points[k]).norm();
        if (on_pattern > std::max(3 * on_cloth, kPatternJump)) {
          std::ostringstream msg;
          msg << std::fixed << std::setprecision(1) << "cut: between points " << k << " and " << k + 1
              << " the line goes " << 100 * on_pattern
              << " cm in the pattern for " << 100 * on_cloth << " cm on the cloth (the stroke went from one layer "
              << "of a fold to another); draw it on one layer, or let it follow the surface";
          throw InputError(msg.str());
        }
      }
      if (crosses_itself(pattern_at_, line_.closed))
        throw InputError("cut: the line crosses itself in the pattern (its points lie on different layers of a fold); "
                         "draw it on one layer, or let it follow the surface");
    }
    Walker walker(s_, adj_);
    walker.in_pattern();
    Cursor c{pattern_at_[0].first, pattern_at_[0].second, -1};
    followed_.push_back(line_.points.front());
    bool on_cloth = true;
    for (std::size_t i = 1; i < pattern_at_.size() && on_cloth; ++i) {
      std::vector<Crossing> part;
      on_cloth = follow(walker.walk(c, pattern_at_[i].second, part), part);
    }
    closed_ = line_.closed && on_cloth && crossings_.size() >= 2;
    if (closed_) {
      const Crossing first = crossings_.front();
      const auto& f = s_.faces[first.from];
      int ka = 0, kb = 0;
      while (f[ka] != first.a) ++ka;
      while (f[kb] != first.b) ++kb;
      std::vector<Crossing> part;
      follow(walker.walk(c, (1 - first.t) * walker.corner(first.from, ka) + first.t * walker.corner(first.from, kb), part),
             part);
      settle_closing(first);
    } else if (on_cloth) {
      followed_.push_back(line_.points.back());
    }
  }

  // Whether the polyline through the points' uv (closed: back to the first) crosses itself.
  static bool crosses_itself(const std::vector<std::pair<int, Vec3>>& at, bool closed) {
    const std::size_t n = at.size(), segments = closed ? n : n - 1;
    auto cross = [](const Vec3& o, const Vec3& a, const Vec3& b) {
      return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
    };
    for (std::size_t i = 0; i < segments; ++i)
      for (std::size_t j = i + 2; j < segments; ++j) {
        if (closed && i == 0 && j == segments - 1) continue;  // the two neighbours of the first point
        const Vec3 &a = at[i].second, &b = at[(i + 1) % n].second, &c = at[j].second, &d = at[(j + 1) % n].second;
        if (cross(a, b, c) * cross(a, b, d) < 0 && cross(c, d, a) * cross(c, d, b) < 0) return true;
      }
    return false;
  }

  // The way a line that went through `went` (in order) was heading at `at`: from the last point
  // short of it; `otherwise` where it has not moved.
  static Vec3 heading(const std::vector<Vec3>& went, const Vec3& at, const Vec3& otherwise) {
    const double tiny = 1e-9 * (1.0 + at.norm());
    for (auto it = went.rbegin(); it != went.rend(); ++it)
      if ((at - *it).norm() > tiny) return at - *it;
    return otherwise;
  }

  bool run_on(Walker& walker, Cursor& c, const Vec3& direction) {
    std::vector<Crossing> part;
    return follow(walker.run(c, direction, part), part);
  }

  bool step(Walker& walker, Cursor& c, const Vec3& target) {
    std::vector<Crossing> part;
    return follow(walker.walk(c, target, part), part);
  }

  bool swept() const { return line_.sweeps.size() == line_.points.size(); }

  // To the line's point i: along the sheet its stroke swept (from the last point's sweep direction
  // through the cursor and point i, to point i's), or over the surface towards it.
  bool step(Walker& walker, Cursor& c, std::size_t i) {
    const Vec3& target = line_.points[i];
    if (!swept()) return step(walker, c, target);
    const Vec3 ahead = target - c.point;
    const std::size_t from = i == 0 ? line_.points.size() - 1 : i - 1;
    const Vec3 normal = ahead.cross(line_.sweeps[from]);
    Vec3 stop = normal.cross(line_.sweeps[i]);
    if (!(normal.norm() > 1e-12 * (1 + ahead.norm())) || !(stop.norm() > 0)) return step(walker, c, target);
    if ((c.point - target).dot(stop) > 0) stop = -stop;
    std::vector<Crossing> part;
    return follow(walker.sweep(c, normal.normalized(), target, stop.normalized(), part), part);
  }

  // Takes a walk's crossings into the line; returns whether the walk is still on the cloth.
  bool follow(bool on, const std::vector<Crossing>& part) {
    for (const Crossing& x : part) {
      crossings_.push_back(x);
      followed_.push_back(x.point);
    }
    return on;
  }

  // --- 2. a vertex for each crossing ---
  bool move_vertices_onto_line() {
    for (const Crossing& x : crossings_) {
      const bool near_a = x.t < kMoveVertex, near_b = 1.0 - x.t < kMoveVertex;
      if (!near_a && !near_b) continue;
      const Index w = (near_a && (!near_b || x.t <= 1.0 - x.t)) ? x.a : x.b;
      const Index other = w == x.a ? x.b : x.a;
      // A border vertex moves only along the border, which keeps the border's line.
      if (moved_.count(w) || s_.vertices[w].inverse_mass == 0.0 || (border_[w] && !adj_.border(edge_key(x.a, x.b))))
        continue;
      move_onto_line(w, other, x);
    }
    return !moved_.empty();
  }

  void resolve() {
    std::vector<Index> at(crossings_.size());
    for (std::size_t i = 0; i < crossings_.size(); ++i) at[i] = vertex_for(crossings_[i]);
    drop_rounding_loops(at);
    // The line's pieces: between consecutive crossings, across the face they share.
    // A piece lies across the face the first crossing enters, when the second lies on that face's
    // edges (on one of them, or at a corner).
    auto on_face = [&](std::size_t j, int face) {
      const auto& f = s_.faces[face];
      const Crossing& x = crossings_[j];
      int has = 0;
      for (Index v : f) has += (v == x.a) + (v == x.b);
      return has == 2 || std::count(f.begin(), f.end(), at[j]) > 0;
    };
    auto piece = [&](std::size_t i, std::size_t j) {
      if (at[i] == at[j]) return true;
      const int face = crossings_[i].to;
      if (face < 0 || !on_face(j, face)) return false;
      chords_[face].emplace_back(at[i], at[j]);
      return true;
    };
    for (std::size_t i = 0; i + 1 < crossings_.size(); ++i) piece(i, i + 1);
    if (closed_ && !piece(crossings_.size() - 1, 0)) closed_ = false;
    for (Index v : at)
      if (path_.empty() || path_.back() != v) path_.push_back(v);
    if (closed_ && path_.size() > 1 && path_.front() == path_.back()) path_.pop_back();
    for (const auto& [face, chords] : chords_)
      for (const auto& [a, b] : chords) segments_.insert(edge_key(a, b));
  }

  // Where both ends of an edge lie on the line (each moved onto it), which end its crossing takes is
  // rounding: the line can leave a vertex for its neighbours and come back, round a sliver of its
  // ring that opening the line would cut off as a piece of its own. Such a loop, within the ring of
  // the vertex it leaves and returns to, is dropped. A closed line has no start, so a loop over its
  // end is found after turning it half round.
  void drop_rounding_loops(std::vector<Index>& at) {
    auto neighbours = [&](Index v, Index w) {
      if (v >= inc_.size()) return false;
      for (Index f : inc_[v])
        for (Index u : s_.faces[f])
          if (u == w) return true;
      return false;
    };
    auto pass = [&](std::vector<std::size_t>& order) {
      std::vector<std::size_t> kept;
      for (std::size_t i : order) {
        const Index v = at[i];
        if (!kept.empty() && at[kept.back()] != v) {
          // A loop within one vertex's ring crosses few edges: no need to look further back.
          std::size_t p = kept.size();
          while (p > 0 && at[kept[p - 1]] != v && kept.size() - p < 32) --p;
          if (p > 0 && at[kept[p - 1]] != v) p = 0;
          auto in_ring = [&](std::size_t k) {
            const Crossing& x = crossings_[k];
            return neighbours(v, at[k]) || ((x.a == v || neighbours(v, x.a)) && (x.b == v || neighbours(v, x.b)));
          };
          if (p > 0 && std::all_of(kept.begin() + p, kept.end(), in_ring))
            kept.resize(p);
        }
        kept.push_back(i);
      }
      order = std::move(kept);
    };
    std::vector<std::size_t> order(at.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    pass(order);
    if (closed_ && order.size() > 2) {
      std::rotate(order.begin(), order.begin() + order.size() / 2, order.end());
      pass(order);
    }
    if (order.size() == at.size()) return;
    std::vector<Crossing> crossings;
    std::vector<Index> kept_at;
    for (std::size_t i : order) crossings.push_back(crossings_[i]), kept_at.push_back(at[i]);
    crossings_ = std::move(crossings);
    at = std::move(kept_at);
  }

  Index vertex_for(const Crossing& x) {
    const bool near_a = x.t < kThroughVertex, near_b = 1.0 - x.t < kThroughVertex;
    if (near_a || near_b) return (near_a && (!near_b || x.t <= 1.0 - x.t)) ? x.a : x.b;
    // A new vertex on the edge, unless one is already close on it (the line crossed it twice).
    auto& points = on_edge_[edge_key(x.a, x.b)];
    for (const auto& [t, v] : points)
      if (std::abs(t - x.t) < kThroughVertex) return v;
    VertexData d;
    d.alive = true;
    d.position = x.point;
    d.velocity = (1 - x.t) * s_.vertices[x.a].velocity + x.t * s_.vertices[x.b].velocity;
    d.inverse_mass = 1.0;
    const Index v = s_.add_vertex(d);
    points.emplace_back(x.t, v);
    made_.insert(v);
    return v;
  }

  // Moves vertex w along its edge to `other` onto the crossing, in space and in its pattern (uv),
  // if every face around it keeps its orientation and most of its area, and w's faces share one uv
  // there (no uv seam through it). Returns false, changing nothing, otherwise.
  bool move_onto_line(Index w, Index other, const Crossing& x) {
    const double share = w == x.a ? x.t : 1.0 - x.t;
    // The move in uv, from a face with the edge (w, other).
    Vec2 uv_w = Vec2::Zero(), delta = Vec2::Zero();
    bool found = false;
    for (Index f : inc_[w]) {
      const auto& face = s_.faces[f];
      int kw = -1, ko = -1;
      for (int k = 0; k < 3; ++k) {
        if (face[k] == w) kw = k;
        if (face[k] == other) ko = k;
      }
      if (ko < 0) continue;
      uv_w = s_.uvs[f][kw];
      delta = share * (s_.uvs[f][ko] - uv_w);
      found = true;
      break;
    }
    if (!found) return false;
    std::vector<std::pair<Index, int>> corners;
    for (Index f : inc_[w]) {
      const auto& face = s_.faces[f];
      int kw = 0;
      while (face[kw] != w) ++kw;
      if ((s_.uvs[f][kw] - uv_w).norm() > 1e-9) return false;  // a uv seam runs through w
      const auto& uv = s_.uvs[f];
      auto area = [&](const Vec2& p0, const Vec2& p1, const Vec2& p2) {
        return (p1 - p0).x() * (p2 - p0).y() - (p1 - p0).y() * (p2 - p0).x();
      };
      std::array<Vec2, 3> moved = uv;
      moved[kw] += delta;
      const double before = area(uv[0], uv[1], uv[2]), after = area(moved[0], moved[1], moved[2]);
      if (!(std::abs(before) > 0) || after / before < 0.2) return false;
      if (smallest_angle(moved) < std::min(kSmallestAngle, smallest_angle(uv))) return false;
      corners.emplace_back(f, kw);
    }
    for (const auto& [f, kw] : corners) {
      original_uvs_.emplace(f, s_.uvs[f]);
      s_.uvs[f][kw] += delta;
    }
    VertexData& d = s_.vertices[w];
    const Index o = other;
    d.velocity = (1 - share) * d.velocity + share * s_.vertices[o].velocity;
    d.position = x.point;
    moved_.insert(w);
    return true;
  }

  // --- 3. the faces crossed, triangulated again with the line's pieces as edges ---
  void rebuild_faces() {
    std::set<Index> touched;
    for (const auto& [key, points] : on_edge_) {
      const auto it = adj_.faces.find(key);
      for (int f : it->second)
        if (f >= 0) touched.insert(Index(f));
      // Along each edge, from its smaller vertex to its larger.
    }
    for (auto& [key, points] : on_edge_) std::sort(points.begin(), points.end());
    for (const auto& [face, chords] : chords_) touched.insert(Index(face));
    // Faces whose edge data must be measured again: those rebuilt and those around a moved vertex.
    std::set<Index> remeasure(touched.begin(), touched.end());
    for (Index w : moved_)
      for (Index f : inc_[w]) remeasure.insert(f);
    // Each original face's rest metric: rest length per unit of uv, and tear threshold per rest length.
    std::map<Index, std::pair<double, double>> metric;
    for (Index f : remeasure) metric[f] = face_metric(f);

    std::vector<char> drop(s_.faces.size(), 0);
    struct NewFace {
      std::array<Index, 3> v;
      std::array<Vec2, 3> uv;
      int panel;
      Index from;
    };
    std::vector<NewFace> made;
    for (Index f : touched) {
      drop[f] = 1;
      const auto face = s_.faces[f];
      const auto uv = s_.uvs[f];
      // The boundary: each corner, then the points on the edge to the next corner.
      std::vector<Index> ring;
      std::vector<Vec2> ring_uv;
      std::vector<int> edge_of;  // the original edge (0..2) a point lies on; a corner k: 3 + k
      for (int k = 0; k < 3; ++k) {
        const Index a = face[k], b = face[(k + 1) % 3];
        ring.push_back(a);
        ring_uv.push_back(uv[k]);
        edge_of.push_back(3 + k);
        const auto it = on_edge_.find(edge_key(a, b));
        if (it == on_edge_.end()) continue;
        std::vector<std::pair<double, Index>> along = it->second;
        if (a > b) {
          for (auto& [t, v] : along) t = 1.0 - t;
          std::sort(along.begin(), along.end());
        }
        const Vec2 ua = uv[k], ub = uv[(k + 1) % 3];
        for (const auto& [t, v] : along) {
          ring.push_back(v);
          ring_uv.push_back((1 - t) * ua + t * ub);
          edge_of.push_back(k);
        }
      }
      // The line's pieces across this face, as ring positions; a piece along an edge needs no split.
      std::vector<std::pair<int, int>> chords;
      const auto found = chords_.find(int(f));
      if (found != chords_.end())
        for (const auto& [p, q] : found->second) {
          const int i = int(std::find(ring.begin(), ring.end(), p) - ring.begin());
          const int j = int(std::find(ring.begin(), ring.end(), q) - ring.begin());
          if (i >= int(ring.size()) || j >= int(ring.size()))
            throw TopologyError("cut: the line's piece across a face does not end on the face's edges");
          if (same_side(edge_of, i, j)) {
            segments_.erase(edge_key(p, q));
            mark_along(ring, edge_of, i, j);
            continue;
          }
          chords.emplace_back(i, j);
        }
      // 2D coordinates to measure angles in: the uv, or the face's plane where the uv is flat.
      std::vector<Vec2> flat = ring_uv;
      if (!(std::abs(area2(ring_uv[0], ring_uv[index_of_corner(edge_of, 1)], ring_uv[index_of_corner(edge_of, 2)])) >
            1e-18))
        flat = plane_coordinates(ring);
      std::vector<int> all(ring.size());
      std::iota(all.begin(), all.end(), 0);
      for (const auto& tri : split_and_triangulate(all, chords, flat))
        made.push_back({{ring[tri[0]], ring[tri[1]], ring[tri[2]]},
                        {ring_uv[tri[0]], ring_uv[tri[1]], ring_uv[tri[2]]},
                        s_.panels[f],
                        f});
    }
    // Edge data: kept where an edge is as it was; else measured in the uv of each face it borders.
    std::unordered_map<std::uint64_t, std::pair<EdgeData, int>> measured;
    auto measure = [&](const std::array<Index, 3>& v, const std::array<Vec2, 3>& uv, Index from) {
      const auto [per_uv, tear] = metric.at(from);
      for (int k = 0; k < 3; ++k) {
        const Index a = v[k], b = v[(k + 1) % 3];
        const std::uint64_t key = edge_key(a, b);
        const bool same = !made_.count(a) && !made_.count(b) && !moved_.count(a) && !moved_.count(b) &&
                          s_.edges.count(key) && !on_edge_.count(key);
        if (same) continue;
        double rest = per_uv > 0 ? per_uv * (uv[(k + 1) % 3] - uv[k]).norm()
                                 : (s_.vertices[b].position - s_.vertices[a].position).norm();
        auto& [data, n] = measured[key];
        data.rest += rest;
        data.threshold += tear * rest;
        ++n;
      }
    };
    for (const NewFace& nf : made) measure(nf.v, nf.uv, nf.from);
    for (Index f : remeasure)
      if (!drop[f]) measure(s_.faces[f], s_.uvs[f], f);
    for (const auto& [key, points] : on_edge_) s_.edges.erase(key);
    for (auto& [key, value] : measured) {
      auto& [data, n] = value;
      s_.edges[key] = {data.rest / n, data.threshold / n};
    }
    s_.erase_faces(drop);
    for (const NewFace& nf : made) s_.add_face(nf.v, nf.uv, nf.panel);
  }

  // Rest length per unit of uv over a face's edges (0 where its uv is flat: rest lengths follow the
  // positions then), and tear threshold per rest length.
  std::pair<double, double> face_metric(Index f) const {
    const auto& face = s_.faces[f];
    double rest = 0, uv = 0, threshold = 0;
    for (int k = 0; k < 3; ++k) {
      const auto it = s_.edges.find(edge_key(face[k], face[(k + 1) % 3]));
      const EdgeData d = it != s_.edges.end() ? it->second : EdgeData{};
      rest += d.rest;
      threshold += d.threshold;
      uv += (original_uv(f, (k + 1) % 3) - original_uv(f, k)).norm();
    }
    const double tear = rest > 0 ? threshold / rest : g_.material().tear_ratio;
    return {uv > 1e-12 ? rest / uv : 0.0, tear};
  }

  // A corner's uv before any vertex was moved onto the line.
  Vec2 original_uv(Index f, int k) const {
    const auto it = original_uvs_.find(f);
    return it != original_uvs_.end() ? it->second[k] : s_.uvs[f][k];
  }

  static double smallest_angle(const std::array<Vec2, 3>& q) {
    double smallest = 180;
    for (int k = 0; k < 3; ++k) {
      const Vec2 u = q[(k + 1) % 3] - q[k], v = q[(k + 2) % 3] - q[k];
      if (!(u.norm() > 0 && v.norm() > 0)) return 0;
      smallest = std::min(smallest, std::acos(std::clamp(u.dot(v) / (u.norm() * v.norm()), -1.0, 1.0)) * 180 / M_PI);
    }
    return smallest;
  }

  static double area2(const Vec2& a, const Vec2& b, const Vec2& c) {
    return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
  }
  static int index_of_corner(const std::vector<int>& edge_of, int k) {
    return int(std::find(edge_of.begin(), edge_of.end(), 3 + k) - edge_of.begin());
  }
  // Whether ring positions i and j lie on one edge of the original face (a corner counts for both
  // its edges).
  static bool same_side(const std::vector<int>& edge_of, int i, int j) {
    auto sides = [&](int p) {
      const int e = edge_of[p];
      return e >= 3 ? std::array<int, 2>{e - 3, (e - 3 + 2) % 3} : std::array<int, 2>{e, e};
    };
    for (int a : sides(i))
      for (int b : sides(j))
        if (a == b) return true;
    return false;
  }
  // A piece of the line along an edge: the pieces of the edge between its ends are cut.
  void mark_along(const std::vector<Index>& ring, const std::vector<int>& edge_of, int i, int j) {
    (void)edge_of;
    const int n = int(ring.size());
    // The shorter way round the ring between i and j runs along the edge.
    const int forward = (j - i + n) % n, backward = (i - j + n) % n;
    const int step = forward <= backward ? 1 : -1;
    for (int p = i; p != j; p = (p + step + n) % n) segments_.insert(edge_key(ring[p], ring[(p + step + n) % n]));
  }

  std::vector<Vec2> plane_coordinates(const std::vector<Index>& ring) const {
    const Vec3 o = pos(ring[0]);
    Vec3 n = Vec3::Zero();
    for (std::size_t i = 1; i + 1 < ring.size(); ++i) n += (pos(ring[i]) - o).cross(pos(ring[i + 1]) - o);
    n = n.norm() > 0 ? Vec3(n.normalized()) : Vec3::UnitZ();
    Vec3 u = n.unitOrthogonal(), w = n.cross(u);
    std::vector<Vec2> out;
    for (Index v : ring) out.emplace_back((pos(v) - o).dot(u), (pos(v) - o).dot(w));
    return out;
  }

  // Splits the polygon (ring positions, in order) at the first chord between two of its corners
  // that are not neighbours, recursively; then triangulates each part.
  static std::vector<std::array<int, 3>> split_and_triangulate(const std::vector<int>& poly,
                                                              const std::vector<std::pair<int, int>>& chords,
                                                              const std::vector<Vec2>& flat) {
    const int n = int(poly.size());
    for (const auto& [p, q] : chords) {
      const int i = int(std::find(poly.begin(), poly.end(), p) - poly.begin());
      const int j = int(std::find(poly.begin(), poly.end(), q) - poly.begin());
      if (i >= n || j >= n) continue;
      const int gap = (j - i + n) % n;
      if (gap <= 1 || gap >= n - 1) continue;  // neighbours: already an edge
      std::vector<int> one, two;
      for (int k = i;; k = (k + 1) % n) {
        one.push_back(poly[k]);
        if (k == j) break;
      }
      for (int k = j;; k = (k + 1) % n) {
        two.push_back(poly[k]);
        if (k == i) break;
      }
      // A chord that crosses this one has an end on each side.
      for (const auto& [r, s] : chords) {
        const bool r1 = std::count(one.begin(), one.end(), r) && r != p && r != q;
        const bool s1 = std::count(one.begin(), one.end(), s) && s != p && s != q;
        const bool r2 = std::count(two.begin(), two.end(), r) && r != p && r != q;
        const bool s2 = std::count(two.begin(), two.end(), s) && s != p && s != q;
        if ((r1 && s2) || (r2 && s1))
          throw InputError("cut: the line crosses itself inside one triangle (as it does where it runs over folds "
                           "from one layer to another); draw it on one layer, or in shorter strokes");
      }
      auto a = split_and_triangulate(one, chords, flat);
      auto b = split_and_triangulate(two, chords, flat);
      a.insert(a.end(), b.begin(), b.end());
      return a;
    }
    std::vector<Vec2> q;
    for (int p : poly) q.push_back(flat[p]);
    std::vector<std::array<int, 3>> out;
    for (const auto& t : best_triangulation(q)) out.push_back({poly[t[0]], poly[t[1]], poly[t[2]]});
    return out;
  }

  // --- 4. the line opened ---
  void open(KnifeCut& out) {
    const auto inc = s_.incidence();
    std::set<Index> on_line;
    for (std::uint64_t key : segments_) {
      on_line.insert(Index(key >> 32));
      on_line.insert(Index(key & 0xffffffffu));
    }
    for (Index v : path_) out.opening.push_back(Vertex(v));
    for (Index v : made_) out.created.push_back(Vertex(v));
    for (Index v : on_line) {
      const auto& fs = inc[v];
      if (fs.size() < 2) continue;
      // Faces around v joined across each edge (v, w) that the line does not cut.
      std::vector<std::size_t> parent(fs.size());
      std::iota(parent.begin(), parent.end(), 0);
      auto find = [&](std::size_t i) {
        while (parent[i] != i) i = parent[i] = parent[parent[i]];
        return i;
      };
      std::unordered_map<Index, std::size_t> first_with;
      for (std::size_t i = 0; i < fs.size(); ++i)
        for (Index w : s_.faces[fs[i]]) {
          if (w == v || segments_.count(edge_key(v, w))) continue;
          auto [it, fresh] = first_with.emplace(w, i);
          if (!fresh) parent[find(i)] = find(it->second);
        }
      std::map<std::size_t, Index> vertex_of;
      for (std::size_t i = 0; i < fs.size(); ++i) {
        const std::size_t r = find(i);
        auto it = vertex_of.find(r);
        if (it == vertex_of.end()) {
          const Index nv = vertex_of.empty() ? v : s_.add_vertex(s_.vertices[v]);
          if (nv != v) out.created.push_back(Vertex(nv));
          it = vertex_of.emplace(r, nv).first;
        }
        if (it->second == v) continue;
        for (Index& c : s_.faces[fs[i]])
          if (c == v) c = it->second;
        for (Index w : s_.faces[fs[i]]) {
          if (w == it->second) continue;
          const auto e = s_.edges.find(edge_key(v, w));
          if (e != s_.edges.end()) s_.edges.emplace(edge_key(it->second, w), e->second);
        }
      }
    }
  }

  const Vec3& pos(Index v) const { return s_.vertices[v].position; }

  const Garment& g_;
  const KnifeLine& line_;
  Soup s_;
  Adjacency adj_;
  std::vector<Crossing> crossings_;
  std::vector<Vec3> followed_;
  bool closed_ = false;
  std::vector<char> border_;
  std::vector<std::vector<Index>> inc_;
  std::set<Index> moved_, made_;
  std::map<Index, std::array<Vec2, 3>> original_uvs_;
  std::unordered_map<std::uint64_t, std::vector<std::pair<double, Index>>> on_edge_;
  std::map<int, std::vector<std::pair<Index, Index>>> chords_;
  std::set<std::uint64_t> segments_;
  std::vector<Index> path_;
  std::vector<std::pair<int, Vec3>> pattern_at_;  // a pattern line's points: face and uv
  // A line as seen (follow_seen): the view, the stroke across it, and which vertices are inside.
  bool seen_ = false, perspective_ = false;
  Vec3 eye_ = Vec3::Zero(), axis_ = Vec3::UnitZ(), side_ = Vec3::UnitX(), up_ = Vec3::UnitY();
  std::vector<Vec2> loop_;
  std::vector<char> inside_;
};

}  // namespace

KnifeCut cut_line(Garment& g, const KnifeLine& line) {
  if (line.sweeps.empty()) return Knife(g, line).run(&g);
  // Drawn in a view, the line follows the sheet its rays sweep; the faces the stroke touched, where
  // given, are for a closed line (below).
  KnifeLine in_view = line;
  in_view.faces.clear();
  in_view.weights.clear();
  if (!line.closed) return Knife(g, in_view).run(&g);
  // A closed line cuts out what it encloses: one more piece, and two more border loops (the
  // opening's and the piece's). It cuts round the cloth it encloses as seen, where it knows the
  // faces the stroke touched; else (or where that is not one line: the cloth inside meets the
  // border) along the sheet of its rays, which can miss where the surface is steep to the view or
  // run down a fold's wall; failing that, the sheet's cut stands if it made a piece, and otherwise
  // the line is walked over the surface.
  const std::size_t pieces = g.count_pieces(), loops = border_loops(g).size();
  auto cuts_out = [&](const Garment& cut) {
    return cut.count_pieces() == pieces + 1 && border_loops(cut).size() == loops + 2;
  };
  if (!line.faces.empty()) {
    Garment seen = g;
    try {
      const KnifeCut cut = Knife(g, line, /*seen=*/true).run(&seen);
      if (cuts_out(seen)) {
        g = std::move(seen);
        return cut;
      }
    } catch (const InputError&) {
      // the next way may cut it
    }
  }
  Garment swept = g;
  std::optional<KnifeCut> swept_cut;
  try {
    swept_cut = Knife(g, in_view).run(&swept);
  } catch (const InputError&) {
    // the walk, the last way, reports its own error if it has one
  }
  if (swept_cut && cuts_out(swept)) {
    g = std::move(swept);
    return *swept_cut;
  }
  if (swept_cut && swept.count_pieces() > pieces) {
    g = std::move(swept);
    return *swept_cut;
  }
  KnifeLine walked = in_view;
  walked.sweeps.clear();
  return Knife(g, walked).run(&g);
}

bool knife_line_closes(const std::vector<Vec3>& points, double within) {
  if (!(within > 0) || points.size() < 4) return false;
  double away = 0;
  for (const Vec3& p : points) away = std::max(away, (p - points.front()).norm());
  return (points.back() - points.front()).norm() <= within && away > 2 * within;
}

std::vector<Vec3> trace_line(const Garment& g, const KnifeLine& line) {
  if (line.sweeps.empty() || line.faces.empty()) return Knife(g, line).run(nullptr).line;
  KnifeLine in_view = line;  // the sheet's line (a closed one may be cut otherwise: cut_line)
  in_view.faces.clear();
  in_view.weights.clear();
  return Knife(g, in_view).run(nullptr).line;
}

}  // namespace kiji

