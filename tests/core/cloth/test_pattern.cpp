#include "kiji/pattern.h"
#include "kiji/error.h"
#include "kiji/topology.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace kiji;

namespace {
double total_rest_area(const Garment& g) {
  double a = 0;
  for (Face f : g.mesh().faces()) a += g.rest_area(f);
  return a;
}
std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}
}  // namespace

TEST(Rectangle, CountsAreaAndUv) {
  Garment g = make_rectangle(2.0, 1.0, 21, 11);
  EXPECT_EQ(g.mesh().number_of_vertices(), 21u * 11u);
  EXPECT_EQ(g.mesh().number_of_faces(), 2u * 20u * 10u);
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 1u);
  EXPECT_NEAR(total_rest_area(g), 2.0, 1e-9);
  EXPECT_DOUBLE_EQ(g.pattern_scale(), 2.0);
  // uv is the flat pattern in metres scaled by the larger side: x in [0,1], y in [0,0.5].
  for (Face f : g.mesh().faces())
    for (Halfedge h : CGAL::halfedges_around_face(g.mesh().halfedge(f), g.mesh())) {
      const Vec3 p = g.position(g.mesh().target(h));
      EXPECT_NEAR(g.uv(h).x(), p.x() / 2.0, 1e-12);
      EXPECT_NEAR(g.uv(h).y(), p.y() / 2.0, 1e-12);
    }
  // Faces wind counter-clockwise seen from +z.
  for (Face f : g.mesh().faces()) {
    Halfedge h = g.mesh().halfedge(f);
    Vec3 a = g.position(g.mesh().source(h)), b = g.position(g.mesh().target(h)),
         c = g.position(g.mesh().target(g.mesh().next(h)));
    EXPECT_GT((b - a).cross(c - a).z(), 0);
  }
  // One border loop of 2*(20+10) edges; total mass = area * density.
  auto loops = border_loops(g);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_EQ(loops[0].size(), 60u);
  double mass = 0;
  for (Vertex v : g.mesh().vertices()) mass += 1.0 / g.inverse_mass(v);
  EXPECT_NEAR(mass, 2.0 * g.material().density, 1e-9);
}

TEST(Rectangle, SpacedMatchesTheSpacing) {
  Garment g = make_rectangle_spaced(1.0, 0.5, 0.01);
  EXPECT_EQ(g.mesh().number_of_vertices(), 101u * 51u);
  for (Edge e : g.mesh().edges()) EXPECT_LE(g.rest_length(e), 0.01 * std::sqrt(2.0) + 1e-12);
}

TEST(Rectangle, BadSizesAreRefusedWithAReason) {
  EXPECT_NE(message_of([] { make_rectangle(0.0, 1.0, 3, 3); }).find("width"), std::string::npos);
  EXPECT_NE(message_of([] { make_rectangle(1.0, -1.0, 3, 3); }).find("height"), std::string::npos);
  EXPECT_NE(message_of([] { make_rectangle(1.0, 1.0, 1, 3); }).find("2 x 2"), std::string::npos);
  EXPECT_NE(message_of([] { make_rectangle(NAN, 1.0, 3, 3); }).find("width"), std::string::npos);
}

TEST(RectSpec, ParsesAndRejects) {
  RectSpec s = RectSpec::parse("rect:1.2,0.8,0.02");
  EXPECT_DOUBLE_EQ(s.width, 1.2);
  EXPECT_DOUBLE_EQ(s.height, 0.8);
  EXPECT_DOUBLE_EQ(s.spacing, 0.02);
  EXPECT_NE(message_of([] { RectSpec::parse("circle:1"); }).find("rect:WIDTH,HEIGHT,SPACING"), std::string::npos);
  EXPECT_NE(message_of([] { RectSpec::parse("rect:1,1"); }).find("2 numbers"), std::string::npos);
  EXPECT_NE(message_of([] { RectSpec::parse("rect:1,x,0.1"); }).find("'x' is not a number"), std::string::npos);
  EXPECT_NE(message_of([] { RectSpec::parse("rect:0,1,0.1"); }).find("width"), std::string::npos);
  EXPECT_NE(message_of([] { RectSpec::parse("rect:1,1,-0.1"); }).find("spacing"), std::string::npos);
  EXPECT_NE(message_of([] { RectSpec::parse("rect:1,0.5,0.7"); }).find("larger than the garment"), std::string::npos);
}

TEST(Panel, TriangulatesAnOutlineAtTheTargetLength) {
  // A T-shirt-like front panel: concave, 10 corners.
  std::vector<Vec2> outline = {{0.0, 0.0},  {0.5, 0.0},  {0.5, 0.45}, {0.68, 0.38}, {0.75, 0.52},
                               {0.45, 0.7}, {0.05, 0.7}, {-0.25, 0.52}, {-0.18, 0.38}, {0.0, 0.45}};
  const double h = 0.02;
  Garment g = make_panel(outline, h, Material::silk(), 3);
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 1u);
  EXPECT_EQ(g.material().name, "silk");
  double polygon_area = 0;
  for (std::size_t i = 0; i < outline.size(); ++i) {
    const Vec2& a = outline[i];
    const Vec2& b = outline[(i + 1) % outline.size()];
    polygon_area += 0.5 * (a.x() * b.y() - b.x() * a.y());
  }
  EXPECT_NEAR(total_rest_area(g), std::abs(polygon_area), 1e-9);
  double longest = 0, sum = 0;
  for (Edge e : g.mesh().edges()) {
    longest = std::max(longest, g.rest_length(e));
    sum += g.rest_length(e);
  }
  EXPECT_LE(longest, h * 1.01);
  EXPECT_GT(sum / g.mesh().number_of_edges(), 0.4 * h);  // not needlessly fine
  for (Face f : g.mesh().faces()) EXPECT_EQ(g.panel(f), 3);
  EXPECT_EQ(border_loops(g).size(), 1u);
  // uv = pattern coordinates scaled to [0,1] over the larger side (1.0 m wide).
  EXPECT_NEAR(g.pattern_scale(), 1.0, 1e-12);
  for (Face f : g.mesh().faces())
    for (Halfedge hh : CGAL::halfedges_around_face(g.mesh().halfedge(f), g.mesh())) {
      const Vec3 p = g.position(g.mesh().target(hh));
      EXPECT_NEAR(g.uv(hh).x(), p.x() + 0.25, 1e-9);
      EXPECT_NEAR(g.uv(hh).y(), p.y(), 1e-9);
    }
}

TEST(Panel, RefusesBadOutlines) {
  EXPECT_NE(message_of([] { make_panel({{0, 0}, {1, 0}}, 0.1); }).find("at least 3"), std::string::npos);
  EXPECT_NE(message_of([] { make_panel({{0, 0}, {1, 1}, {1, 0}, {0, 1}}, 0.1); }).find("crosses itself"),
            std::string::npos);
  EXPECT_NE(message_of([] { make_panel({{0, 0}, {1, 0}, {0, NAN}}, 0.1); }).find("finite"), std::string::npos);
  EXPECT_NE(message_of([] { make_panel({{0, 0}, {1, 0}, {0, 1}}, 0.0); }).find("edge length"), std::string::npos);
}
