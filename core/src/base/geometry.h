// Exact point-triangle and segment-triangle queries, shared by the collider and the solver.
// Private to libkiji.
#pragma once

#include "kiji/types.h"

#include <algorithm>
#include <cmath>

namespace kiji::geom {

struct ClosestPoint {
  Vec3 point;
  double b0, b1, b2;  // barycentric coordinates of `point` on (a, b, c)
};

// The point of triangle (a, b, c) closest to p, by Voronoi regions (Ericson, Real-Time Collision
// Detection, 5.1.5). Degenerate triangles are handled (the result is on one of the edges).
inline ClosestPoint closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return {a, 1, 0, 0};
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return {b, 0, 1, 0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 - d3 > 0 ? d1 / (d1 - d3) : 0.0;  // d1 - d3 = |ab|^2: 0 when a = b
    return {a + v * ab, 1 - v, v, 0};
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return {c, 0, 0, 1};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 - d6 > 0 ? d2 / (d2 - d6) : 0.0;  // |ac|^2
    return {a + w * ac, 1 - w, 0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double bc2 = (d4 - d3) + (d5 - d6);  // |bc|^2
    const double w = bc2 > 0 ? (d4 - d3) / bc2 : 0.0;
    return {b + w * (c - b), 0, 1 - w, w};
  }
  const double denom = va + vb + vc;
  if (!(denom > 0)) {  // degenerate (zero-area) triangle: fall back to the closest edge point
    auto seg = [&](const Vec3& s0, const Vec3& s1, double& t) {
      const Vec3 d = s1 - s0;
      const double dd = d.squaredNorm();
      t = dd > 0 ? std::clamp((p - s0).dot(d) / dd, 0.0, 1.0) : 0.0;
      return (s0 + t * d - p).squaredNorm();
    };
    double t0, t1, t2;
    const double e0 = seg(a, b, t0), e1 = seg(b, c, t1), e2 = seg(c, a, t2);
    if (e0 <= e1 && e0 <= e2) return {a + t0 * ab, 1 - t0, t0, 0};
    if (e1 <= e2) return {b + t1 * (c - b), 0, 1 - t1, t1};
    return {c + t2 * (a - c), t2, 0, 1 - t2};
  }
  const double inv = 1.0 / denom;
  const double v = vb * inv, w = vc * inv;
  return {a + ab * v + ac * w, 1 - v - w, v, w};
}

// Where the segment p -> q crosses triangle (a, b, c) (either side), as the segment parameter t in
// [0, 1]; false if it does not (Moller-Trumbore; a segment lying in the triangle's plane does not
// count as crossing).
inline bool segment_crosses_triangle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b,
                                     const Vec3& c, double& t_out) {
  const Vec3 d = q - p;
  const Vec3 e1 = b - a, e2 = c - a;
  const Vec3 h = d.cross(e2);
  const double det = e1.dot(h);
  const double scale = e1.norm() * e2.norm() * d.norm();
  if (!(std::abs(det) > 1e-14 * scale)) return false;
  const double inv = 1.0 / det;
  const Vec3 s = p - a;
  const double u = inv * s.dot(h);
  if (u < 0 || u > 1) return false;
  const Vec3 qv = s.cross(e1);
  const double v = inv * d.dot(qv);
  if (v < 0 || u + v > 1) return false;
  const double t = inv * e2.dot(qv);
  if (t < 0 || t > 1) return false;
  t_out = t;
  return true;
}

}  // namespace kiji::geom
