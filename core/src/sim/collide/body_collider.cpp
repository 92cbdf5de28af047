#include "kiji/collision.h"

#include "base/geometry.h"
#include "kiji/error.h"

#include <btBulletCollisionCommon.h>

#include <algorithm>
#include <cmath>
#include <limits>

static_assert(sizeof(btScalar) == 8, "Kiji needs Bullet in double precision (pkg-config bullet-float64)");

namespace kiji {

// The body's triangles in Bullet: an indexed vertex array and a static BVH triangle-mesh shape
// (a quantised AABB tree) over it. Exact tests are ours (geometry.h).
struct BodyCollider::Impl {
  std::vector<int> indices;       // 3 per triangle
  std::vector<btScalar> coords;   // 3 per vertex
  std::vector<Box3> boxes;        // exact AABB per triangle (the tree's boxes are quantised)
  std::vector<Vec3> normals;
  std::unique_ptr<btTriangleIndexVertexArray> array;
  std::unique_ptr<btBvhTriangleMeshShape> shape;
};

namespace {
struct Collect : btNodeOverlapCallback {
  const std::vector<Box3>* boxes;
  Box3 box;
  std::vector<int>* out;
  void processNode(int /*subPart*/, int triangle) override {
    if ((*boxes)[triangle].intersects(box)) out->push_back(triangle);
  }
};
}  // namespace

bool BodyCollider::degenerate(const Body& body, std::size_t t) {
  const auto& v = body.vertices();
  const auto& tri = body.triangles()[t];
  return (v[tri[1]] - v[tri[0]]).cross(v[tri[2]] - v[tri[0]]).squaredNorm() == 0;
}

BodyCollider::BodyCollider(const Body& body) : body_(&body), impl_(std::make_unique<Impl>()) {
  const auto& verts = body.vertices();
  const auto& tris = body.triangles();
  if (tris.empty()) throw InputError("body '" + body.name() + "' has no triangles to collide with");
  impl_->coords.reserve(verts.size() * 3);
  for (const Vec3& v : verts) {
    impl_->coords.push_back(v.x());
    impl_->coords.push_back(v.y());
    impl_->coords.push_back(v.z());
  }
  impl_->indices.reserve(tris.size() * 3);
  impl_->boxes.reserve(tris.size());
  impl_->normals.reserve(tris.size());
  for (std::size_t t = 0; t < tris.size(); ++t) {
    Box3 b;
    for (int k = 0; k < 3; ++k) {
      impl_->indices.push_back(tris[t][k]);
      b.extend(verts[tris[t][k]]);
    }
    // A triangle of no area has no side to be on: it is in no box (found by no query), and the
    // cloth meets the triangles around it instead.
    if (degenerate(body, t)) b.setEmpty();
    impl_->boxes.push_back(b);
    impl_->normals.push_back(body.triangle_normal(t));
  }
  impl_->array = std::make_unique<btTriangleIndexVertexArray>(
      static_cast<int>(tris.size()), impl_->indices.data(), 3 * static_cast<int>(sizeof(int)),
      static_cast<int>(verts.size()), impl_->coords.data(), 3 * static_cast<int>(sizeof(btScalar)));
  impl_->shape = std::make_unique<btBvhTriangleMeshShape>(impl_->array.get(), true, true);
}

BodyCollider::~BodyCollider() = default;

void BodyCollider::triangles_in_box(const Box3& box, std::vector<int>& out) const {
  out.clear();
  if (box.isEmpty()) return;
  Collect cb;
  cb.boxes = &impl_->boxes;
  cb.box = box;
  cb.out = &out;
  const btVector3 lo(box.min().x(), box.min().y(), box.min().z());
  const btVector3 hi(box.max().x(), box.max().y(), box.max().z());
  impl_->shape->getOptimizedBvh()->reportAabbOverlappingNodex(&cb, lo, hi);
}

BodyContact BodyCollider::closest(const Vec3& p, double radius) const {
  BodyContact best;
  if (!all_finite(p) || !(radius > 0)) return best;
  std::vector<int> tris;
  triangles_in_box(Box3(p - Vec3::Constant(radius), p + Vec3::Constant(radius)), tris);
  const auto& V = body_->vertices();
  const auto& T = body_->triangles();
  double best_d2 = radius * radius;
  double best_align = -1;
  for (int t : tris) {
    const auto cp = geom::closest_on_triangle(p, V[T[t][0]], V[T[t][1]], V[T[t][2]]);
    const Vec3 d = p - cp.point;
    const double d2 = d.squaredNorm();
    if (d2 > best_d2 * (1 + 1e-12) + 1e-30) continue;
    // Ties (the closest point on a shared edge or vertex): take the triangle whose normal is best
    // aligned with the offset, so the sign is the one of the face the point is really over.
    const double len = std::sqrt(d2);
    const double align = len > 0 ? std::abs(d.dot(impl_->normals[t])) / len : 1.0;
    if (best.hit && d2 >= best_d2 * (1 - 1e-12) - 1e-30 && align <= best_align) continue;
    best.hit = true;
    best.triangle = static_cast<std::size_t>(t);
    best.point = cp.point;
    best.normal = impl_->normals[t];
    best.distance = d.dot(best.normal) >= 0 ? len : -len;
    best_d2 = d2;
    best_align = align;
  }
  return best;
}

bool BodyCollider::inside(const Vec3& p) const {
  if (!all_finite(p)) return false;
  const Box3 bounds = body_->bounds();
  if (!bounds.contains(p)) return false;
  const double reach = 1.01 * bounds.diagonal().norm() + 1e-9;
  // Nearly along axes, so that each ray's box is thin and meets few triangles; off them by odd
  // angles, so that a ray seldom grazes an edge of a body meshed along the axes.
  static const Vec3 kRays[3] = {Vec3(1, 0.0123, 0.0071).normalized(), Vec3(-1, 0.0089, -0.0137).normalized(),
                                Vec3(0.0111, -0.0061, -1).normalized()};
  const auto& V = body_->vertices();
  const auto& T = body_->triangles();
  std::vector<int> tris;
  int votes = 0;
  for (const Vec3& dir : kRays) {
    const Vec3 q = p + reach * dir;
    triangles_in_box(Box3(p.cwiseMin(q), p.cwiseMax(q)), tris);
    int crossings = 0;
    for (int t : tris) {
      double s;
      if (!geom::segment_crosses_triangle(p, q, V[T[t][0]], V[T[t][1]], V[T[t][2]], s)) continue;
      crossings += dir.dot(impl_->normals[t]) > 0 ? 1 : -1;
    }
    votes += crossings > 0;
  }
  if (votes == 0 || votes == 3) return votes == 3;
  // The rays disagree where the surface is open (a hole, a sheet with one side, parts that meet
  // along edges shared by three faces): there the volume's own measure decides, the winding number
  // of the whole surface around p (Jacobson et al. 2013), 1 inside and 0 outside, a half by a hole.
  double w = 0;
  for (const auto& t : T) {
    const Vec3 a = V[t[0]] - p, b = V[t[1]] - p, c = V[t[2]] - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    w += 2 * std::atan2(a.dot(b.cross(c)), la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb);
  }
  return w / (4 * M_PI) > 0.5;
}

BodyContact BodyCollider::first_crossing(const Vec3& a, const Vec3& b) const {
  BodyContact best;
  if (!all_finite(a) || !all_finite(b)) return best;
  Box3 box(a.cwiseMin(b), a.cwiseMax(b));
  std::vector<int> tris;
  triangles_in_box(box, tris);
  const auto& V = body_->vertices();
  const auto& T = body_->triangles();
  double best_t = std::numeric_limits<double>::infinity();
  for (int t : tris) {
    double s;
    if (!geom::segment_crosses_triangle(a, b, V[T[t][0]], V[T[t][1]], V[T[t][2]], s)) continue;
    if (s >= best_t) continue;
    best_t = s;
    best.hit = true;
    best.triangle = static_cast<std::size_t>(t);
    best.point = a + s * (b - a);
    best.normal = impl_->normals[t];
    best.distance = (a - best.point).dot(best.normal);  // > 0: the segment enters from outside
  }
  return best;
}

}  // namespace kiji
