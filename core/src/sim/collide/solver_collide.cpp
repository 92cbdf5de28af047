// Collisions for the solver: cloth against the body and cloth against itself.
//
//  - body: each substep, every moving vertex looks up its cell of the body's distance field
//    (body_field.h): far from the body it is done; near it, it is tested exactly against the few
//    triangles the cell lists. A vertex that moved further than a cell in the substep (a flick of
//    the pen) is tested against what the body's Bullet tree finds along its motion;
//  - self: culling happens once per window of substeps, and the substeps run exact tests on the
//    pairs found: two Bullet btDbvt trees (leaves: clusters of 8 cloth vertices, of 8 cloth triangles),
//    refitted to the swept boxes at each gather and intersected with each other, give vertex-
//    triangle pairs (a vertex never with the triangles of its own neighbourhood); pairs that cannot
//    come within the thickness during the window are dropped, and each keeps the side it started
//    on. The window is the whole step for cloth at rest and a few substeps for cloth moving fast
//    relative to itself (self_window in solver_xpbd.cpp).
#include "base/geometry.h"
#include "base/parallel.h"
#include "sim/collide/body_field.h"
#include "sim/collide/self_pairs.h"
#include "sim/solver_state.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <unordered_map>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace kiji::solver_detail {

namespace {
// How far beyond the thickness a vertex over an upward surface still counts as held up by it, as a
// share of the thickness (resolve_body_against): 0.1-0.25 mm, several times what gravity moves
// resting cloth in a substep.
constexpr double kHeldMargin = 0.05;

// The box swept by vertex i over the step's predicted motion (less a common motion `c`, for
// culling in a moving frame), grown by `pad`, plus `slack` times that motion (room for constraint
// corrections the prediction does not know), plus how far the vertex ended from its prediction in
// the last step (a hand, a seam closing or the strain limit can carry a vertex further than its
// own motion would: without this it could pass a body triangle that is not among its candidates,
// and stay inside). Self-collision passes that miss less the cloth's mean miss: in its moving
// frame a falling cloth's common g dt^2 is no motion (at 100,000 vertices, 3 mm spacing, it had
// grown every vertex's box by more than the spacing).
Box3 swept_box(const SolverArrays& s, const std::vector<Vec3>& motion, const std::vector<double>& surprise,
               double surprise_scale, int i, double pad, double slack, const Vec3& c = Vec3::Zero()) {
  const Vec3& a = s.x[i];
  const Vec3 m = motion[i] - c;
  const Vec3 b = a + m;
  const double e = pad + slack * m.norm() + (surprise.size() == s.n ? surprise_scale * surprise[i] : 0.0);
  return Box3(a.cwiseMin(b) - Vec3::Constant(e), a.cwiseMax(b) + Vec3::Constant(e));
}

// A cell of a uniform grid as one key (21 bits an axis: cells of 2 cm reach 20 km each way).
std::uint64_t cell_key(std::int64_t x, std::int64_t y, std::int64_t z) {
  return (std::uint64_t(x & 0x1fffff) << 42) | (std::uint64_t(y & 0x1fffff) << 21) | std::uint64_t(z & 0x1fffff);
}

void refit(btDbvtNode* node) {
  if (node->isleaf()) return;
  refit(node->childs[0]);
  refit(node->childs[1]);
  Merge(node->childs[0]->volume, node->childs[1]->volume, node->volume);
}
}  // namespace

void set_body(SolverArrays& s, const Body* body) {
  s.body = body;
  s.field = nullptr;  // made for the cloth's thickness at its first step (prepare_body_field)
  s.sleep_ready = false;  // a new body: everything wakes
  s.body_tris.clear();
  s.body_boxes.clear();
  s.body_bounds.setEmpty();
  s.body_points.clear();
  s.point_pairs.clear();
  if (!body) return;
  const auto& V = body->vertices();
  const auto& T = body->triangles();
  s.body_tris.reserve(T.size());
  s.body_boxes.reserve(T.size());
  for (std::size_t t = 0; t < T.size(); ++t) {
    SolverArrays::BodyTri bt{V[T[t][0]], V[T[t][1]], V[T[t][2]], body->triangle_normal(t)};
    Box3 b;
    b.extend(bt.a);
    b.extend(bt.b);
    b.extend(bt.c);
    if (BodyCollider::degenerate(*body, t)) b.setEmpty();  // no candidate (see BodyCollider)
    s.body_tris.push_back(bt);
    s.body_boxes.push_back(b);
    s.body_bounds.extend(b);
  }
  // Only a body rounded from a low-poly one has points thinner than the cloth's spacing after
  // rounding; a fine body's fingertips only catch cloth pulled past them (a sewn armhole).
  if (body->report().smoothing > 0) find_body_points(s, *body);
}

// --- The body's sharp points against the cloth's triangles ---

void find_body_points(SolverArrays& s, const Body& body) {
  s.body_points.clear();
  const auto& V = body.vertices();
  const auto& T = body.triangles();
  // The angle each vertex leaves of a full turn (its angle defect: 0 where the surface is flat).
  std::vector<double> defect(V.size(), 0.0);
  std::vector<char> used(V.size(), 0);
  for (const auto& t : T)
    for (int k = 0; k < 3; ++k) {
      const Vec3 u = V[t[(k + 1) % 3]] - V[t[k]], w = V[t[(k + 2) % 3]] - V[t[k]];
      const double c = u.dot(w) / std::max(1e-300, u.norm() * w.norm());
      defect[t[k]] -= std::acos(std::clamp(c, -1.0, 1.0));
      used[t[k]] = 1;
    }
  // The body's points: where the defects within kPointRadius sum to over 90 degrees, the curvature
  // of a cap under 3 cm across: a fingertip, the tip of a horn or of an ear, however finely it is
  // meshed (a sphere the size of a head sums to 4 degrees there).
  constexpr double kPointRadius = 0.02;
  std::unordered_map<std::uint64_t, std::vector<int>> grid;
  auto cell = [](double c) { return static_cast<std::int64_t>(std::floor(c / kPointRadius)); };
  auto key = cell_key;
  for (std::size_t i = 0; i < V.size(); ++i) {
    if (!used[i]) continue;
    defect[i] += 2 * M_PI;
    if (std::abs(defect[i]) > 1e-9) grid[key(cell(V[i].x()), cell(V[i].y()), cell(V[i].z()))].push_back(int(i));
  }
  for (std::size_t i = 0; i < V.size(); ++i) {
    if (!used[i]) continue;
    double sum = 0;
    const std::int64_t cx = cell(V[i].x()), cy = cell(V[i].y()), cz = cell(V[i].z());
    for (std::int64_t x = cx - 1; x <= cx + 1; ++x)
      for (std::int64_t y = cy - 1; y <= cy + 1; ++y)
        for (std::int64_t z = cz - 1; z <= cz + 1; ++z) {
          const auto it = grid.find(key(x, y, z));
          if (it == grid.end()) continue;
          for (int j : it->second)
            if ((V[j] - V[i]).squaredNorm() < kPointRadius * kPointRadius) sum += defect[j];
        }
    if (sum > M_PI / 2) s.body_points.push_back(V[i]);
  }
}

void gather_point_pairs(SolverArrays& s, double thickness) {
  s.point_pairs.clear();
  if (s.body_points.empty()) return;
  // The points in cells of a grid; each cloth triangle looks in the cells its swept box covers.
  Box3 points_box;
  for (const Vec3& p : s.body_points) points_box.extend(p);
  const double cell = std::max(0.05, 4 * thickness);
  auto key = cell_key;
  auto cell_of = [&](double c) { return static_cast<std::int64_t>(std::floor(c / cell)); };
  std::unordered_map<std::uint64_t, std::vector<int>> grid;
  for (int k = 0; k < static_cast<int>(s.body_points.size()); ++k) {
    const Vec3& p = s.body_points[k];
    grid[key(cell_of(p.x()), cell_of(p.y()), cell_of(p.z()))].push_back(k);
  }
  const double pad = 1.5 * thickness;
  for (int t = 0; t < static_cast<int>(s.tris.size()); ++t) {
    const auto& f = s.tris[t];
    if (!s.moving[f[0]] && !s.moving[f[1]] && !s.moving[f[2]]) continue;
    Box3 b;
    for (int k = 0; k < 3; ++k) {
      b.extend(s.x[f[k]]);
      b.extend(s.x[f[k]] + s.pred[f[k]]);
    }
    b.min() -= Vec3::Constant(pad);
    b.max() += Vec3::Constant(pad);
    if (!b.intersects(points_box)) continue;
    for (std::int64_t x = cell_of(b.min().x()); x <= cell_of(b.max().x()); ++x)
      for (std::int64_t y = cell_of(b.min().y()); y <= cell_of(b.max().y()); ++y)
        for (std::int64_t z = cell_of(b.min().z()); z <= cell_of(b.max().z()); ++z) {
          auto it = grid.find(key(x, y, z));
          if (it == grid.end()) continue;
          for (int k : it->second) {
            const Vec3& p = s.body_points[k];
            if (!b.contains(p)) continue;
            const Vec3& A = s.x[f[0]];
            const double side = (s.x[f[1]] - A).cross(s.x[f[2]] - A).dot(p - A) >= 0 ? 1.0 : -1.0;
            s.point_pairs.push_back({k, t, side});
          }
        }
  }
}

void resolve_point_pairs(SolverArrays& s, double thickness, double mu) {
  s.point_held.clear();
  for (const SolverArrays::PointPair& pp : s.point_pairs) {
    const auto& f = s.tris[pp.t];
    const Vec3& p = s.body_points[pp.point];
    Vec3& A = s.x[f[0]];
    Vec3& B = s.x[f[1]];
    Vec3& C = s.x[f[2]];
    Vec3 n = (B - A).cross(C - A);
    const double len = n.norm();
    if (!(len > 1e-20)) continue;
    n *= pp.side / len;  // from the triangle towards the side the point started on
    const geom::ClosestPoint cp = geom::closest_on_triangle(p, A, B, C);
    const Vec3 d = p - cp.point;
    const double dn = d.dot(n);
    const bool over = cp.b0 > 1e-9 && cp.b1 > 1e-9 && cp.b2 > 1e-9;
    Vec3 dir;  // the way the triangle moves
    double depth;
    if (over && dn < thickness) {
      // Over the triangle, nearer than the thickness or through it: the triangle moves off the
      // point, to keep it on the side it started on.
      dir = -n;
      depth = thickness - dn;
    } else {
      const double d2 = d.squaredNorm();
      if (over || d2 >= thickness * thickness) continue;
      const double dist = std::sqrt(d2);
      dir = dist > 1e-12 ? Vec3(-d / dist) : Vec3(-n);
      depth = thickness - dist;
    }
    const double w0 = s.w[f[0]], w1 = s.w[f[1]], w2 = s.w[f[2]];
    const double denom = cp.b0 * cp.b0 * w0 + cp.b1 * cp.b1 * w1 + cp.b2 * cp.b2 * w2;
    if (!(denom > 0)) continue;
    // At most half the thickness a substep, as for the cloth's own pairs (resolve_pair).
    const double push = std::min(depth, 0.5 * thickness);
    const double lambda = push / denom;
    A += (w0 * cp.b0 * lambda) * dir;
    B += (w1 * cp.b1 * lambda) * dir;
    C += (w2 * cp.b2 * lambda) * dir;
    if (dir.dot(s.up) > 0) s.point_held.insert(s.point_held.end(), {f[0], f[1], f[2]});
    if (!(mu > 0)) continue;
    // Coulomb friction on the substep's motion of the triangle's point of contact along the
    // point's surface, as the body's triangles give a vertex (resolve_body_against).
    const Vec3 moved = cp.b0 * (A - s.xp[f[0]]) + cp.b1 * (B - s.xp[f[1]]) + cp.b2 * (C - s.xp[f[2]]);
    const Vec3 tan = moved - dir * moved.dot(dir);
    const double lt = tan.norm();
    if (!(lt > 0)) continue;
    const Vec3 back = (lt <= mu * push) ? Vec3(-tan) : Vec3(tan * (-mu * push / lt));
    A += (w0 * cp.b0 / denom) * back;
    B += (w1 * cp.b1 / denom) * back;
    C += (w2 * cp.b2 / denom) * back;
  }
}

void resolve_body_against(SolverArrays& s, int i, double th, double mu, const int* c, int cnt) {
  Vec3 x = s.x[i];
  const Vec3 xp = s.xp[i];
  double push = 0;
  Vec3 nrm = Vec3::Zero();
  // Resting on the body, a vertex is pushed out in one substep and not in the next (the cloth's
  // pull lifts it a few micrometres). Held is whether it lies within the margin of an upward
  // surface, so that it does not flip from substep to substep: flipping, the long-range limits
  // moved hanging cloth the whole way and then its share, and it never came to rest.
  const double held_within = (1 + kHeldMargin) * th;
  bool near_up = false;
  for (int k = 0; k < cnt; ++k) {
    const SolverArrays::BodyTri& T = s.body_tris[c[k]];
    const double dn = (x - T.a).dot(T.n);
    if (dn >= held_within) continue;
    const double dp = (xp - T.a).dot(T.n);
    if (dp >= 0 && dn < 0) {
      // It went through the triangle's plane this substep: did it go through the triangle?
      double t;
      if (geom::segment_crosses_triangle(xp, x, T.a, T.b, T.c, t)) {
        // Back to the side it came from, along the triangle's normal: only the motion through the
        // surface is undone; the motion along it is kept, for friction to take what it may.
        // Stopping the vertex where it crossed would be friction without limit: an edge pulled
        // around the head by the strain limit (its chord dips into the head) would stay stretched.
        const Vec3 nx = x + (th - dn) * T.n;
        push += th - dn;
        nrm = T.n;
        x = nx;
        continue;
      }
    }
    if (dn <= -th) continue;
    if (dp < -th) continue;  // it came from deep behind (inside, or beyond a thin part): leave it
    // The thickness or more from the triangle's box on an axis: as far from the triangle. Most
    // candidates of a vertex resting on the body are its triangle's neighbours, nearly in its plane
    // but beside it.
    const Box3& tb = s.body_boxes[c[k]];
    if ((x - tb.max()).maxCoeff() >= held_within || (tb.min() - x).maxCoeff() >= held_within) continue;
    const geom::ClosestPoint cp = geom::closest_on_triangle(x, T.a, T.b, T.c);
    const Vec3 d = x - cp.point;
    const double d2 = d.squaredNorm();
    if (d2 >= held_within * held_within) continue;
    if (d2 >= th * th) {
      near_up = near_up || (dn > 0 && d.dot(s.up) > 0);
      continue;
    }
    // Behind the plane, nearest the triangle's border and come from in front of the plane this
    // substep (it did not cross the triangle): beside it, over a ridge such as an ear's rim, not
    // inside. It goes the thickness away from the border; along the normal it went over the ridge,
    // and its edges pulled it back, every substep.
    const bool beside = dn <= 0 && dp > 0 && (cp.b0 <= 0 || cp.b1 <= 0 || cp.b2 <= 0);
    const Vec3 dir = ((dn > 0 || beside) && d2 > 1e-24) ? Vec3(d / std::sqrt(d2)) : T.n;
    const Vec3 nx = cp.point + th * dir;
    push += (nx - x).norm();
    nrm = dir;
    x = nx;
  }
  s.held_up[i] = (push > 0 && nrm.dot(s.up) > 0) || near_up;
  if (push > 0 && mu > 0) {
    // Coulomb friction on the substep's tangential motion (position-based, Macklin et al. 2014).
    const Vec3 dx = x - xp;
    const Vec3 tan = dx - nrm * dx.dot(nrm);
    const double lt = tan.norm();
    if (lt > 0) x -= (lt <= mu * push) ? tan : Vec3(tan * (mu * push / lt));
  }
  s.x[i] = x;
}

namespace {
// One point of a cloth edge, at t from its end i to j, against the body's triangles c: kept
// `clearance` out of them on the side it came from, with friction, as resolve_body_against keeps a
// vertex, the push shared by the two ends as their weights allow (a point between two masses).
// Whether it was pushed; kDry: whether it would be, moving nothing.
template <bool kDry>
bool resolve_edge_point(SolverArrays& s, int i, int j, double t, double clearance, double mu, const int* c,
                        int cnt) {
  Vec3* X = s.x.data();
  const double wi = s.w[i], wj = s.w[j];
  const double ti = 1 - t;
  const double weff = ti * ti * wi + t * t * wj;
  if (!(weff > 0)) return false;
  const Vec3 x0 = ti * X[i] + t * X[j];
  const Vec3 xp = ti * (s.moving[i] ? s.xp[i] : X[i]) + t * (s.moving[j] ? s.xp[j] : X[j]);
  Vec3 x = x0;
  double push = 0;
  Vec3 nrm = Vec3::Zero();
  for (int k = 0; k < cnt; ++k) {
    const SolverArrays::BodyTri& T = s.body_tris[c[k]];
    const double dn = (x - T.a).dot(T.n);
    if (dn >= clearance) continue;
    const double dp = (xp - T.a).dot(T.n);
    if (dp >= 0 && dn < 0) {
      double tc;
      if (geom::segment_crosses_triangle(xp, x, T.a, T.b, T.c, tc)) {
        if (kDry) return true;
        x += (clearance - dn) * T.n;
        push += clearance - dn;
        nrm = T.n;
        continue;
      }
    }
    // Behind the triangle without having crossed it: on the far side of a thin part, or of an open
    // sheet (a wing), where the vertices are kept; pushed through to the front, the edge dragged
    // its cloth through the sheet.
    if (dn < 0) continue;
    const Box3& tb = s.body_boxes[c[k]];
    if ((x - tb.max()).maxCoeff() >= clearance || (tb.min() - x).maxCoeff() >= clearance) continue;
    const geom::ClosestPoint cp = geom::closest_on_triangle(x, T.a, T.b, T.c);
    const Vec3 d = x - cp.point;
    const double d2 = d.squaredNorm();
    if (d2 >= clearance * clearance) continue;
    const Vec3 dir = d2 > 1e-24 ? Vec3(d / std::sqrt(d2)) : T.n;
    const Vec3 nx = cp.point + clearance * dir;
    // A point pushed by nothing (it lies exactly the clearance out) moves nothing.
    if (kDry && (nx - x).norm() > 0) return true;
    push += (nx - x).norm();
    nrm = dir;
    x = nx;
  }
  if (!(push > 0)) return false;
  if (kDry) return true;
  if (mu > 0) {
    const Vec3 dx = x - xp;
    const Vec3 tan = dx - nrm * dx.dot(nrm);
    const double lt = tan.norm();
    if (lt > 0) x -= (lt <= mu * push) ? tan : Vec3(tan * (mu * push / lt));
  }
  const Vec3 move = (x - x0) / weff;
  X[i] += (ti * wi) * move;
  X[j] += (t * wj) * move;
  return true;
}

// What resolve_body_edges asks of every edge, from the field and the cloth's thickness.
struct EdgeReach {
  EdgeReach(const BodyField& f, double th, double clearance)
      : th(th),
        clearance(clearance),
        reach(clearance + f.cell_radius()),
        fast2(f.cell() * f.cell()),
        // Points no further apart than twice the clearance: a sharp ridge of the body between two of
        // them, each kept the clearance from it, cannot come through the edge.
        spacing(2 * clearance),
        covered(f.turn_reach() - clearance),
        listed(f.band() - f.cell_radius()) {}
  double th, clearance, reach, fast2, spacing, covered, listed;
};

// The edge from i to j against the body (resolve_body_edges): whether a point of it was pushed;
// kDry: whether one would be, moving nothing (the points after the first push are not looked at).
template <bool kDry>
bool body_edge(SolverArrays& s, const BodyCollider& collider, const EdgeReach& r, double mu, int i, int j,
               std::vector<int>& tris) {
  const BodyField& f = *s.field;
  const double clearance = r.clearance;
  const double len = (s.x[i] - s.x[j]).norm();
  // A step gone non-finite is undone after it; a point of an edge of no length is its ends'.
  if (!(len > 0 && len < std::numeric_limits<double>::infinity())) return false;
  // Far from the body: a body point within the clearance of a point of a segment of length l is
  // within sqrt(l^2 / 4 + clearance^2) of one of its ends. The ends' gaps, then the middle's. An
  // end that did not move this substep was not looked up: taken as near and sharp, so that the
  // step is the same whatever its arrays held before (a session reopened, a rebuild).
  const bool mi = s.moving[i], mj = s.moving[j];
  const double gi = mi ? s.body_gap[i] : 0.0, gj = mj ? s.body_gap[j] : 0.0;
  if (std::min(gi, gj) * std::min(gi, gj) >= 0.25 * len * len + clearance * clearance) return false;
  // Over a surface that turns by less than phi, ends kept the thickness from it leave the edge's
  // middle about th - len phi / 4 from it, beyond the clearance. How the surface turns near the
  // ends (and below, the middle), from their cells: together they list every triangle within the
  // clearance of the edge when it is no longer than twice (four times) turn_reach - clearance.
  // A longer edge is not passed over so, and needs no cosine.
  const bool within2 = len <= 2 * r.covered, within4 = len <= 4 * r.covered;
  double cos_phi = -1;
  if (within4) {
    const double phi = 4 * (r.th - clearance) / len;
    cos_phi = phi >= M_PI ? -1.0 : std::cos(phi);
  }
  const float ends_turn = std::min(mi ? s.body_turn[i] : -1.0f, mj ? s.body_turn[j] : -1.0f);
  if (within2 && ends_turn >= cos_phi) return false;
  double gm;
  const std::int64_t mc = f.cell_of(0.5 * (s.x[i] + s.x[j]), gm);
  const double g = std::min({gi, gj, gm});
  if (g * g >= 0.0625 * len * len + clearance * clearance) return false;
  if (within4 && std::min(ends_turn, mc < 0 ? 1.0f : f.turn(mc)) >= cos_phi) return false;
  const int n = static_cast<int>(std::clamp(len / r.spacing, 1.0, double(kEdgePoints)));
  bool pushed = false;
  for (int q = 1; q <= n; ++q) {
    const double t = double(q) / (n + 1);
    const Vec3 x = (1 - t) * s.x[i] + t * s.x[j];
    const Vec3 xp = (1 - t) * (mi ? s.xp[i] : s.x[i]) + t * (mj ? s.xp[j] : s.x[j]);
    if ((x - xp).squaredNorm() > r.fast2) {
      Box3 bx(xp.cwiseMin(x), xp.cwiseMax(x));
      bx.min() -= Vec3::Constant(1.5 * clearance);
      bx.max() += Vec3::Constant(1.5 * clearance);
      if (!bx.intersects(s.body_bounds)) continue;
      collider.triangles_in_box(bx, tris);
      if (!tris.empty() &&
          resolve_edge_point<kDry>(s, i, j, t, clearance, mu, tris.data(), static_cast<int>(tris.size()))) {
        if (kDry) return true;
        pushed = true;
      }
      continue;
    }
    // The middle's cell lists what is within the clearance of a point near the middle (allowing
    // for the pushes of the points before it); further out, the point's own cell.
    const double from_middle = std::abs(t - 0.5) * len;
    const bool near_middle = mc >= 0 && from_middle + 2 * clearance <= r.listed;
    const std::int64_t c = near_middle ? mc : f.cell_of(x);
    if (c < 0 || f.distance(c) > r.reach + (near_middle ? from_middle : 0.0)) continue;
    int count = 0;
    const int* list = f.triangles(c, count);
    if (resolve_edge_point<kDry>(s, i, j, t, clearance, mu, list, count)) {
      if (kDry) return true;
      pushed = true;
    }
  }
  return pushed;
}
}  // namespace

void resolve_body_edges(SolverArrays& s, const BodyCollider& collider, const int* ei, const int* ej, int b, int e,
                        double th, double clearance, double mu, bool whole) {
  const EdgeReach r(*s.field, th, clearance);
  thread_local std::vector<int> tris;
  // A cloth of one block sweeps all its edges in one order, on one thread. Most edges are passed
  // over or their points not pushed, and finding that is most of the pass: the threads find it
  // for all the edges, without moving anything, and the sweep then takes in order only the edges
  // that push and those whose ends an edge before them moved. The same as the plain sweep, bit for
  // bit: an edge passed over read only its ends, as the sweep would have found them.
  constexpr int kShareFrom = 1024;
  if (!whole || e - b < kShareFrom || parallel::thread_count() < 2) {
    for (int k = b; k < e; ++k) body_edge<false>(s, collider, r, mu, ei[k], ej[k], tris);
    return;
  }
  s.edge_pushes.resize(e - b);
  char* pushes = s.edge_pushes.data();
  parallel::for_range(e - b, 256, [&](int lo, int hi) {
    thread_local std::vector<int> mine;
    for (int k = lo; k < hi; ++k) pushes[k] = body_edge<true>(s, collider, r, mu, ei[b + k], ej[b + k], mine);
  });
  s.edge_moved.resize(s.n, 0);
  std::vector<int>& moved = s.edge_moved_list;
  moved.clear();
  for (int k = b; k < e; ++k) {
    const int i = ei[k], j = ej[k];
    if (!pushes[k - b] && !s.edge_moved[i] && !s.edge_moved[j]) continue;
    if (body_edge<false>(s, collider, r, mu, i, j, tris)) {
      for (int v : {i, j})
        if (!s.edge_moved[v]) s.edge_moved[v] = 1, moved.push_back(v);
    }
  }
  for (int v : moved) s.edge_moved[v] = 0;
}

void prepare_body_field(SolverArrays& s, double th) {
  const double need = (1 + kHeldMargin) * th;
  if (s.body && (!s.field || need + s.field->cell_radius() > s.field->band())) s.field = BodyField::of(*s.body, need);
}

void resolve_body(SolverArrays& s, const BodyCollider& collider, const std::vector<int>& verts, double th, double mu,
                  bool floor) {
  prepare_body_field(s, th);
  const BodyField& f = *s.field;
  const double reach = (1 + kHeldMargin) * th + f.cell_radius();
  const double fast = f.cell();
  const int na = static_cast<int>(verts.size());
  s.escaped.resize(s.n);
  s.body_gap.resize(s.n, 0.0f);
  s.body_turn.resize(s.n, -1.0f);
  parallel::for_range(na, 1024, [&](int b, int e) {
    for (int a = b; a < e; ++a) {
      const int i = verts[a];
      const Vec3& x = s.x[i];
      s.escaped[i] = (x - s.xp[i]).squaredNorm() > fast * fast;
      s.body_gap[i] = 0;
      s.body_turn[i] = -1;
      if (s.escaped[i]) continue;
      double gap;
      const std::int64_t c = f.cell_of(x, gap);
      // Near the body, less the thickness: the push below moves the vertex by up to about that.
      s.body_gap[i] = static_cast<float>(c < 0 ? gap : std::max(0.0, gap - th));
      s.body_turn[i] = c < 0 ? 1.0f : f.turn(c);
      if (c < 0 || f.distance(c) > reach) {
        s.held_up[i] = 0;
        continue;
      }
      int count = 0;
      const int* tris = f.triangles(c, count);
      resolve_body_against(s, i, th, mu, tris, count);
    }
  });
  s.escapees.clear();
  for (int i : verts)
    if (s.escaped[i]) s.escapees.push_back(i);
  parallel::for_range(static_cast<int>(s.escapees.size()), 64, [&](int b0, int e0) {
    thread_local std::vector<int> tris;
    for (int k = b0; k < e0; ++k) {
      const int i = s.escapees[k];
      Box3 b(s.xp[i].cwiseMin(s.x[i]), s.xp[i].cwiseMax(s.x[i]));
      b.min() -= Vec3::Constant(1.5 * th);
      b.max() += Vec3::Constant(1.5 * th);
      if (!b.intersects(s.body_bounds)) {
        s.held_up[i] = 0;
        continue;
      }
      collider.triangles_in_box(b, tris);
      if (!tris.empty()) resolve_body_against(s, i, th, mu, tris.data(), static_cast<int>(tris.size()));
      else s.held_up[i] = 0;
    }
  });
  if (!floor) return;
  // The floor through the body's lowest point: a vertex that came from above it is kept the
  // thickness above it, with friction on its motion along it, as the body keeps it.
  const double ground = s.body_bounds.min().y(), rest = ground + th;
  parallel::for_range(na, 2048, [&](int b, int e) {
    for (int a = b; a < e; ++a) {
      const int i = verts[a];
      Vec3& x = s.x[i];
      if (!(x.y() < rest) || !(s.xp[i].y() >= ground)) continue;
      const double push = rest - x.y();
      x.y() = rest;
      const Vec3 dx = x - s.xp[i];
      const Vec3 tan(dx.x(), 0, dx.z());
      const double lt = tan.norm();
      if (mu > 0 && lt > 0) x -= (lt <= mu * push) ? tan : Vec3(tan * (mu * push / lt));
      s.held_up[i] = s.up.y() > 0;
    }
  });
}

namespace {
struct PairCollector : btDbvt::ICollide {
  const SolverArrays* s;
  double th;
  std::vector<SolverArrays::SelfPair>* out;
  const SolverArrays::FloatBox* vert_live;  // each vertex's box in this search, in cluster order
  std::size_t budget;                       // the most pairs `out` takes (see StepReport::self_overloaded)
  bool full = false;
  // A cluster of vertices against a cluster of triangles whose boxes meet: the items' boxes, each
  // vertex's (grown by what the two clusters' frames sweep apart, see gather_self_pairs) against
  // the cluster's triangles' (an item taking no part has an empty box, which meets nothing).
  void Process(const btDbvtNode* a, const btDbvtNode* b) override {
    if (full) return;
    const int cv = static_cast<int>(reinterpret_cast<std::intptr_t>(a->data));
    const int ct = static_cast<int>(reinterpret_cast<std::intptr_t>(b->data));
    const int t0 = s->tcl_begin[ct], t1 = s->tcl_begin[ct + 1];
    const SolverArrays::TriClusterBoxes& tb = s->tri_cluster_live[ct];
    const unsigned present = (1u << (t1 - t0)) - 1;
    const SolverArrays::FloatBox& fv = s->vcl_frame_box[cv];
    const SolverArrays::FloatBox& ft = s->tcl_frame_box[ct];
    float lo[3], hi[3];  // the hull of zero and the vertex cluster's frame less the triangle cluster's
    for (int k = 0; k < 3; ++k) lo[k] = std::min(0.0f, fv.lo[k] - ft.hi[k]), hi[k] = std::max(0.0f, fv.hi[k] - ft.lo[k]);
    for (int p = s->vcl_begin[cv]; p < s->vcl_begin[cv + 1]; ++p) {
      SolverArrays::FloatBox v = vert_live[p];
      for (int k = 0; k < 3; ++k) v.lo[k] += lo[k], v.hi[k] += hi[k];
      unsigned hits = meets_cluster(v, tb) & present;
      if (!hits) continue;
      // Not the triangles of the vertex and of its neighbours: they are close at rest.
      for (int k = s->excl_begin[p]; k < s->excl_begin[p + 1]; ++k)
        if (s->excl_cluster[k] == ct) {
          hits &= ~unsigned(s->excl_mask[k]);
          break;
        }
      for (; hits; hits &= hits - 1) pair(s->vcl_items[p], s->tcl_items[t0 + __builtin_ctz(hits)]);
    }
  }
  // Bit k: the vertex's box meets the cluster's triangle k's (without a branch per box: whether
  // two boxes meet is a coin toss here, and mispredicted branches were most of a gather).
  static unsigned meets_cluster(const SolverArrays::FloatBox& v, const SolverArrays::TriClusterBoxes& t) {
    static_assert(SolverArrays::kTriCluster == 8, "a triangle cluster's boxes are two vectors of four");
#if defined(__SSE2__)
    unsigned m = 0;
    for (int half = 0; half < 2; ++half) {
      __m128 in = _mm_castsi128_ps(_mm_set1_epi32(-1));
      for (int a = 0; a < 3; ++a) {
        in = _mm_and_ps(in, _mm_cmple_ps(_mm_set1_ps(v.lo[a]), _mm_load_ps(&t.hi[a][4 * half])));
        in = _mm_and_ps(in, _mm_cmpge_ps(_mm_set1_ps(v.hi[a]), _mm_load_ps(&t.lo[a][4 * half])));
      }
      m |= unsigned(_mm_movemask_ps(in)) << (4 * half);
    }
    return m;
#else
    unsigned m = 0;
    for (int k = 0; k < SolverArrays::kTriCluster; ++k) {
      bool in = true;
      for (int a = 0; a < 3; ++a) in &= (v.lo[a] <= t.hi[a][k]) & (v.hi[a] >= t.lo[a][k]);
      m |= unsigned(in) << k;
    }
    return m;
#endif
  }
  void pair(int v, int t) {
    SolverArrays::SelfPair p;
    if (!self_pair_test(*s, th, v, t, p)) return;
    if (out->size() >= budget) {
      full = true;
      return;
    }
    out->push_back(p);
  }
};

}  // namespace

// Vertex-triangle pairs that can come within the thickness during the window (the motion `win`).
//
// Culling is done in frames that move. A vertex and a triangle at the same parameter t of the
// window are x_v + t win_v and x_T + t win_T; written with any motions c_a, c_b (frames), they are
//   (x_v + t (win_v - c_a)) - (x_T + t (win_T - c_b)) + t (c_a - c_b)
// apart. The first two terms lie in the boxes swept over win - c_a and win - c_b, and the third in
// the hull of zero and c_a - c_b: a vertex box grown by that hull that does not meet the triangle's
// box holds no pair.
//  - Each cluster of vertices and of triangles has its own frame, its own mean motion, when
//    everything moves. Cloth moves together locally: its items' boxes in their own frames are
//    about as small as at rest wherever the cloth goes, and two clusters side by side on one sheet
//    have nearly the same frame (little growth between them). A tree's leaf takes its items' boxes
//    grown by the hull of zero and its frame less the cloth's mean motion c, so the trees, searched
//    as they are (btDbvt::collideTT), find every pair of leaves whose items may meet (both points
//    lie in their leaves' boxes then, at the same t); the growth between the two clusters' frames
//    is then applied to each vertex's box against the triangles' (PairCollector).
//  - Under a local region, all frames are c, the moving part's mean motion (no growth anywhere).
// With the cloth's mean as the one frame everywhere, a 100,000-vertex cloth falling onto the body
// met 6.4 triangle boxes a vertex in a gather for the whole step; with the clusters' frames, 1.3.
// (One frame for all had already taken a falling 20,000-vertex cloth from ~5 million box overlaps
// a step to ~0.6 million, what it has at rest.)
//
// Only pairs with a moving vertex can do anything: those of a moving vertex with any triangle, and
// those of a held vertex (a pin, outside the local region) with a triangle that has a moving
// corner. Each kind is one intersection of the two trees, with the items that cannot be in it
// given an empty box (which never meets anything and leaves its cluster's box as it is), so that a
// region of 1,000 moving vertices searches what 1,000 vertices need; when everything moves, the
// second search is not run, nor when the held vertices are few (pins): then one search of
// everything costs less.
// The vertex tree is cut into subtrees with something in them, each intersected with the triangle
// tree on its own (in parallel) into its own list; the lists are joined in subtree order, the same
// for any number of threads.
namespace {
using FloatBox = SolverArrays::FloatBox;
// A search's budget of pairs (StepReport::self_overloaded): this many a vertex of each subtree,
// and a little more for small subtrees. Cloth at work has at most about 160 a vertex over a
// subtree (a whole 20,000-vertex garment dragged fast across itself), 126 in the tests' coarse
// cloth thrown at the body.
constexpr std::size_t kPairsPerVertex = 256, kPairsSlack = 4096;
constexpr float kInf = std::numeric_limits<float>::infinity();
const FloatBox kNoBox{{kInf, kInf, kInf}, {-kInf, -kInf, -kInf}};
const btDbvtVolume kNothing =
    btDbvtVolume::FromMM(btVector3(1e300, 1e300, 1e300), btVector3(-1e300, -1e300, -1e300));

bool is_nothing(const btDbvtVolume& v) { return v.Mins().x() > v.Maxs().x(); }
bool is_nothing(const FloatBox& b) { return b.lo[0] > b.hi[0]; }

// Widened before rounding by more than a float's rounding error (2^-24 of the value), so that the
// float box holds the double one.
FloatBox to_float(const Box3& b) {
  FloatBox f;
  for (int a = 0; a < 3; ++a) {
    f.lo[a] = static_cast<float>(b.min()[a] - std::abs(b.min()[a]) * 1e-6);
    f.hi[a] = static_cast<float>(b.max()[a] + std::abs(b.max()[a]) * 1e-6);
  }
  return f;
}

FloatBox point_box(const Vec3& c) { return to_float(Box3(c, c)); }

bool meet(const FloatBox& a, const FloatBox& b) {
  return a.lo[0] <= b.hi[0] && b.lo[0] <= a.hi[0] && a.lo[1] <= b.hi[1] && b.lo[1] <= a.hi[1] &&
         a.lo[2] <= b.hi[2] && b.lo[2] <= a.hi[2];
}

void merge(FloatBox& a, const FloatBox& b) {
  for (int k = 0; k < 3; ++k) a.lo[k] = std::min(a.lo[k], b.lo[k]), a.hi[k] = std::max(a.hi[k], b.hi[k]);
}

btDbvtVolume to_volume(const FloatBox& b) {
  return is_nothing(b) ? kNothing
                       : btDbvtVolume::FromMM(btVector3(b.lo[0], b.lo[1], b.lo[2]), btVector3(b.hi[0], b.hi[1], b.hi[2]));
}

// The pairs of the items with a box in this search (vert_live, tri_live: in cluster order); each
// cluster leaf gets the box around its items' boxes, and each triangle cluster its items' boxes
// side by side.
void collide_trees(SolverArrays& s, double thickness, const Vec3& mean, const std::vector<FloatBox>& vert_live,
                   const std::vector<FloatBox>& tri_live) {
  const FloatBox common = point_box(mean);
  // A leaf's box: its items' (in its frame) grown by the hull of zero and its frame less the mean.
  auto leaf_volume = [&](FloatBox all, const FloatBox& frame) {
    if (is_nothing(all)) return kNothing;
    for (int k = 0; k < 3; ++k)
      all.lo[k] += std::min(0.0f, frame.lo[k] - common.hi[k]), all.hi[k] += std::max(0.0f, frame.hi[k] - common.lo[k]);
    return to_volume(all);
  };
  s.tri_cluster_live.resize(s.tcl_leaf.size());
  parallel::for_range(static_cast<int>(s.tcl_leaf.size()), 256, [&](int c0, int c1) {
    for (int c = c0; c < c1; ++c) {
      SolverArrays::TriClusterBoxes& t = s.tri_cluster_live[c];
      FloatBox all = kNoBox;
      for (int k = 0; k < SolverArrays::kTriCluster; ++k) {
        const int q = s.tcl_begin[c] + k;
        const FloatBox& b = q < s.tcl_begin[c + 1] ? tri_live[q] : kNoBox;
        for (int a = 0; a < 3; ++a) t.lo[a][k] = b.lo[a], t.hi[a][k] = b.hi[a];
        merge(all, b);
      }
      s.tcl_leaf[c]->volume = leaf_volume(all, s.tcl_frame_box[c]);
    }
  });
  parallel::for_range(static_cast<int>(s.vcl_leaf.size()), 256, [&](int c0, int c1) {
    for (int c = c0; c < c1; ++c) {
      FloatBox all = kNoBox;
      for (int p = s.vcl_begin[c]; p < s.vcl_begin[c + 1]; ++p) merge(all, vert_live[p]);
      s.vcl_leaf[c]->volume = leaf_volume(all, s.vcl_frame_box[c]);
    }
  });
  refit(s.tri_tree.m_root);
  refit(s.vert_tree.m_root);
  if (is_nothing(s.vert_tree.m_root->volume) || is_nothing(s.tri_tree.m_root->volume)) return;
  // Subtrees of the vertex tree, breadth first, to about 64 (a fixed cut: the same for any thread
  // count), leaving out those with nothing in them.
  std::vector<const btDbvtNode*> roots{s.vert_tree.m_root}, next;
  for (bool split = true; split && roots.size() < 64;) {
    split = false;
    next.clear();
    for (const btDbvtNode* node : roots) {
      if (node->isleaf()) {
        next.push_back(node);
        continue;
      }
      for (const btDbvtNode* child : node->childs)
        if (!is_nothing(child->volume)) next.push_back(child);
      split = true;
    }
    roots.swap(next);
  }
  s.self_gather.resize(roots.size());
  s.self_gather_full.assign(roots.size(), 0);
  parallel::for_range(static_cast<int>(roots.size()), 1, [&](int r0, int r1) {
    std::vector<const btDbvtNode*> stack;
    for (int r = r0; r < r1; ++r) {
      s.self_gather[r].clear();
      // The subtree's budget: kPairsPerVertex a vertex under it (a knot's only bound; a fixed cut
      // and its own count, so the same pairs are kept for any thread count).
      std::size_t vertices = 0;
      stack.assign(1, roots[r]);
      while (!stack.empty()) {
        const btDbvtNode* node = stack.back();
        stack.pop_back();
        if (node->isleaf()) {
          const int c = static_cast<int>(reinterpret_cast<std::intptr_t>(node->data));
          vertices += s.vcl_begin[c + 1] - s.vcl_begin[c];
        } else {
          stack.push_back(node->childs[0]);
          stack.push_back(node->childs[1]);
        }
      }
      PairCollector pc;
      pc.s = &s;
      pc.th = thickness;
      pc.out = &s.self_gather[r];
      pc.vert_live = vert_live.data();
      pc.budget = kPairsPerVertex * vertices + kPairsSlack;
      s.vert_tree.collideTT(roots[r], s.tri_tree.m_root, pc);
      s.self_gather_full[r] = pc.full;
    }
  });
  for (std::size_t r = 0; r < roots.size(); ++r) {
    s.self_pairs.insert(s.self_pairs.end(), s.self_gather[r].begin(), s.self_gather[r].end());
    if (s.self_gather_full[r]) s.report.self_overloaded = true;
  }
}
}  // namespace

void gather_self_pairs(SolverArrays& s, double thickness, double surprise_scale) {
  s.self_pairs.clear();
  s.last_self_pairs = 0;
  if (!s.tri_tree.m_root || !s.vert_tree.m_root) return;
  // What self_pair_test reads of each triangle, once for the gather.
  const int ntris = static_cast<int>(s.tris.size());
  s.tri_n.resize(ntris);
  s.tri_g.resize(ntris);
  s.tri_r.resize(ntris);
  parallel::for_range(ntris, 2048, [&](int b, int e) {
    for (int t = b; t < e; ++t) {
      const Vec3& A = s.x[s.tris[t][0]];
      const Vec3& B = s.x[s.tris[t][1]];
      const Vec3& C = s.x[s.tris[t][2]];
      const Vec3 n = (B - A).cross(C - A);
      const double len = n.norm();
      s.tri_n[t] = len > 0 ? Vec3(n / len) : Vec3::Zero();
      s.tri_g[t] = (A + B + C) * (1.0 / 3.0);
      s.tri_r[t] = std::sqrt(std::max({(A - s.tri_g[t]).squaredNorm(), (B - s.tri_g[t]).squaredNorm(),
                                       (C - s.tri_g[t]).squaredNorm()}));
    }
  });
  Vec3 c = Vec3::Zero();
  const std::size_t nm = s.act.size();  // the moving vertices, in index order
  for (int i : s.act) c += s.win[i];
  if (nm == 0) return;
  c /= double(nm);
  const unsigned char* M = s.moving.data();
  // A few held vertices (pins): one search of everything costs less than two; the leaves get their
  // boxes as they are computed.
  const bool one_search = self_search_whole(s);
  const int nt = static_cast<int>(s.tcl_items.size()), nv = static_cast<int>(s.vcl_items.size());
  constexpr int kV = SolverArrays::kVertCluster, kT = SolverArrays::kTriCluster;
  // The clusters' frames: when everything moves, each cluster's own motion (the mean of its
  // vertices', of its triangles' first corners': any motion would do for a frame, and first
  // corners are a third of the reading); under a local region, the mean c for all (the moving
  // part is small, and its clusters' frames would cost a pass over the whole cloth).
  const int ncv = static_cast<int>(s.vcl_leaf.size()), nct = static_cast<int>(s.tcl_leaf.size());
  s.vcl_frame.resize(ncv);
  s.tcl_frame.resize(nct);
  s.vcl_frame_box.resize(ncv);
  s.tcl_frame_box.resize(nct);
  if (one_search) {
    parallel::for_range(ncv, 1024, [&](int c0, int c1) {
      for (int k = c0; k < c1; ++k) {
        Vec3 m = Vec3::Zero();
        for (int p = s.vcl_begin[k]; p < s.vcl_begin[k + 1]; ++p) m += s.win[s.vcl_items[p]];
        s.vcl_frame[k] = m / double(s.vcl_begin[k + 1] - s.vcl_begin[k]);
        s.vcl_frame_box[k] = point_box(s.vcl_frame[k]);
      }
    });
    parallel::for_range(nct, 1024, [&](int c0, int c1) {
      for (int k = c0; k < c1; ++k) {
        Vec3 m = Vec3::Zero();
        for (int q = s.tcl_begin[k]; q < s.tcl_begin[k + 1]; ++q) m += s.win[s.tris[s.tcl_items[q]][0]];
        s.tcl_frame[k] = m / double(s.tcl_begin[k + 1] - s.tcl_begin[k]);
        s.tcl_frame_box[k] = point_box(s.tcl_frame[k]);
      }
    });
  } else {
    s.vcl_frame.assign(ncv, c);
    s.tcl_frame.assign(nct, c);
    s.vcl_frame_box.assign(ncv, point_box(c));
    s.tcl_frame_box.assign(nct, point_box(c));
  }
  // The boxes of what the window sweeps, each in its cluster's frame (in cluster order).
  s.tri_box.resize(nt);
  s.vert_box.resize(nv);
  auto tri_box = [&](int q) {
    const Vec3& f = s.tcl_frame[q / kT];
    Box3 b;
    for (int u : s.tris[s.tcl_items[q]]) {
      b.extend(s.x[u]);
      b.extend(Vec3(s.x[u] + s.win[u] - f));
    }
    return to_float(b);
  };
  auto vert_box = [&](int p) {
    const int i = s.vcl_items[p];
    return to_float(swept_box(s, s.win, s.surprise_self, surprise_scale, i, std::min(thickness, 0.6 * s.spacing[i]), 0.1,
                              s.vcl_frame[p / kV]));
  };
  if (one_search) {
    parallel::for_range(nt, 2048, [&](int b0, int e0) {
      for (int q = b0; q < e0; ++q) s.tri_box[q] = tri_box(q);
    });
    parallel::for_range(nv, 2048, [&](int b0, int e0) {
      for (int p = b0; p < e0; ++p) s.vert_box[p] = vert_box(p);
    });
    collide_trees(s, thickness, c, s.vert_box, s.tri_box);
    s.last_self_pairs = s.self_pairs.size();
    ++s.report.self_gathers;
    s.report.self_pairs += s.self_pairs.size();
    partition_self_pairs(s);
    return;
  }
  // Two searches. Only the boxes of what moves are needed whole: those of the moving vertices and
  // of the triangles with a moving corner, and what they sweep bounds each search; a held item's
  // box (3/4 of them under a local region) is made only in the search it can take part in, and
  // kept only if it meets that bound.
  auto moving_tri = [&](int q) {
    const auto& tri = s.tris[s.tcl_items[q]];
    return M[tri[0]] || M[tri[1]] || M[tri[2]];
  };
  // (In pieces, in parallel on a large cloth: a box around boxes is the same in any order.)
  constexpr int kMaxPieces = 16;
  const int pieces = nv + nt >= 16384 ? kMaxPieces : 1;
  FloatBox moving_bounds[kMaxPieces], active_bounds[kMaxPieces];
  parallel::for_each(pieces, [&](int piece) {
    FloatBox mb = kNoBox, ab = kNoBox;
    for (int p = parallel::piece_begin(nv, piece, pieces), e = parallel::piece_begin(nv, piece + 1, pieces); p < e; ++p)
      if (M[s.vcl_items[p]]) merge(mb, s.vert_box[p] = vert_box(p));
    for (int q = parallel::piece_begin(nt, piece, pieces), e = parallel::piece_begin(nt, piece + 1, pieces); q < e; ++q)
      if (moving_tri(q)) merge(ab, s.tri_box[q] = tri_box(q));
    moving_bounds[piece] = mb;
    active_bounds[piece] = ab;
  });
  FloatBox moving_bound = kNoBox, active_bound = kNoBox;
  for (int piece = 0; piece < pieces; ++piece) {
    merge(moving_bound, moving_bounds[piece]);
    merge(active_bound, active_bounds[piece]);
  }
  s.tri_live.resize(nt);
  s.vert_live.resize(nv);
  auto within = [](const FloatBox& b, const FloatBox& bound) { return meet(b, bound) ? b : kNoBox; };
  // Moving vertices against all triangles (those within their reach).
  parallel::for_range(nv, 2048, [&](int b0, int e0) {
    for (int p = b0; p < e0; ++p) s.vert_live[p] = M[s.vcl_items[p]] ? within(s.vert_box[p], moving_bound) : kNoBox;
  });
  parallel::for_range(nt, 2048, [&](int b0, int e0) {
    for (int q = b0; q < e0; ++q) s.tri_live[q] = within(moving_tri(q) ? s.tri_box[q] : tri_box(q), moving_bound);
  });
  collide_trees(s, thickness, c, s.vert_live, s.tri_live);
  // Held vertices (those within reach of a moving triangle) against the triangles with a moving
  // corner.
  parallel::for_range(nv, 2048, [&](int b0, int e0) {
    for (int p = b0; p < e0; ++p) s.vert_live[p] = M[s.vcl_items[p]] ? kNoBox : within(vert_box(p), active_bound);
  });
  parallel::for_range(nt, 2048, [&](int b0, int e0) {
    for (int q = b0; q < e0; ++q) s.tri_live[q] = moving_tri(q) ? within(s.tri_box[q], active_bound) : kNoBox;
  });
  collide_trees(s, thickness, c, s.vert_live, s.tri_live);
  s.last_self_pairs = s.self_pairs.size();
  ++s.report.self_gathers;
  s.report.self_pairs += s.self_pairs.size();
  partition_self_pairs(s);
}

namespace {

// One pair: pushes the vertex and the triangle apart to the thickness.
inline void resolve_pair(SolverArrays& s, const SolverArrays::SelfPair& p, double thickness) {
  double* R = s.reach.data();
  const auto& tri = s.tris[p.t];
  // The distance from a point to a triangle changes no faster than the point and the triangle's
  // corners move: a pair that started further apart than the thickness plus everything its four
  // vertices have moved since (pushes included) cannot be within it, nor have crossed. Many pairs
  // gathered for a window with large relative motion (cloth landing, a pinch) end here.
  if (p.d0 - R[p.v] - std::max({R[tri[0]], R[tri[1]], R[tri[2]]}) > thickness) return;
  Vec3& xv = s.x[p.v];
  Vec3& A = s.x[tri[0]];
  Vec3& B = s.x[tri[1]];
  Vec3& C = s.x[tri[2]];
  // On a mesh finer than the thickness, the triangles just beyond the vertex's neighbours are
  // closer than the thickness at rest: keep the pair's distance below the rest spacing.
  const double th = std::min(thickness, 0.6 * s.spacing[p.v]);
  Vec3 n = (B - A).cross(C - A);
  const double len = n.norm();
  if (!(len > 1e-20)) return;
  n *= p.side / len;
  const geom::ClosestPoint cp = geom::closest_on_triangle(xv, A, B, C);
  const Vec3 d = xv - cp.point;
  const double dn = d.dot(n);
  const double d2 = d.squaredNorm();
  Vec3 dir;
  double depth;
  const bool over = cp.b0 > 1e-9 && cp.b1 > 1e-9 && cp.b2 > 1e-9;
  bool crossed = false;
  if (dn < 0 && over) {
    // Over the triangle on the wrong side: did it cross during this substep (it was on the
    // right side at the substep's start)? Going round the triangle's edge is not a crossing.
    const Vec3& pA = s.xp[tri[0]];
    const Vec3 pn = (s.xp[tri[1]] - pA).cross(s.xp[tri[2]] - pA) * p.side;
    crossed = (s.xp[p.v] - pA).dot(pn) >= 0;
  }
  if (crossed) {
    dir = n;  // back to the side it started on
    depth = th - dn;
  } else {
    if (d2 >= th * th) return;
    const double dist = std::sqrt(d2);
    dir = dist > 1e-12 ? Vec3(d / dist) : n;
    depth = th - dist;
  }
  const double wv = s.w[p.v], w0 = s.w[tri[0]], w1 = s.w[tri[1]], w2 = s.w[tri[2]];
  const double denom = wv + cp.b0 * cp.b0 * w0 + cp.b1 * cp.b1 * w1 + cp.b2 * cp.b2 * w2;
  if (!(denom > 0)) return;
  // At most half the thickness per substep: a deeper push turns into a velocity kick (x - xp) / h
  // that other contacts then push back against; spread over substeps it stays stable.
  const double lambda = std::min(depth, 0.5 * th) / denom;
  xv += (wv * lambda) * dir;
  A -= (w0 * cp.b0 * lambda) * dir;
  B -= (w1 * cp.b1 * lambda) * dir;
  C -= (w2 * cp.b2 * lambda) * dir;
  R[p.v] += wv * lambda;
  R[tri[0]] += w0 * cp.b0 * lambda;
  R[tri[1]] += w1 * cp.b1 * lambda;
  R[tri[2]] += w2 * cp.b2 * lambda;
}

}  // namespace

// The pairs in slabs across the cloth's longest side, each with as many pairs: a pair whose four
// vertices (the vertex and the triangle's corners) are all in one slab shares none with a pair of
// another slab, and the slabs are resolved in parallel, each in the gathered order; the pairs
// across two slabs after them, in sequence. The slabs do not depend on the thread count, nor so
// the result.
void partition_self_pairs(SolverArrays& s) {
  const std::size_t np = s.self_pairs.size();
  s.self_runs.assign(1, 0);
  if (np < kParallelSelfPairs) {  // too few to be worth it: in sequence, as gathered
    s.self_runs.push_back(static_cast<int>(np));
    s.self_runs_serial_from = 0;
    return;
  }
  Box3 box;
  for (const auto& p : s.self_pairs) box.extend(s.x[p.v]);
  int axis = 0;
  box.sizes().maxCoeff(&axis);
  std::vector<double>& key = s.pair_key;
  key.resize(np);
  for (std::size_t q = 0; q < np; ++q) {
    const double c = s.x[s.self_pairs[q].v][axis];
    key[q] = std::isfinite(c) ? c : 0.0;  // a diverging vertex (caught after the step) keeps the sort sound
  }
  double bound[kSelfSlabs - 1];
  for (int k = 1; k < kSelfSlabs; ++k) {
    auto at = key.begin() + static_cast<std::ptrdiff_t>(np * k / kSelfSlabs);
    std::nth_element(key.begin(), at, key.end());
    bound[k - 1] = *at;
  }
  auto slab = [&](int v) {
    return static_cast<int>(std::upper_bound(std::begin(bound), std::end(bound), s.x[v][axis]) - bound);
  };
  s.pair_slab.resize(np);
  int count[kSelfSlabs + 1] = {0};
  for (std::size_t q = 0; q < np; ++q) {
    const auto& p = s.self_pairs[q];
    const auto& tri = s.tris[p.t];
    const int k = slab(p.v);
    const int c = (slab(tri[0]) == k && slab(tri[1]) == k && slab(tri[2]) == k) ? k : kSelfSlabs;
    s.pair_slab[q] = static_cast<unsigned char>(c);
    ++count[c];
  }
  int at[kSelfSlabs + 1] = {0};
  for (int c = 0; c < kSelfSlabs; ++c) at[c + 1] = at[c] + count[c];
  s.pair_scratch.resize(np);
  for (std::size_t q = 0; q < np; ++q) s.pair_scratch[at[s.pair_slab[q]]++] = s.self_pairs[q];
  s.self_pairs.swap(s.pair_scratch);
  for (int c = 0; c < kSelfSlabs; ++c) s.self_runs.push_back(at[c]);
  s.self_runs_serial_from = kSelfSlabs;
  s.self_runs.push_back(static_cast<int>(np));
}

void resolve_self(SolverArrays& s, double thickness) {
  if (s.self_runs.empty() || s.self_runs.back() != static_cast<int>(s.self_pairs.size())) partition_self_pairs(s);
  const int runs = static_cast<int>(s.self_runs.size()) - 1;
  const int together = std::min(runs, s.self_runs_serial_from);
  parallel::for_range(together, 1, [&](int r0, int r1) {
    for (int r = r0; r < r1; ++r)
      for (int q = s.self_runs[r]; q < s.self_runs[r + 1]; ++q) resolve_pair(s, s.self_pairs[q], thickness);
  });
  for (int r = together; r < runs; ++r)
    for (int q = s.self_runs[r]; q < s.self_runs[r + 1]; ++q) resolve_pair(s, s.self_pairs[q], thickness);
}

}  // namespace kiji::solver_detail
