// A garment of over 10,000 vertices draped on the default body, checked as a user would look at it:
// it has come to rest, it lies on the body, nothing is inside the body, the cloth is not torn apart.
#include "kiji/drape.h"
#include "kiji/pattern.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace kiji;

TEST(Drape, SettlesOnTheDefaultBody) {
  const Body body = Body::load(Body::default_path());
  Garment g = make_rectangle(1.0, 1.0, 101, 101);
  ASSERT_GE(g.mesh().number_of_vertices(), 10000u);
  place_over_body(g, body);
  const double start_y = g.bounds().min().y();
  EXPECT_GT(start_y, body.bounds().max().y()) << "the cloth starts above the body";
  double mass = 0, height_before = 0;
  for (Vertex v : g.mesh().vertices()) {
    mass += g.mass(v);
    height_before += g.mass(v) * g.position(v).y();
  }

  DrapeOptions options;
  options.seconds = 3.0;
  const DrapeResult r = drape(g, body, options);
  const ClothMeasures& m = r.measures;
  const double thickness = g.material().thickness;
  double height_after = 0;
  for (Vertex v : g.mesh().vertices()) height_after += g.mass(v) * g.position(v).y();
  const double released = 9.81 * (height_before - height_after);

  EXPECT_TRUE(g.is_valid());
  // At rest: what kinetic energy is left is under 0.1 % of the energy the fall released.
  EXPECT_GT(released, 0.1);
  EXPECT_LT(m.kinetic_energy, 1e-3 * released) << "kinetic energy " << m.kinetic_energy << " J";
  EXPECT_LE(m.max_penetration, thickness) << "a vertex is inside the body";
  // The cloth keeps its size: on average edges are within 1 % of their rest length, and no edge is
  // stretched or compressed by 10 % or more, not over the crown of the head where the cloth hangs,
  // not in the folds.
  EXPECT_LT(m.mean_strain, 0.01);
  EXPECT_LT(m.max_strain, 0.10);
  // Resting on the body, not fallen through or past it: many vertices touch it, and the cloth
  // hangs from the head and shoulders, its lowest point below where it started but above the hips.
  EXPECT_GT(m.contacts, g.mesh().number_of_vertices() / 20) << "contacts " << m.contacts;
  EXPECT_GT(g.bounds().min().y(), 0.5 * body.height());
  EXPECT_LT(g.bounds().min().y(), start_y - 0.2);
}
