// The knife along a drawn line: the opening follows the line (within a quarter of the vertex
// spacing), the triangles stay well shaped, no cloth is lost, a closed line cuts out its inside,
// and a line drawn on cloth folded over itself stays on the layer it began on.
#include "kiji/error.h"
#include "kiji/pattern.h"
#include "kiji/topology.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace kiji;

namespace {

constexpr double kPi = 3.14159265358979323846;

// The face of the garment under a point of the plane z = `z` (the nearest centroid).
Face face_at(const Garment& g, const Vec3& p) {
  Face best;
  double d = 1e300;
  for (Face f : g.mesh().faces()) {
    Vec3 c = Vec3::Zero();
    for (Vertex v : CGAL::vertices_around_face(g.mesh().halfedge(f), g.mesh())) c += g.position(v) / 3;
    if ((c - p).squaredNorm() < d) d = (c - p).squaredNorm(), best = f;
  }
  return best;
}

double total_rest_area(const Garment& g) {
  double a = 0;
  for (Face f : g.mesh().faces()) a += g.rest_area(f);
  return a;
}

// The smallest angle of any face, in degrees, from its rest lengths.
double smallest_angle(const Garment& g) {
  const Mesh& m = g.mesh();
  double smallest = 180;
  for (Face f : m.faces()) {
    std::vector<double> l;
    for (Halfedge h : CGAL::halfedges_around_face(m.halfedge(f), m)) l.push_back(g.rest_length(m.edge(h)));
    for (int k = 0; k < 3; ++k) {
      const double a = l[k], b = l[(k + 1) % 3], c = l[(k + 2) % 3];  // the angle opposite c
      smallest = std::min(smallest, std::acos(std::clamp((a * a + b * b - c * c) / (2 * a * b), -1.0, 1.0)) * 180 / kPi);
    }
  }
  return smallest;
}

double distance_to_polyline(const Vec3& p, const std::vector<Vec3>& line) {
  double d = 1e300;
  for (std::size_t i = 0; i + 1 < line.size(); ++i) {
    const Vec3 a = line[i], ab = line[i + 1] - a;
    const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    d = std::min(d, (a + t * ab - p).norm());
  }
  return d;
}

// The border loops that the cut made: those with a vertex away from the rectangle's outline.
std::vector<std::vector<Vertex>> inner_loops(const Garment& g, double width, double height) {
  std::vector<std::vector<Vertex>> out;
  for (const auto& loop : border_loops(g)) {
    bool inner = true;
    for (Vertex v : loop) {
      const Vec3 p = g.position(v);
      if (p.x() < 1e-9 || p.y() < 1e-9 || p.x() > width - 1e-9 || p.y() > height - 1e-9) inner = false;
    }
    if (inner) out.push_back(loop);
  }
  return out;
}

std::vector<Vec3> circle(const Vec3& centre, double rx, double ry, int n, double z = 0) {
  std::vector<Vec3> out;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * kPi * i / n;
    out.emplace_back(centre.x() + rx * std::cos(a), centre.y() + ry * std::sin(a), z);
  }
  return out;
}

// A steep dome 15 cm high and 14 cm across in the middle of a 0.6 m square: its height at (x, y).
double dome_height(double x, double y) {
  const double r = std::hypot(x - 0.3, y - 0.3) / 0.07;
  return 0.15 * std::exp(-r * r * r * r);
}

// The square of cloth laid over that dome.
Garment cloth_over_dome(double spacing) {
  Garment g = make_rectangle_spaced(0.6, 0.6, spacing);
  for (Vertex v : g.mesh().vertices()) {
    const Vec3 p = g.position(v);
    g.set_position(v, Vec3(p.x(), p.y(), dome_height(p.x(), p.y())));
  }
  return g;
}

}  // namespace

TEST(CutLine, AClosedLoopCutsOutItsInsideAlongTheDrawnCurve) {
  const double spacing = 0.02;
  Garment g = make_rectangle_spaced(0.6, 0.6, spacing);
  const double area = total_rest_area(g);
  const Vec3 centre(0.3, 0.3, 0);
  KnifeLine line;
  line.points = circle(centre, 0.12, 0.09, 140);  // an ellipse, as a head opening is drawn
  line.start = face_at(g, line.points.front());
  line.closed = true;
  const KnifeCut cut = cut_line(g, line);
  EXPECT_TRUE(cut.closed);
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 2u);
  EXPECT_NEAR(total_rest_area(g), area, 1e-9 * area);  // no cloth lost
  // Both sides of the opening follow the drawn curve: within a quarter of the spacing.
  std::vector<Vec3> drawn = line.points;
  drawn.push_back(drawn.front());
  double worst = 0, sum = 0;
  std::size_t n = 0;
  for (const auto& loop : inner_loops(g, 0.6, 0.6))
    for (Vertex v : loop) {
      const double d = distance_to_polyline(g.position(v), drawn);
      worst = std::max(worst, d);
      sum += d;
      ++n;
    }
  ASSERT_GT(n, 60u);  // both sides of a 66 cm opening at 2 cm
  EXPECT_LT(worst, 0.25 * spacing);
  const double angle = smallest_angle(g);
  EXPECT_GT(angle, 15.0);
  std::printf("the opening's border from the drawn ellipse: %.3f spacing at most, %.3f on average; smallest angle %.1f degrees\n",
              worst / spacing, sum / n / spacing, angle);
}

TEST(CutLine, AStrokeFromBorderToBorderSeparatesThePiecesAlongTheLine) {
  const double spacing = 0.05;
  Garment g = make_rectangle_spaced(1.0, 1.0, spacing);
  const double area = total_rest_area(g);
  KnifeLine line;
  // A slanted wavy line, drawn from off the cloth on the left to off the cloth on the right.
  for (int i = 0; i <= 60; ++i) {
    const double x = 0.02 + 0.96 * i / 60;
    line.points.emplace_back(x, 0.37 + 0.2 * x + 0.04 * std::sin(9 * x), 0);
  }
  line.start = face_at(g, line.points.front());
  line.from = Vec3(-0.1, 0.37 - 0.02, 0);
  line.to = Vec3(1.1, 0.57 + 0.04 * std::sin(9.0) + 0.02, 0);
  cut_line(g, line);
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 2u);
  EXPECT_NEAR(total_rest_area(g), area, 1e-9 * area);
  std::vector<Vec3> drawn{*line.from};
  drawn.insert(drawn.end(), line.points.begin(), line.points.end());
  drawn.push_back(*line.to);
  double worst = 0;
  for (const auto& loop : border_loops(g))
    for (Vertex v : loop) {
      const Vec3 p = g.position(v);
      if (p.x() > 1e-9 && p.x() < 1 - 1e-9 && p.y() > 1e-9 && p.y() < 1 - 1e-9)
        worst = std::max(worst, distance_to_polyline(p, drawn));
    }
  EXPECT_LT(worst, 0.25 * spacing);
  EXPECT_GT(smallest_angle(g), 15.0);
}

TEST(CutLine, AStrokeLeavingClothDrapedOverAnArchCutsOnDownToTheBorder) {
  // Cloth lying over an arch (half a cylinder), the stroke drawn across its top and off to each side
  // at the top's height, as a user draws across draped cloth: the slopes turn away from the pointer,
  // and the line goes on down them, straight, to the border on both sides.
  Garment g = make_rectangle_spaced(0.6, 0.6, 0.02);
  const double r = 0.6 / kPi;
  for (Vertex v : g.mesh().vertices()) {
    const Vec3 p = g.position(v);
    const double a = p.x() / r - kPi / 2;  // -90 to 90 degrees from the top
    g.set_position(v, Vec3(r * std::sin(a), p.y(), r * std::cos(a)));
  }
  KnifeLine line;
  line.points = {Vec3(-0.03, 0.31, r), Vec3(0.0, 0.3, r), Vec3(0.03, 0.29, r)};
  line.start = face_at(g, line.points.front());
  line.from = Vec3(-0.5, 0.33, r);
  line.to = Vec3(0.5, 0.27, r);
  cut_line(g, line);
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 2u) << "the line stopped on a slope";
}

TEST(CutLine, ALineThatRunsIntoTheClothEndsInASlit) {
  Garment g = make_rectangle_spaced(1.0, 1.0, 0.05);
  KnifeLine line;
  line.points = {Vec3(0.03, 0.52, 0), Vec3(0.25, 0.53, 0), Vec3(0.5, 0.52, 0)};
  line.start = face_at(g, line.points.front());
  line.from = Vec3(-0.1, 0.52, 0);
  const KnifeCut cut = cut_line(g, line);
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 1u);
  const auto loops = border_loops(g);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_GE(cut.opening.size(), 10u);
  // The slit reaches from the border to about where the line ends.
  double deepest = 0;
  for (Vertex v : loops[0]) {
    const Vec3 p = g.position(v);
    if (p.x() < 1 - 1e-9 && p.y() > 1e-9 && p.y() < 1 - 1e-9) deepest = std::max(deepest, p.x());
  }
  EXPECT_NEAR(deepest, 0.5, 0.05);
}

TEST(CutLine, ALineOnClothFoldedOverItselfStaysOnItsLayer) {
  // A rectangle folded in two at y = 0.5: the upper half lies back over the lower, 4 mm above it.
  Garment g = make_rectangle_spaced(1.0, 1.0, 0.05);
  for (Vertex v : g.mesh().vertices()) {
    const Vec3 p = g.position(v);
    if (p.y() > 0.5) g.set_position(v, Vec3(p.x(), 1.0 - p.y(), 0.004 * (p.y() - 0.5) / 0.5 + 0.004));
    else if (p.y() == 0.5) g.set_position(v, Vec3(p.x(), 0.5, 0.002));
  }
  const Garment before = g;
  // Drawn from above (+z) on the top layer; the points a pick found alternate between the layers,
  // as a ray does where the two lie close.
  KnifeLine line;
  for (int i = 0; i <= 40; ++i) {
    const double x = 0.03 + 0.94 * i / 40;
    line.points.emplace_back(x, 0.27, (i % 3 == 1) ? 0.0 : 0.006);
  }
  line.start = face_at(g, Vec3(0.03, 0.27, 0.006));
  line.from = Vec3(-0.1, 0.27, 0.006);
  line.to = Vec3(1.1, 0.27, 0.006);
  const KnifeCut cut = cut_line(g, line);
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 2u);  // the top layer cut off across; the bottom layer whole
  for (const Vec3& p : cut.line) EXPECT_GT(p.z(), 0.004) << "the line went onto the lower layer";
  // The lower layer's faces are as they were.
  std::size_t lower_before = 0, lower_after = 0;
  for (Vertex v : before.mesh().vertices()) lower_before += before.position(v).z() == 0.0;
  for (Vertex v : g.mesh().vertices()) lower_after += g.position(v).z() == 0.0;
  EXPECT_EQ(lower_after, lower_before);
}

TEST(CutLine, TraceFollowsTheLineWithoutCutting) {
  Garment g = make_rectangle_spaced(0.5, 0.5, 0.05);
  const auto version = g.topology_version();
  KnifeLine line;
  line.points = {Vec3(0.1, 0.12, 0), Vec3(0.4, 0.31, 0)};
  line.start = face_at(g, line.points.front());
  const auto traced = trace_line(g, line);
  EXPECT_GE(traced.size(), 8u);
  EXPECT_EQ(g.topology_version(), version);
  for (const Vec3& p : traced) EXPECT_LT(distance_to_polyline(p, line.points), 1e-9);
}

TEST(CutLine, RefusesBadInputAndChangesNothing) {
  Garment g = make_rectangle_spaced(0.5, 0.5, 0.05);
  const auto version = g.topology_version();
  KnifeLine line;
  line.points = {Vec3(0.1, 0.1, 0), Vec3(std::nan(""), 0.3, 0)};
  line.start = face_at(g, line.points.front());
  EXPECT_THROW(cut_line(g, line), InputError);
  line.points = {};
  EXPECT_THROW(cut_line(g, line), InputError);
  line.points = {Vec3(0.1, 0.1, 0), Vec3(0.3, 0.3, 0)};
  line.start = Face(99999);
  EXPECT_THROW(cut_line(g, line), InputError);
  EXPECT_EQ(g.topology_version(), version);
}

// Cloth over a steep dome, a loop drawn on its slopes from straight above (the mouse's view rays
// given): the loop's inside is cut out along the drawn loop.
TEST(CutLine, ALoopDrawnFromAboveOnASteepDomeCutsOutItsInside) {
  const double spacing = 0.02;
  Garment g = cloth_over_dome(spacing);
  KnifeLine line;
  for (const Vec3& p : circle(Vec3(0.3, 0.3, 0), 0.075, 0.06, 120)) {
    line.points.emplace_back(p.x(), p.y(), dome_height(p.x(), p.y()));
    line.sweeps.emplace_back(0, 0, -1);
  }
  line.start = face_at(g, line.points.front());
  line.closed = true;
  const KnifeCut cut = cut_line(g, line);
  EXPECT_TRUE(cut.closed);
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 2u);
  std::vector<Vec3> drawn = line.points;
  drawn.push_back(drawn.front());
  double worst = 0;
  for (const auto& loop : inner_loops(g, 0.6, 0.6))
    for (Vertex v : loop) worst = std::max(worst, distance_to_polyline(g.position(v), drawn));
  EXPECT_LT(worst, 0.25 * spacing);
}

// The same dome, a stroke drawn straight across it from above, border to border: the line goes up
// one steep side and down the other under the stroke and parts the cloth in two (no closed-line
// fallback applies to an open line: this is the sheet alone).
TEST(CutLine, AStrokeDrawnFromAboveAcrossASteepDomePartsTheCloth) {
  for (const double spacing : {0.01, 0.015, 0.02}) {
    Garment g = cloth_over_dome(spacing);
    KnifeLine line;
    for (int i = 0; i <= 100; ++i) {
      const double x = 0.05 + 0.5 * i / 100.0, y = 0.3 + 0.037 * spacing + 0.02 * (x - 0.3);
      line.points.emplace_back(x, y, dome_height(x, y));
      line.sweeps.emplace_back(0, 0, -1);
    }
    line.from = Vec3(-0.1, line.points.front().y(), 0);
    line.to = Vec3(0.7, line.points.back().y(), 0);
    line.start = face_at(g, line.points.front());
    cut_line(g, line);
    EXPECT_TRUE(g.is_valid()) << spacing;
    EXPECT_EQ(g.count_pieces(), 2u) << "at a spacing of " << spacing << " m";
  }
}

namespace {
// Where a pattern point (metres, in the flat rectangle) lies on the cloth: its face and weights.
std::pair<Face, Vec3> at_pattern(const Garment& g, const Vec2& q) {
  const Mesh& m = g.mesh();
  for (Face f : m.faces()) {
    Vec2 uv[3];
    int k = 0;
    for (Halfedge h : CGAL::halfedges_around_face(m.halfedge(f), m)) uv[k++] = g.uv(h) * g.pattern_scale();
    const Vec2 e0 = uv[1] - uv[0], e1 = uv[2] - uv[0], d = q - uv[0];
    const double den = e0.x() * e1.y() - e0.y() * e1.x();
    const double w1 = (d.x() * e1.y() - d.y() * e1.x()) / den, w2 = (e0.x() * d.y() - e0.y() * d.x()) / den;
    if (w1 >= -1e-12 && w2 >= -1e-12 && w1 + w2 <= 1 + 1e-12) return {f, Vec3(1 - w1 - w2, w1, w2)};
  }
  return {Mesh::null_face(), Vec3::Zero()};
}

// Adds a pattern point to a line along the pattern: its face, weights and place on the cloth.
// Returns false, adding nothing, where the point is off the cloth.
bool add_at_pattern(const Garment& g, KnifeLine& line, const Vec2& q) {
  const auto [face, w] = at_pattern(g, q);
  if (face == Mesh::null_face()) return false;
  Vec3 p = Vec3::Zero();
  int k = 0;
  for (Vertex v : CGAL::vertices_around_face(g.mesh().halfedge(face), g.mesh())) p += w[k++] * g.position(v);
  line.faces.push_back(face);
  line.weights.push_back(w);
  line.points.push_back(p);
  return true;
}

// A 0.5 x 0.4 m cloth pleated: it runs on to x = 0.2 m, back under itself to 0.15 and on again,
// three layers 4 mm apart.
Garment pleated(double spacing) {
  Garment g = make_rectangle_spaced(0.5, 0.4, spacing);
  for (Vertex v : g.mesh().vertices()) {
    const double x = g.position(v).x(), y = g.position(v).y();
    g.set_position(v, x < 0.2 ? Vec3(x, 0, y) : x < 0.25 ? Vec3(0.4 - x, 0.004, y) : Vec3(x - 0.1, 0.008, y));
  }
  return g;
}

// How far the border cut inside the cloth lies from the ellipse of the pattern x^2 / 0.14^2 +
// y^2 / 0.1^2 = 1 about (0.22, 0.2), at most (radially, in metres of pattern); and its vertices.
std::pair<double, std::size_t> off_the_ellipse(const Garment& g) {
  const Mesh& m = g.mesh();
  double worst = 0;
  std::size_t on = 0;
  for (Halfedge h : m.halfedges()) {
    if (!m.is_border(h)) continue;
    const Vec2 q = g.uv(m.opposite(h)) * g.pattern_scale() - Vec2(0.22, 0.2);
    const double r = std::hypot(q.x() / 0.14, q.y() / 0.1);
    if (r > 1.5) continue;  // the rectangle's own border
    ++on;
    worst = std::max(worst, std::abs(r - 1) * 0.1);
  }
  return {worst, on};
}
}  // namespace

// A script cuts through points it chose on the cloth (an ellipse of the pattern, as the main job
// cuts the head opening) across a pleat (`pleated`). Walked over the surface, the line stops at the
// pleat's creases (as it should for a stroke drawn on one layer) and cuts no piece out; followed
// in the pattern, it cuts out the ellipse exactly, pleat and all.
TEST(CutLine, ALineThroughPointsOfThePatternCutsAcrossAPleat) {
  const double spacing = 0.01;
  const Garment cloth = pleated(spacing);
  KnifeLine line;
  const int n = 48;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    ASSERT_TRUE(add_at_pattern(cloth, line, Vec2(0.22 + 0.14 * std::cos(a), 0.2 + 0.1 * std::sin(a))));
  }
  line.start = line.faces.front();
  line.closed = true;

  Garment walked = cloth;
  KnifeLine over_surface = line;
  over_surface.faces.clear();
  over_surface.weights.clear();
  cut_line(walked, over_surface);
  EXPECT_GT(off_the_ellipse(walked).first, 0.01) << "walked over the surface, the line keeps to the bottom layer";

  Garment g = cloth;
  const double area = total_rest_area(g);
  const KnifeCut cut = cut_line(g, line);
  EXPECT_TRUE(cut.closed);
  EXPECT_TRUE(g.is_valid());
  ASSERT_EQ(g.count_pieces(), 2u);
  EXPECT_NEAR(total_rest_area(g), area, 1e-9 * area);
  // The piece cut out is the ellipse of the pattern: both sides of the opening on it, within a
  // quarter of the spacing.
  const auto [worst, on] = off_the_ellipse(g);
  EXPECT_GT(on, 2u * 60u) << "both sides of a 76 cm opening at 1 cm";
  EXPECT_LT(worst, 0.25 * spacing);
}

// A stroke drawn over a fold touches its layers in turn, so in the pattern its line loops across
// itself; followed there it would cut out the pieces between the loops. It is refused, with the
// reason, and the cloth is as it was: a figure eight in the pattern stands for such a line.
TEST(CutLine, ALineThatCrossesItselfInThePatternIsRefused) {
  Garment g = make_rectangle_spaced(0.5, 0.4, 0.01);
  const Garment before = g;
  KnifeLine line;
  const int n = 60;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    ASSERT_TRUE(add_at_pattern(g, line, Vec2(0.25 + 0.15 * std::sin(a), 0.2 + 0.1 * std::sin(2 * a))));
  }
  line.start = line.faces.front();
  line.closed = true;
  try {
    cut_line(g, line);
    FAIL() << "a line crossing itself in the pattern was cut";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("crosses itself in the pattern"), std::string::npos) << e.what();
  }
  EXPECT_EQ(g.mesh().number_of_faces(), before.mesh().number_of_faces());
  EXPECT_EQ(g.count_pieces(), 1u);
}

// A stroke that goes from one layer of a fold to another (a pen or mouse over a pleat: two points
// 4 mm apart on the cloth, 4 cm apart in the pattern) is refused when it follows the pattern, with
// the reason, and the cloth is as it was.
TEST(CutLine, ALineThatJumpsBetweenTheLayersOfAFoldIsRefusedAlongThePattern) {
  Garment g = pleated(0.01);
  const std::size_t faces = g.mesh().number_of_faces();
  KnifeLine line;
  for (const Vec2 q : {Vec2(0.10, 0.2), Vec2(0.18, 0.2), Vec2(0.22, 0.2), Vec2(0.22, 0.3)})
    ASSERT_TRUE(add_at_pattern(g, line, q));
  line.start = line.faces.front();
  try {
    cut_line(g, line);
    FAIL() << "a line jumping between layers was cut along the pattern";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("between points 1 and 2"), std::string::npos) << e.what();
  }
  EXPECT_EQ(g.mesh().number_of_faces(), faces);
}
