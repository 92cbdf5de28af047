#include "kiji/haptic_force.h"

#include "base/geometry.h"

#include <algorithm>

namespace kiji {

const Vec3* HapticSnapshot::position_of(Vertex v) const {
  const auto it = std::lower_bound(vertices.begin(), vertices.end(), v);
  if (it == vertices.end() || *it != v) return nullptr;
  return &positions[static_cast<std::size_t>(it - vertices.begin())];
}

SurfaceHit HapticSnapshot::nearest(const Vec3& p) const {
  SurfaceHit best;
  for (const auto& t : triangles) {
    const Vec3 &a = positions[t[0]], &b = positions[t[1]], &c = positions[t[2]];
    const geom::ClosestPoint cp = geom::closest_on_triangle(p, a, b, c);
    const double d = (cp.point - p).norm();
    if (d >= best.distance) continue;
    best.hit = true;
    best.garment = garment;
    best.point = cp.point;
    best.distance = d;
    best.barycentric = Vec3(cp.b0, cp.b1, cp.b2);
    const Vec3 n = (b - a).cross(c - a);
    best.normal = n.norm() > 0 ? Vec3(n.normalized()) : Vec3(0, 1, 0);
    int k = 0;
    best.barycentric.maxCoeff(&k);
    best.nearest = vertices[t[k]];
  }
  return best;
}

Vec3 HapticSpring::force(const HapticSnapshot& snapshot, const Vec3& pointer) const {
  Vec3 f = Vec3::Zero();
  if (vertices.empty() || snapshot.garment != garment) return f;
  const double k = share();
  for (std::size_t i = 0; i < vertices.size(); ++i)
    if (const Vec3* x = snapshot.position_of(vertices[i])) f += k * (*x - offsets[i] - pointer);
  return f;
}

Vec3 HapticSpring::force(const Garment& g, const Vec3& pointer) const {
  Vec3 f = Vec3::Zero();
  if (vertices.empty()) return f;
  const double k = share();
  const Mesh& m = g.mesh();
  for (std::size_t i = 0; i < vertices.size(); ++i)
    if (m.has_valid_index(vertices[i]) && !m.is_removed(vertices[i])) f += k * (g.position(vertices[i]) - offsets[i] - pointer);
  return f;
}

Vec3 HapticPush::force(const SurfaceHit& nearest, const Vec3& pen) const {
  if (!nearest.hit || nearest.distance > touch) return Vec3::Zero();
  Vec3 n = nearest.normal;
  if ((pen - nearest.point).dot(n) < 0) n = -n;
  return stiffness * (touch - nearest.distance) * n;
}

Feedback haptic_model_force(const HapticModel& model, const HapticSnapshot& snapshot, const ToolEvent& event) {
  Feedback f;
  if (const auto* spring = std::get_if<HapticSpring>(&model)) f.force = spring->force(snapshot, event.position);
  else if (const auto* push = std::get_if<HapticPush>(&model)) f.force = push->force(snapshot.nearest(event.position), event.position);
  return f;
}

}  // namespace kiji
