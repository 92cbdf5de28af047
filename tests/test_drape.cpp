// A garment of over 10,000 vertices draped on the default body, checked as a user would look at it:
// it has come to rest, it lies on the body, nothing is inside the body, the cloth is not stretched.
#include "kiji/drape.h"
#include "kiji/pattern.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace kiji;

TEST(Drape, SettlesOnTheDefaultBody) {
  const Body body = Body::load(Body::default_path());
  Garment g = make_rectangle(1.4, 1.0, 141, 101);
  ASSERT_GE(g.mesh().number_of_vertices(), 10000u);
  place_over_body(g, body);
  const double start_y = g.bounds().min().y();
  EXPECT_GT(start_y, body.bounds().max().y() - 0.3) << "the cloth starts above the shoulders";

  DrapeOptions options;
  options.seconds = 3.0;
  const DrapeResult r = drape(g, body, options);
  const ClothMeasures& m = r.measures;
  const double thickness = g.material().thickness;

  EXPECT_TRUE(g.is_valid());
  // At rest: the root-mean-square speed under 2 cm/s.
  double mass = 0;
  for (Vertex v : g.mesh().vertices()) mass += g.mass(v);
  EXPECT_LT(std::sqrt(2 * m.kinetic_energy / mass), 0.02) << "kinetic energy " << m.kinetic_energy;
  EXPECT_LE(m.max_penetration, thickness) << "a vertex is inside the body";
  EXPECT_LT(m.max_strain, 0.10);
  // Resting on the body, not fallen through or past it: many vertices touch it, and the cloth
  // hangs from the shoulders, its lowest point well below where it started.
  EXPECT_GT(m.contacts, g.mesh().number_of_vertices() / 20) << "contacts " << m.contacts;
  EXPECT_GT(g.bounds().min().y(), 0.5 * body.height());
  EXPECT_LT(g.bounds().min().y(), start_y - 0.2);
}
