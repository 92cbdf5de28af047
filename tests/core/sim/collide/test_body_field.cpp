// The body's distance field (sim/collide/body_field.h): what a cell lists is what a vertex in it is
// tested against, so a triangle missing from a list is cloth that can pass through the body.
#include "sim/collide/body_field.h"
#include "base/geometry.h"
#include "support/test_shapes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <thread>

using namespace kiji;
using kiji::solver_detail::BodyField;

namespace {

// Every triangle of the body within `reach` of p, by brute force.
std::vector<int> near_triangles(const Body& body, const Vec3& p, double reach) {
  std::vector<int> out;
  const auto& V = body.vertices();
  const auto& T = body.triangles();
  for (std::size_t t = 0; t < T.size(); ++t)
    if ((p - geom::closest_on_triangle(p, V[T[t][0]], V[T[t][1]], V[T[t][2]]).point).norm() <= reach)
      out.push_back(static_cast<int>(t));
  return out;
}

double distance_to(const Body& body, const Vec3& p) {
  double best = 1e300;
  const auto& V = body.vertices();
  for (const auto& f : body.triangles())
    best = std::min(best, (p - geom::closest_on_triangle(p, V[f[0]], V[f[1]], V[f[2]]).point).norm());
  return best;
}

}  // namespace

TEST(BodyField, EveryTriangleWithinReachOfAPointIsInItsCellsList) {
  // Two spheres close together, as one body: a gap of 6 mm between them, as in a crease between two
  // parts of a body, where a cell lists triangles of both.
  Body a = test::make_sphere(0.08, Vec3(0, 0, 0), 3), b = test::make_sphere(0.05, Vec3(0.136, 0, 0), 3);
  std::vector<Vec3> v = a.vertices();
  std::vector<std::array<int, 3>> t = a.triangles();
  for (const Body* part : {&b}) {
    const int base = static_cast<int>(v.size());
    for (const Vec3& p : part->vertices()) v.push_back(p);
    for (auto f : part->triangles()) t.push_back({f[0] + base, f[1] + base, f[2] + base});
  }
  const Body body = Body::from_triangles(v, t, "two spheres");
  const double reach = 0.0042;  // a 4 mm cloth's, with the held margin
  const BodyField field(body, reach);
  EXPECT_GE(field.band(), reach + field.cell_radius());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  int near = 0;
  for (int k = 0; k < 4000; ++k) {
    // Points near the surfaces: within 1.5 cm of either sphere.
    Vec3 dir(u(rng), u(rng), u(rng));
    if (dir.norm() < 1e-3) continue;
    dir.normalize();
    const Vec3 p = k % 2 ? Vec3(Vec3(0.136, 0, 0) + (0.05 + 0.015 * u(rng)) * dir) : Vec3((0.08 + 0.015 * u(rng)) * dir);
    const std::vector<int> expected = near_triangles(body, p, reach);
    const std::int64_t cell = field.cell_of(p);
    if (expected.empty()) {
      // Out of reach: the cell is far, or its distance says the point cannot be within reach.
      if (cell >= 0) EXPECT_GT(field.distance(cell) + field.cell_radius(), reach - 1e-12);
      continue;
    }
    ++near;
    ASSERT_GE(cell, 0) << "a point within reach of the body is in no cell";
    EXPECT_LE(field.distance(cell), reach + field.cell_radius() + 1e-9) << "its cell is called far";
    // The cell's distance is the distance from its centre: within a cell's radius of the point's.
    EXPECT_NEAR(field.distance(cell), distance_to(body, p), field.cell_radius() + 1e-6);
    int count = 0;
    const int* listed = field.triangles(cell, count);
    for (int tri : expected) EXPECT_TRUE(std::binary_search(listed, listed + count, tri)) << "triangle " << tri;
  }
  EXPECT_GT(near, 1000);
}

TEST(BodyField, IsSharedByBodiesOfTheSameTrianglesAndWidenedForAThickerCloth) {
  const Body body = test::make_sphere(0.1, Vec3::Zero(), 2);
  const Body copy = body;
  const auto f1 = BodyField::of(body, 0.004);
  const auto f2 = BodyField::of(copy, 0.004);
  EXPECT_EQ(f1.get(), f2.get()) << "a copy of a body has the same field";
  // The same triangles made again (as each peer decodes the body from the wire) share it too; a
  // body with other triangles has its own.
  const Body again = test::make_sphere(0.1, Vec3::Zero(), 2);
  EXPECT_EQ(BodyField::of(again, 0.004).get(), f1.get()) << "the same triangles, loaded again";
  const Body other = test::make_sphere(0.11, Vec3::Zero(), 2);
  EXPECT_NE(BodyField::of(other, 0.004).get(), f1.get()) << "another body its own";
  const auto thick = BodyField::of(body, 0.03);  // a 3 cm padding
  EXPECT_GE(thick->band(), 0.03 + thick->cell_radius());
  EXPECT_EQ(BodyField::of(again, 0.004).get(), thick.get()) << "the wider field serves a thinner cloth";
}

TEST(BodyField, PointsFarAwayOrNotFiniteAreInNoCell) {
  const Body body = test::make_sphere(0.1, Vec3::Zero(), 2);
  const auto f = BodyField::of(body, 0.004);
  EXPECT_LT(f->cell_of(Vec3(0, 0, 0)), 0) << "the centre is 10 cm from the surface";
  EXPECT_LT(f->cell_of(Vec3(5, 0, 0)), 0);
  EXPECT_LT(f->cell_of(Vec3(std::nan(""), 0, 0)), 0);
  EXPECT_LT(f->cell_of(Vec3(1e308, -1e308, 0)), 0);
  EXPECT_GE(f->cell_of(Vec3(0.1, 0, 0)), 0) << "on the surface";
}

TEST(BodyField, BlocksFilledByManyThreadsInAnyOrderHoldWhatOneThreadFills) {
  // A block is filled in by the first point to fall in it, from whichever of the solver's threads:
  // peers compare state hashes, so the field must not depend on who asked first.
  const Body body = test::make_sphere(0.1, Vec3::Zero(), 3);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Vec3> points;
  while (points.size() < 6000) {
    Vec3 dir(u(rng), u(rng), u(rng));
    if (dir.norm() < 1e-3) continue;
    points.push_back((0.1 + 0.012 * u(rng)) * dir.normalized());
  }
  const BodyField serial(body, 0.0042);
  EXPECT_EQ(serial.blocks_filled(), 0u) << "nothing is filled in before a point asks";
  serial.cell_of(points[0]);
  EXPECT_EQ(serial.blocks_filled(), 1u);
  EXPECT_LT(serial.blocks_filled(), serial.blocks_near());
  std::vector<std::int64_t> cells(points.size());
  for (std::size_t k = 0; k < points.size(); ++k) cells[k] = serial.cell_of(points[k]);

  const BodyField threaded(body, 0.0042);
  std::vector<std::int64_t> cells_threaded(points.size());
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t)
    threads.emplace_back([&, t] {
      // Each thread walks the points from its own start, backwards on odd threads.
      for (std::size_t n = 0; n < points.size(); ++n) {
        const std::size_t k = (t % 2 ? points.size() - 1 - n : n + t * 750) % points.size();
        cells_threaded[k] = threaded.cell_of(points[k]);
      }
    });
  for (auto& th : threads) th.join();
  EXPECT_EQ(threaded.blocks_filled(), serial.blocks_filled());
  for (std::size_t k = 0; k < points.size(); ++k) {
    ASSERT_EQ(cells[k] < 0, cells_threaded[k] < 0) << "point " << k;
    if (cells[k] < 0) continue;
    EXPECT_EQ(serial.distance(cells[k]), threaded.distance(cells_threaded[k]));
    int n1 = 0, n2 = 0;
    const int* l1 = serial.triangles(cells[k], n1);
    const int* l2 = threaded.triangles(cells_threaded[k], n2);
    ASSERT_EQ(n1, n2);
    EXPECT_TRUE(std::equal(l1, l1 + n1, l2));
  }
}
