// Procedural shapes for the tests: bodies built with Body::from_triangles.
#pragma once

#include "kiji/body.h"

#include <array>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

namespace kiji::test {

// A floor 4 m square at y = 0, facing up.
inline Body make_floor() {
  return Body::from_triangles({{-2, 0, -2}, {2, 0, -2}, {2, 0, 2}, {-2, 0, 2}}, {{{0, 2, 1}}, {{0, 3, 2}}}, "floor");
}

// An icosphere of the given radius and centre, subdivided `levels` times (20 * 4^levels
// triangles), wound counter-clockwise seen from outside so normals point outwards.
inline Body make_sphere(double radius, const Vec3& centre, int levels = 3) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                         {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& p : v) p.normalize();
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9}, {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8}, {3, 8, 9},
                                       {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      const int id = static_cast<int>(v.size()) - 1;
      mid[key] = id;
      return id;
    };
    std::vector<std::array<int, 3>> g;
    for (const auto& tri : f) {
      const int a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), c = midpoint(tri[2], tri[0]);
      g.push_back({tri[0], a, c});
      g.push_back({tri[1], b, a});
      g.push_back({tri[2], c, b});
      g.push_back({a, b, c});
    }
    f.swap(g);
  }
  for (auto& tri : f) {  // make sure every triangle faces outwards
    const Vec3 n = (v[tri[1]] - v[tri[0]]).cross(v[tri[2]] - v[tri[0]]);
    if (n.dot(v[tri[0]] + v[tri[1]] + v[tri[2]]) < 0) std::swap(tri[1], tri[2]);
  }
  for (auto& p : v) p = centre + radius * p;
  return Body::from_triangles(std::move(v), std::move(f), "sphere");
}

// A slab 3 m square and 0.2 m thick whose top face passes through the origin, tilted by `degrees`
// about z: its top runs downhill towards -x (for positive degrees).
inline Body make_slope(double degrees) {
  const double a = degrees * M_PI / 180, c = std::cos(a), s = std::sin(a);
  std::vector<Vec3> v;
  for (double x : {-1.5, 1.5})
    for (double y : {-0.2, 0.0})
      for (double z : {-1.5, 1.5}) v.emplace_back(c * x - s * y, s * x + c * y, z);
  // Corner index 4 ix + 2 iy + iz; each side as two triangles, wound outwards.
  std::vector<std::array<int, 3>> f;
  for (const std::array<int, 4>& q : {std::array<int, 4>{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6},
                                      {0, 2, 6, 4}, {1, 5, 7, 3}}) {
    f.push_back({q[0], q[1], q[2]});
    f.push_back({q[0], q[2], q[3]});
  }
  const Vec3 middle(0.1 * s, -0.1 * c, 0);  // half the thickness below the top's middle
  for (auto& tri : f) {
    const Vec3 n = (v[tri[1]] - v[tri[0]]).cross(v[tri[2]] - v[tri[0]]);
    if (n.dot(v[tri[0]] + v[tri[1]] + v[tri[2]] - 3 * middle) < 0) std::swap(tri[1], tri[2]);
  }
  return Body::from_triangles(std::move(v), std::move(f), "slope");
}

// An axis-aligned box from `lo` to `hi`, wound outwards (a thin one is a wall with a sharp top).
inline Body make_box(const Vec3& lo, const Vec3& hi) {
  std::vector<Vec3> v;
  for (double x : {lo.x(), hi.x()})
    for (double y : {lo.y(), hi.y()})
      for (double z : {lo.z(), hi.z()}) v.emplace_back(x, y, z);
  std::vector<std::array<int, 3>> f;
  for (const std::array<int, 4>& q : {std::array<int, 4>{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6},
                                      {0, 2, 6, 4}, {1, 5, 7, 3}}) {
    f.push_back({q[0], q[1], q[2]});
    f.push_back({q[0], q[2], q[3]});
  }
  const Vec3 middle = 0.5 * (lo + hi);
  for (auto& tri : f) {
    const Vec3 n = (v[tri[1]] - v[tri[0]]).cross(v[tri[2]] - v[tri[0]]);
    if (n.dot(v[tri[0]] + v[tri[1]] + v[tri[2]] - 3 * middle) < 0) std::swap(tri[1], tri[2]);
  }
  return Body::from_triangles(std::move(v), std::move(f), "box");
}

}  // namespace kiji::test
