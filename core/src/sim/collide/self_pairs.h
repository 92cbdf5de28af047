// The exact test that makes a vertex and a cloth triangle a self-collision pair, shared by the
// searches that find the candidates (solver_collide.cpp, self_grid.cpp). Private to libkiji.
#pragma once

#include "base/geometry.h"
#include "sim/solver_state.h"

#include <algorithm>
#include <cmath>

namespace kiji::solver_detail {

// Whether vertex v and triangle t can come within the distance resolve_self keeps them apart
// during the window (each moving by `win`), and if so the pair, with the side v is on and their
// distance now.
inline bool self_pair_test(const SolverArrays& s, double th, int v, int t, SolverArrays::SelfPair& out) {
  const auto& tri = s.tris[t];
  if (s.w[v] == 0 && s.w[tri[0]] == 0 && s.w[tri[1]] == 0 && s.w[tri[2]] == 0) return false;
  const Vec3& A = s.x[tri[0]];
  const Vec3& B = s.x[tri[1]];
  const Vec3& C = s.x[tri[2]];
  double rel = 0;
  for (int k = 0; k < 3; ++k) rel = std::max(rel, (s.win[v] - s.win[tri[k]]).squaredNorm());
  // resolve_self keeps a pair min(thickness, 0.6 spacing) apart: pairs that cannot come that
  // close are none (on a mesh finer than the thickness, the full thickness would gather several
  // rings of neighbours for every vertex, and more the finer the mesh).
  const double reach = std::min(th, 0.6 * s.spacing[v]) + std::sqrt(rel);
  // The plane first (cheap): a vertex further from the triangle's plane than it can come during
  // the window is no pair. Then the sphere around the triangle (on a flat sheet the plane test
  // passes the triangles next to the vertex's neighbours, none of them within reach).
  const Vec3& n = s.tri_n[t];
  const double dn = (s.x[v] - A).dot(n);
  if (dn * dn > reach * reach) return false;
  const double r = s.tri_r[t] + reach;
  if ((s.x[v] - s.tri_g[t]).squaredNorm() > r * r) return false;
  const geom::ClosestPoint cp = geom::closest_on_triangle(s.x[v], A, B, C);
  const Vec3 d = s.x[v] - cp.point;
  if (d.squaredNorm() > reach * reach) return false;  // cannot come within the thickness in the window
  out = {v, t, d.dot((B - A).cross(C - A)) >= 0 ? 1.0 : -1.0, d.norm()};
  return true;
}

}  // namespace kiji::solver_detail
