#include "kiji/collision.h"
#include "kiji/error.h"
#include "support/test_shapes.h"

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

namespace {
// The generalised winding number of a triangle soup at p (Jacobson et al. 2013): the solid angle
// its triangles subtend, signed by their winding, over 4 pi. 1 inside a closed surface, 0 outside,
// whatever lies inside it or crosses it; an exact and slow reference for BodyCollider::inside.
double winding_number(const Body& body, const Vec3& p) {
  double w = 0;
  for (const auto& t : body.triangles()) {
    const Vec3 a = body.vertices()[t[0]] - p, b = body.vertices()[t[1]] - p, c = body.vertices()[t[2]] - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    w += 2 * std::atan2(a.dot(b.cross(c)), la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb);
  }
  return w / (4 * M_PI);
}

// A sphere with a fin of no thickness on top (two triangles back to back, as game models make a
// blade or a fingertip), and a second sphere overlapping the first.
Body sphere_with_fin_and_twin() {
  const Body a = test::make_sphere(0.1, Vec3(0, 0, 0), 2), b = test::make_sphere(0.1, Vec3(0.15, 0, 0), 2);
  std::vector<Vec3> v = a.vertices();
  std::vector<std::array<int, 3>> t = a.triangles();
  const int n = static_cast<int>(v.size());
  for (const Vec3& p : b.vertices()) v.push_back(p);
  for (const auto& f : b.triangles()) t.push_back({f[0] + n, f[1] + n, f[2] + n});
  const int m = static_cast<int>(v.size());
  v.insert(v.end(), {Vec3(-0.05, 0.09, 0), Vec3(0.05, 0.09, 0), Vec3(0, 0.2, 0)});
  t.push_back({m, m + 1, m + 2});
  t.push_back({m, m + 2, m + 1});
  return Body::from_triangles(std::move(v), std::move(t), "sphere with a fin");
}
}  // namespace

TEST(Collision, InsideIsByTheVolumeNotByTheClosestFace) {
  const Body body = sphere_with_fin_and_twin();
  BodyCollider c(body);
  EXPECT_TRUE(c.inside(Vec3(-0.02, 0.01, 0.03)));
  EXPECT_TRUE(c.inside(Vec3(0.075, 0, 0))) << "where the two spheres overlap";
  EXPECT_FALSE(c.inside(Vec3(0, 0, 0.15)));
  EXPECT_FALSE(c.inside(Vec3(5, 5, 5))) << "far outside";
  EXPECT_FALSE(c.inside(Vec3(std::nan(""), 0, 0)));
  // Beside the fin, on either side: outside, though one of the fin's faces is closest and faces
  // away from the point.
  int face_says_inside = 0;
  for (double z : {0.01, -0.01}) {
    const Vec3 p(0.002, 0.15, z);
    EXPECT_FALSE(c.inside(p)) << "z = " << z;
    face_says_inside += c.closest(p, 0.1).distance < 0;
  }
  EXPECT_EQ(face_says_inside, 1) << "the case this test is for: the closest face's side is wrong on one side";
}

// A Quake II character (679 triangles) has all the faults game models have: fins of no thickness
// at the hands, faces turned inwards and buried in the volume, hair overlapping the head, a hole.
// Near its surface, inside agrees with the exact winding number everywhere.
TEST(Collision, InsideAgreesWithTheWindingNumberNearAGameCharacter) {
  BodyImportOptions o;
  o.height = 1.7;
  const Body body = Body::load(KIJI_TEST_MODELS "/MD2/sydney.md2", o);
  BodyCollider c(body);
  std::uint64_t seed = 12345;
  auto uniform = [&] {  // a fixed sequence in [-1, 1)
    seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
    return double(seed >> 11) / double(1ULL << 52) - 1.0;
  };
  const auto& V = body.vertices();
  int tested = 0, wrong = 0, face_wrong = 0, inside = 0;
  for (int k = 0; k < 3000; ++k) {
    const Vec3 p = V[k * 7919 % V.size()] + 0.03 * Vec3(uniform(), uniform(), uniform());
    const double w = winding_number(body, p);
    if (std::abs(w - std::round(w)) > 0.1) continue;  // by the hole: neither in nor out
    const bool in = w > 0.5;
    ++tested;
    inside += in;
    wrong += c.inside(p) != in;
    const BodyContact near = c.closest(p, 0.1);
    face_wrong += near.hit && (near.distance < 0) != in;
  }
  EXPECT_GT(tested, 2900);
  EXPECT_GT(inside, 500);
  EXPECT_EQ(wrong, 0) << "of " << tested << " points";
  EXPECT_GT(face_wrong, 10) << "the faults this test is for: the closest face's side is wrong there";
}

// The cloth's vertices that `kiji drape --body faerie.md2 --height 1.7` left by the wing's root (a
// surface with 192 border edges and 40 edges of three faces), where two of the three rays crossed
// the wing from behind and counted the point inside: the winding number there is about 0.05.
TEST(Collision, InsideHoldsWhereTheRaysDisagreeOnAnOpenSurface) {
  BodyImportOptions o;
  o.height = 1.7;
  o.find_front = true;
  o.smooth = true;
  const Body body = Body::load(KIJI_TEST_MODELS "/MD2/faerie.md2", o);
  BodyCollider c(body);
  for (const Vec3& p : {Vec3(0.1549, 1.4924, 0.0512), Vec3(0.1309, 1.4520, 0.0763), Vec3(0.1347, 1.4507, 0.0758)}) {
    const double w = winding_number(body, p);
    ASSERT_LT(w, 0.1) << "outside by the winding number: " << p.transpose();
    EXPECT_FALSE(c.inside(p)) << p.transpose();
  }
  // And inside and outside agree with the winding number near the whole figure.
  const auto& V = body.vertices();
  int tested = 0, wrong = 0, inside = 0;
  for (std::size_t k = 0; k < 2000; ++k) {
    const Vec3 p = V[k * 7919 % V.size()] + 0.02 * Vec3(std::sin(k * 1.3), std::cos(k * 2.1), std::sin(k * 0.7 + 1));
    const double w = winding_number(body, p);
    if (std::abs(w - std::round(w)) > 0.1) continue;  // by a hole: neither in nor out
    ++tested;
    inside += w > 0.5;
    wrong += c.inside(p) != (w > 0.5);
  }
  EXPECT_GT(tested, 1500);
  EXPECT_GT(inside, 300);
  EXPECT_EQ(wrong, 0) << "of " << tested << " points";
}
