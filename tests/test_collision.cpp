#include "kiji/collision.h"
#include "kiji/error.h"
#include "test_shapes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

using namespace kiji;

namespace {
Body one_triangle() {
  return Body::from_triangles({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{{0, 1, 2}}}, "triangle");
}
void expect_vec(const Vec3& a, const Vec3& b, double tol) {
  EXPECT_NEAR((a - b).norm(), 0.0, tol) << "got (" << a.transpose() << "), expected (" << b.transpose() << ")";
}
}  // namespace

TEST(Collision, ClosestPointOnAKnownTriangleInEveryRegion) {
  const Body body = one_triangle();
  BodyCollider c(body);
  struct Case {
    Vec3 p, q;
  };
  const Case cases[] = {
      {{0.2, 0.3, 0.5}, {0.2, 0.3, 0}},   // over the face
      {{-1, -2, 0.1}, {0, 0, 0}},         // vertex regions
      {{3, -1, 0}, {1, 0, 0}},
      {{-0.5, 2, -0.2}, {0, 1, 0}},
      {{0.5, -1, 0.3}, {0.5, 0, 0}},      // edge regions
      {{-2, 0.4, 0}, {0, 0.4, 0}},
      {{1, 1, 0.25}, {0.5, 0.5, 0}},      // hypotenuse
  };
  for (const auto& k : cases) {
    const BodyContact r = c.closest(k.p, 10.0);
    ASSERT_TRUE(r.hit);
    EXPECT_EQ(r.triangle, 0u);
    expect_vec(r.point, k.q, 1e-12);
    EXPECT_NEAR(std::abs(r.distance), (k.p - k.q).norm(), 1e-12);
  }
  // Too far for the radius: no hit.
  EXPECT_FALSE(c.closest(Vec3(0.2, 0.2, 5), 1.0).hit);
}

TEST(Collision, SignedDistanceIsPositiveInFrontNegativeBehind) {
  const Body body = one_triangle();
  BodyCollider c(body);
  const BodyContact front = c.closest(Vec3(0.25, 0.25, 0.1), 1.0);
  const BodyContact back = c.closest(Vec3(0.25, 0.25, -0.1), 1.0);
  ASSERT_TRUE(front.hit && back.hit);
  expect_vec(front.normal, Vec3(0, 0, 1), 1e-12);  // counter-clockwise from +z
  EXPECT_NEAR(front.distance, 0.1, 1e-12);
  EXPECT_NEAR(back.distance, -0.1, 1e-12);
}

TEST(Collision, SphereDistancesNormalsAndSigns) {
  const double R = 0.3;
  const Vec3 centre(0.1, 1.0, -0.2);
  const Body sphere = test::make_sphere(R, centre, 3);
  BodyCollider c(sphere);
  // The facets lie between the inscribed and circumscribed spheres; at 1,280 triangles the facet
  // planes come within 0.6 % of R of the centre.
  const double tess = 0.006 * R;
  for (const Vec3 dir : {Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, -1), Vec3(1, 1, 1).normalized(),
                         Vec3(-0.3, -1, 0.5).normalized()}) {
    for (double r : {0.2, 0.29, 0.31, 0.35}) {
      const BodyContact k = c.closest(centre + r * dir, 0.2);
      ASSERT_TRUE(k.hit) << "r=" << r;
      EXPECT_NEAR(k.distance, r - R, tess) << "r=" << r;
      EXPECT_GT(k.normal.dot(dir), 0.95) << "normals point outwards";
      EXPECT_NEAR((k.point - centre).norm(), R, tess);
    }
  }
}

TEST(Collision, SegmentCrossingFindsTheFirstTriangle) {
  const double R = 0.3;
  const Vec3 centre(0, 0, 0);
  const Body sphere = test::make_sphere(R, centre, 3);
  BodyCollider c(sphere);
  const BodyContact in = c.first_crossing(Vec3(-1, 0.05, 0.02), Vec3(1, 0.05, 0.02));
  ASSERT_TRUE(in.hit);
  EXPECT_LT(in.point.x(), 0) << "the first crossing is on the near side";
  EXPECT_NEAR(in.point.norm(), R, 0.004 * R);
  EXPECT_GT(in.distance, 0) << "entering from outside";
  EXPECT_LT(in.normal.x(), -0.9);
  // From inside out: the crossing is where it leaves, with the start behind the surface.
  const BodyContact out = c.first_crossing(Vec3(0, 0, 0), Vec3(0, 1, 0));
  ASSERT_TRUE(out.hit);
  EXPECT_NEAR(out.point.y(), R, 0.004 * R);
  EXPECT_LT(out.distance, 0);
  // Missing it, or stopping short of it: no crossing.
  EXPECT_FALSE(c.first_crossing(Vec3(-1, 0.5, 0), Vec3(1, 0.5, 0)).hit);
  EXPECT_FALSE(c.first_crossing(Vec3(-1, 0, 0), Vec3(-0.35, 0, 0)).hit);
  EXPECT_FALSE(c.first_crossing(Vec3(-0.1, 0, 0), Vec3(0.1, 0, 0)).hit) << "wholly inside";
}

TEST(Collision, TreeQueryReturnsExactlyTheTrianglesOfABox) {
  const Body sphere = test::make_sphere(0.3, Vec3(0, 0, 0), 3);
  BodyCollider c(sphere);
  const Box3 cap(Vec3(-0.1, 0.25, -0.1), Vec3(0.1, 0.4, 0.1));
  std::vector<int> got;
  c.triangles_in_box(cap, got);
  std::vector<int> expected;
  const auto& V = sphere.vertices();
  for (std::size_t t = 0; t < sphere.triangles().size(); ++t) {
    Box3 b;
    for (int k = 0; k < 3; ++k) b.extend(V[sphere.triangles()[t][k]]);
    if (b.intersects(cap)) expected.push_back(static_cast<int>(t));
  }
  std::sort(got.begin(), got.end());
  ASSERT_FALSE(expected.empty());
  EXPECT_EQ(got, expected);
  for (int t : got) EXPECT_GT(sphere.triangle_normal(t).y(), 0.5) << "a triangle of the top cap";
  c.triangles_in_box(Box3(Vec3(2, 2, 2), Vec3(3, 3, 3)), got);
  EXPECT_TRUE(got.empty());
}
