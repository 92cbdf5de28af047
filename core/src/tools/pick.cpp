#include "kiji/pick.h"

#include "base/geometry.h"
#include "base/parallel.h"

namespace kiji {

SurfaceHit pick(const std::vector<Garment>& garments, const Vec3& position, const Vec3& ray, double radius) {
  SurfaceHit best;
  if (!all_finite(position) || !all_finite(ray)) return best;
  const bool use_ray = ray.squaredNorm() > 0;
  const Vec3 dir = use_ray ? Vec3(ray.normalized()) : Vec3::Zero();
  const double reach = 1e3;
  // Each vertex's side of the ray's line (or of the box within radius of the point), in a
  // mask of six bits: a triangle whose three corners share a bit is wholly to one side, missed,
  // with no test of its own. The few left are tested exactly.
  Vec3 e1 = Vec3::UnitX(), e2 = Vec3::UnitY(), e3 = Vec3::UnitZ();
  if (use_ray) {
    e3 = dir;
    e1 = dir.unitOrthogonal();
    e2 = e3.cross(e1);
  }
  const Vec3 lo = use_ray ? Vec3(0, 0, 0) : Vec3::Constant(-radius);
  const Vec3 hi = use_ray ? Vec3(0, 0, reach) : Vec3::Constant(radius);
  // In parallel, in pieces of the face indices: each piece keeps its nearest hit (the first of
  // equals), and the pieces' are taken in order, as one loop over the faces would; the winner's
  // normal, uv and nearest corner are filled in after.
  for (std::size_t gi = 0; gi < garments.size(); ++gi) {
    const Garment& g = garments[gi];
    const Mesh& m = g.mesh();
    const int nv = static_cast<int>(g.vertex_capacity());
    const int nf = static_cast<int>(m.number_of_faces() + m.number_of_removed_faces());
    std::vector<unsigned char> side(nv, 0);
    parallel::for_range(nv, 4096, [&](int b0, int b1) {
      for (int i = b0; i < b1; ++i) {
        const Vertex v(i);
        if (m.is_removed(v)) continue;
        const Vec3 r = g.position(v) - position;
        const Vec3 q(r.dot(e1), r.dot(e2), r.dot(e3));
        const double tol = 1e-9 * (1 + r.cwiseAbs().maxCoeff());  // the projections' rounding, well covered
        unsigned char bits = 0;
        for (int k = 0; k < 3; ++k)
          bits |= static_cast<unsigned char>(((q[k] < lo[k] - tol) << (2 * k)) | ((q[k] > hi[k] + tol) << (2 * k + 1)));
        side[i] = bits;
      }
    });
    const int pieces = parallel::piece_count(nf, 4096);
    std::vector<SurfaceHit> found(pieces);
    parallel::for_each(pieces, [&](int piece) {
      SurfaceHit& mine = found[piece];
      for (int fi = parallel::piece_begin(nf, piece, pieces), fe = parallel::piece_begin(nf, piece + 1, pieces);
           fi < fe; ++fi) {
        const Face f(fi);
        if (m.is_removed(f)) continue;
        const Halfedge h0 = m.halfedge(f), h1 = m.next(h0), h2 = m.next(h1);
        if (side[m.target(h0).idx()] & side[m.target(h1).idx()] & side[m.target(h2).idx()]) continue;
        const Vec3 a = g.position(m.target(h0)), b = g.position(m.target(h1)), c = g.position(m.target(h2));
        Vec3 point, bary;
        double distance;
        if (use_ray) {
          double t = 0;
          if (!geom::segment_crosses_triangle(position, position + reach * dir, a, b, c, t)) continue;
          point = position + t * reach * dir;
          const geom::ClosestPoint cp = geom::closest_on_triangle(point, a, b, c);
          bary = Vec3(cp.b0, cp.b1, cp.b2);
          distance = t * reach;
        } else {
          const geom::ClosestPoint cp = geom::closest_on_triangle(position, a, b, c);
          point = cp.point;
          bary = Vec3(cp.b0, cp.b1, cp.b2);
          distance = (point - position).norm();
          if (distance > radius) continue;
        }
        if (distance >= mine.distance) continue;
        mine.hit = true;
        mine.garment = gi;
        mine.face = f;
        mine.barycentric = bary;
        mine.point = point;
        mine.distance = distance;
      }
    });
    for (const SurfaceHit& mine : found)
      if (mine.distance < best.distance) best = mine;
  }
  if (!best.hit) return best;
  const Garment& g = garments[best.garment];
  const Mesh& m = g.mesh();
  const Halfedge h0 = m.halfedge(best.face), h1 = m.next(h0), h2 = m.next(h1);
  const Vec3 a = g.position(m.target(h0)), b = g.position(m.target(h1)), c = g.position(m.target(h2));
  const Vec3& bary = best.barycentric;
  const Vec3 n = (b - a).cross(c - a);
  best.normal = n.norm() > 0 ? Vec3(n.normalized()) : Vec3(0, 1, 0);
  best.uv = bary[0] * g.uv(h0) + bary[1] * g.uv(h1) + bary[2] * g.uv(h2);
  int k = 0;
  bary.maxCoeff(&k);
  best.nearest = m.target(k == 0 ? h0 : (k == 1 ? h1 : h2));
  return best;
}

}  // namespace kiji
