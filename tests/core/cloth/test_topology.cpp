#include "kiji/topology.h"
#include "kiji/error.h"
#include "kiji/pattern.h"

#include <gtest/gtest.h>

#include <map>

using namespace kiji;

namespace {

// The vertex of a rectangle nearest a pattern point.
Vertex at(const Garment& g, double x, double y) {
  Vertex best;
  double d = 1e300;
  for (Vertex v : g.mesh().vertices()) {
    const double e = (g.position(v) - Vec3(x, y, 0)).squaredNorm();
    if (e < d) {
      d = e;
      best = v;
    }
  }
  return best;
}

// Each face's corner uvs, keyed by its centroid, to check uv survives edits.
std::map<std::array<long, 3>, std::vector<std::pair<std::array<long, 3>, Vec2>>> corner_uvs(const Garment& g) {
  auto key = [](const Vec3& p) {
    return std::array<long, 3>{std::lround(p.x() * 1e6), std::lround(p.y() * 1e6), std::lround(p.z() * 1e6)};
  };
  std::map<std::array<long, 3>, std::vector<std::pair<std::array<long, 3>, Vec2>>> out;
  for (Face f : g.mesh().faces()) {
    Vec3 c = Vec3::Zero();
    std::vector<std::pair<std::array<long, 3>, Vec2>> corners;
    for (Halfedge h : CGAL::halfedges_around_face(g.mesh().halfedge(f), g.mesh())) {
      c += g.position(g.mesh().target(h)) / 3.0;
      corners.emplace_back(key(g.position(g.mesh().target(h))), g.uv(h));
    }
    std::sort(corners.begin(), corners.end(), [](auto& a, auto& b) { return a.first < b.first; });
    out[key(c)] = corners;
  }
  return out;
}

void expect_same_uvs(const Garment& before, const Garment& after) {
  auto a = corner_uvs(before), b = corner_uvs(after);
  for (const auto& [centroid, corners] : b) {
    auto it = a.find(centroid);
    ASSERT_NE(it, a.end()) << "a face appeared that was not there before";
    for (std::size_t k = 0; k < 3; ++k) EXPECT_TRUE(corners[k].second.isApprox(it->second[k].second, 1e-12));
  }
}

std::size_t count_border_vertices(const Garment& g) {
  std::size_t n = 0;
  for (Vertex v : g.mesh().vertices()) n += g.mesh().is_border(v) ? 1 : 0;
  return n;
}

}  // namespace

TEST(SplitVertex, InteriorVertexOpensASlitAndKeepsEveryFace) {
  Garment g = make_rectangle(1.0, 1.0, 5, 5);
  const Garment before = g;
  const auto version = g.topology_version();
  const Vertex v = at(g, 0.5, 0.5), a = at(g, 0.25, 0.5), b = at(g, 0.75, 0.5);
  const Vertex nv = split_vertex_between(g, v, a, b);
  EXPECT_TRUE(g.is_valid());
  EXPECT_GT(g.topology_version(), version);
  EXPECT_EQ(g.mesh().number_of_vertices(), 26u);
  EXPECT_EQ(g.mesh().number_of_faces(), 32u);
  EXPECT_EQ(g.position(nv), g.position(v));
  // A slit a - v - b: a second border loop of four edges (a, v, b, v').
  auto loops = border_loops(g);
  ASSERT_EQ(loops.size(), 2u);
  EXPECT_EQ(std::min(loops[0].size(), loops[1].size()), 4u);
  EXPECT_EQ(g.count_pieces(), 1u);
  expect_same_uvs(before, g);
  // Masses still add up to the cloth's mass.
  double mass = 0;
  for (Vertex u : g.mesh().vertices()) mass += 1.0 / g.inverse_mass(u);
  EXPECT_NEAR(mass, g.material().density, 1e-12);
}

TEST(SplitVertex, BorderVertexCutFromTheBorder) {
  Garment g = make_rectangle(1.0, 1.0, 5, 5);
  const Vertex v = at(g, 0.5, 0.0), a = at(g, 0.5, 0.25);
  const Vertex nv = split_vertex_between(g, v, a, a);
  EXPECT_TRUE(g.is_valid());
  EXPECT_NE(nv, v);
  EXPECT_EQ(g.mesh().number_of_vertices(), 26u);
  EXPECT_EQ(g.mesh().number_of_faces(), 32u);
  auto loops = border_loops(g);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_EQ(loops[0].size(), 16u + 2u);  // the border now runs into the slit and back
}

TEST(SplitVertex, RefusesFacesNotAroundTheVertex) {
  Garment g = make_rectangle(1.0, 1.0, 4, 4);
  const Vertex v = at(g, 0.0, 0.0);
  Face far;
  for (Face f : g.mesh().faces()) far = f;  // the last face is at the far corner
  EXPECT_THROW(split_vertex(g, v, {far}), InputError);
  std::vector<Face> all;
  for (Face f : CGAL::faces_around_target(g.mesh().halfedge(v), g.mesh()))
    if (f != Mesh::null_face()) all.push_back(f);
  EXPECT_THROW(split_vertex(g, v, all), InputError);
  EXPECT_EQ(g.mesh().number_of_vertices(), 16u);
}

TEST(RemoveEdge, RemovesTheEdgeAndItsTwoFaces) {
  Garment g = make_rectangle(1.0, 1.0, 5, 5);
  auto [h, found] = CGAL::halfedge(at(g, 0.5, 0.5), at(g, 0.75, 0.5), g.mesh());
  ASSERT_TRUE(found);
  remove_edge(g, g.mesh().edge(h));
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.mesh().number_of_faces(), 30u);
  EXPECT_EQ(g.mesh().number_of_vertices(), 25u);
  EXPECT_EQ(border_loops(g).size(), 2u);  // a hole
}

TEST(RemoveEdge, SplitsAVertexLeftWithTwoWedges) {
  // Tearing the only bridge at a border vertex: after the edge's faces go, the border vertex at
  // (0.5, 0) would hold two separate wedges; it becomes two vertices.
  Garment g = make_rectangle(1.0, 0.5, 5, 3);
  const Vertex v = at(g, 0.5, 0.0);
  std::vector<Edge> edges;
  for (Halfedge h : CGAL::halfedges_around_target(g.mesh().halfedge(v), g.mesh()))
    if (!g.mesh().is_border(g.mesh().edge(h))) edges.push_back(g.mesh().edge(h));
  ASSERT_GE(edges.size(), 1u);
  // Remove the interior edge pointing straight up from v.
  Edge up;
  for (Edge e : edges) {
    const Halfedge h = g.mesh().halfedge(e);
    const Vertex o = g.mesh().source(h) == v ? g.mesh().target(h) : g.mesh().source(h);
    if (std::abs(g.position(o).x() - 0.5) < 1e-9) up = e;
  }
  const auto faces_before = g.mesh().number_of_faces();
  remove_edge(g, up);
  EXPECT_TRUE(g.is_valid()) << "no non-manifold vertex may be left";
  EXPECT_EQ(g.mesh().number_of_faces(), faces_before - 2);
}

TEST(RemoveEdge, TearingAcrossMakesTwoPieces) {
  Garment g = make_rectangle(1.0, 1.0, 6, 6);
  // Every edge crossing the line x = 0.5 goes.
  std::vector<Edge> cut;
  for (Edge e : g.mesh().edges()) {
    const Halfedge h = g.mesh().halfedge(e);
    const double x0 = g.position(g.mesh().source(h)).x(), x1 = g.position(g.mesh().target(h)).x();
    if ((x0 - 0.5) * (x1 - 0.5) < 0) cut.push_back(e);
  }
  remove_edges(g, cut);
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 2u);
}

TEST(MergeVertices, UndoesACutAndJoinsTheEdgesThatCoincide) {
  // The paper's sew: a vertex split from the border is merged back; the two edges to the shared
  // neighbour become one, and the cloth is whole again.
  Garment g = make_rectangle(1.0, 1.0, 5, 5);
  const auto edges_before = g.mesh().number_of_edges();
  const Vertex v = at(g, 0.5, 0.0), a = at(g, 0.5, 0.25);
  const Vertex nv = split_vertex_between(g, v, a, a);
  EXPECT_EQ(g.mesh().number_of_edges(), edges_before + 1);
  ASSERT_EQ(border_loops(g)[0].size(), 18u);
  g.set_position(nv, g.position(nv) + Vec3(0.01, 0, 0));
  merge_vertices(g, v, nv);
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.mesh().number_of_vertices(), 25u);
  EXPECT_EQ(g.mesh().number_of_faces(), 32u);
  EXPECT_EQ(g.mesh().number_of_edges(), edges_before);
  auto loops = border_loops(g);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_EQ(loops[0].size(), 16u);
  EXPECT_TRUE(g.position(v).isApprox(Vec3(0.505, 0, 0), 1e-12)) << "merged vertex sits at the midpoint";
}

TEST(MergeVertices, RefusesANonManifoldResultAndChangesNothing) {
  Garment g = make_rectangle(1.0, 1.0, 5, 5);
  const Garment before = g;
  const auto version = g.topology_version();
  // Two interior vertices.
  EXPECT_THROW(merge_vertices(g, at(g, 0.25, 0.25), at(g, 0.75, 0.75)), TopologyError);
  // Two border vertices with no common neighbour: they would pinch the cloth at one point.
  EXPECT_THROW(merge_vertices(g, at(g, 0.0, 0.0), at(g, 1.0, 1.0)), TopologyError);
  EXPECT_EQ(g.topology_version(), version);
  EXPECT_EQ(g.mesh().number_of_vertices(), before.mesh().number_of_vertices());
  for (Vertex v : g.mesh().vertices()) EXPECT_EQ(g.position(v), before.position(v));
  EXPECT_THROW(merge_vertices(g, at(g, 0, 0), at(g, 0, 0)), InputError);
}

TEST(Stitch, RectangleSewnEdgeToEdgeBecomesATube) {
  Garment g = make_rectangle(1.0, 0.5, 11, 6);
  std::vector<Vertex> left, right;
  for (int j = 0; j < 6; ++j) {
    left.push_back(at(g, 0.0, 0.1 * j));
    right.push_back(at(g, 1.0, 0.1 * j));
  }
  stitch(g, left, right);
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 1u);
  EXPECT_EQ(g.mesh().number_of_vertices(), 66u - 6u);
  EXPECT_EQ(g.mesh().number_of_faces(), 100u);
  auto loops = border_loops(g);
  ASSERT_EQ(loops.size(), 2u) << "a tube has two border loops";
  EXPECT_EQ(loops[0].size(), 10u);
  EXPECT_EQ(loops[1].size(), 10u);
  for (Vertex v : left) EXPECT_FALSE(g.mesh().is_removed(v));
}

TEST(Stitch, TwoPanelsWithDifferentResolutionsJoinAlongTheSeam) {
  Garment g = make_rectangle(0.5, 1.0, 6, 11);   // seam side x = 0.5 has 11 vertices
  Garment b = make_rectangle(0.5, 1.0, 4, 7);    // its side x = 0 has 7 vertices
  b.transform(Eigen::Affine3d(Eigen::Translation3d(0.6, 0, 0)));
  const Vertex first_b = append_garment(g, b);
  // b's vertex i is now first_b + i, with its position.
  EXPECT_EQ(first_b.idx(), 6u * 11u);
  EXPECT_EQ(g.mesh().number_of_vertices(), 6u * 11u + 4u * 7u);
  for (Vertex v : b.mesh().vertices())
    EXPECT_EQ(g.position(Vertex(first_b.idx() + v.idx())), b.position(v)) << "vertex " << v.idx() << " of b";
  EXPECT_EQ(g.count_pieces(), 2u);
  const Garment before = g;
  std::vector<Vertex> a_side, b_side;
  for (int j = 0; j < 11; ++j) a_side.push_back(at(g, 0.5, 0.1 * j));
  for (int j = 0; j < 7; ++j) b_side.push_back(at(g, 0.6, j / 6.0));
  stitch(g, a_side, b_side);
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 1u);
  auto loops = border_loops(g);
  ASSERT_EQ(loops.size(), 1u) << "no border left along the seam";
  // Every seam vertex except the two ends is now interior.
  for (int j = 1; j < 10; ++j) EXPECT_FALSE(g.mesh().is_border(a_side[j]));
  // Area is kept: the refinement only splits triangles.
  double area = 0, area_before = 0;
  for (Face f : g.mesh().faces()) area += g.rest_area(f);
  for (Face f : before.mesh().faces()) area_before += before.rest_area(f);
  EXPECT_NEAR(area, area_before, 1e-9);
}

TEST(Stitch, FlipsAPanelWithTheOppositeOrientation) {
  Garment g = make_rectangle(0.5, 0.5, 6, 6);
  Garment b = make_rectangle(0.5, 0.5, 6, 6);
  // Mirror b: its faces now wind the other way relative to the seam.
  Eigen::Affine3d mirror = Eigen::Affine3d::Identity();
  mirror.linear()(0, 0) = -1;
  b.transform(Eigen::Translation3d(1.1, 0, 0) * mirror);
  append_garment(g, b);
  std::vector<Vertex> a_side, b_side;
  for (int j = 0; j < 6; ++j) {
    a_side.push_back(at(g, 0.5, 0.1 * j));
    b_side.push_back(at(g, 0.6, 0.1 * j));
  }
  stitch(g, a_side, b_side);
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 1u);
  EXPECT_EQ(border_loops(g).size(), 1u);
  EXPECT_EQ(count_border_vertices(g), 4u * 5u + 4u * 5u - 2u * 5u);
}

// A seam sewn as it closes: tack_seam pairs the sides as stitch would (refining the coarser side)
// and changes no face; close_tacks sews the pairs that have met, from the end where they met along
// the seam, and leaves the rest tacked; at the end the seam is the one stitch makes at once.
TEST(Stitch, ATackedSeamIsSewnRunByRunAsItsPairsMeet) {
  Garment g = make_rectangle(0.5, 1.0, 6, 11);  // seam side x = 0.5 has 11 vertices
  Garment b = make_rectangle(0.5, 1.0, 4, 7);   // its side x = 0 has 7
  b.transform(Eigen::Affine3d(Eigen::Translation3d(0.8, 0, 0)));
  append_garment(g, b);
  std::vector<Vertex> a_side, b_side;
  for (int j = 0; j < 11; ++j) a_side.push_back(at(g, 0.5, 0.1 * j));
  for (int j = 0; j < 7; ++j) b_side.push_back(at(g, 0.8, j / 6.0));
  Garment at_once = g;
  stitch(at_once, a_side, b_side);

  const std::size_t faces = g.mesh().number_of_faces();
  const auto pairs = tack_seam(g, a_side, b_side);
  ASSERT_EQ(pairs.size(), 15u);  // 11 and 7 refined to the union of their shares along the side: 15
  EXPECT_EQ(g.tacks.size(), 15u);
  EXPECT_EQ(g.count_pieces(), 2u);
  EXPECT_EQ(g.mesh().number_of_faces(), faces + 4 + 8);  // refined, not joined
  EXPECT_EQ(close_tacks(g, 0.01), 0u);                   // nothing has met: 30 cm apart

  // The pairs near y = 0 meet first (the solver draws each pair together): a run of them is sewn.
  auto meet = [&](double below) {
    for (const auto& [p, q] : g.tacks)
      if (g.position(p).y() < below) g.set_position(q, g.position(p));
  };
  meet(0.35);
  const std::size_t sewn = close_tacks(g, 0.01);
  EXPECT_GE(sewn, 4u);
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 1u);
  EXPECT_EQ(g.tacks.size(), 15u - sewn);
  // A single pair met alone, away from the seam sewn so far, waits: it would pinch the cloth.
  for (const auto& [p, q] : g.tacks)
    if (g.position(p).y() > 0.95) g.set_position(q, g.position(p));
  EXPECT_EQ(close_tacks(g, 0.01), 0u);
  // The rest meet: the seam closes to the end, as stitch() would have sewn it at once.
  meet(2.0);
  EXPECT_EQ(close_tacks(g, 0.01), 15u - sewn);
  EXPECT_TRUE(g.tacks.empty());
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 1u);
  EXPECT_EQ(border_loops(g).size(), 1u) << "no border left along the seam";
  EXPECT_EQ(g.mesh().number_of_vertices(), at_once.mesh().number_of_vertices());
  EXPECT_EQ(g.mesh().number_of_faces(), at_once.mesh().number_of_faces());
}

TEST(Stitch, RefusesVerticesThatAreNotABorderPath) {
  Garment g = make_rectangle(1.0, 1.0, 5, 5);
  EXPECT_THROW(stitch(g, {at(g, 0.25, 0.25), at(g, 0.5, 0.25)}, {at(g, 0, 0), at(g, 0.25, 0)}), InputError);
  EXPECT_THROW(stitch(g, {at(g, 0, 0)}, {at(g, 1, 0)}), InputError);
  EXPECT_TRUE(g.is_valid());
}

TEST(BorderPath, WalksAlongTheBorder) {
  Garment g = make_rectangle(1.0, 1.0, 5, 5);
  auto path = border_path(g, at(g, 0, 0), at(g, 1, 0));
  ASSERT_EQ(path.size(), 5u);
  for (std::size_t i = 0; i < 5; ++i) EXPECT_LT((g.position(path[i]) - Vec3(0.25 * i, 0, 0)).norm(), 1e-12);
  EXPECT_EQ(border_path(g, at(g, 1, 0), at(g, 0, 0)).size(), 5u);
  EXPECT_THROW(border_path(g, at(g, 0.5, 0.5), at(g, 1, 0)), InputError);
}

TEST(CutAlong, BorderToBorderSeparatesThePiecesKeepingEveryFace) {
  Garment g = make_rectangle(1.0, 1.0, 11, 11);
  const auto faces = g.mesh().number_of_faces();
  const Garment before = g;
  const auto path = edge_path(g, at(g, 0.0, 0.5), at(g, 1.0, 0.5));
  ASSERT_EQ(path.size(), 11u);
  const auto created = cut_along(g, path);
  EXPECT_EQ(created.size(), 11u);
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 2u);
  EXPECT_EQ(g.mesh().number_of_faces(), faces);
  EXPECT_EQ(g.mesh().number_of_vertices(), 121u + 11u);
  expect_same_uvs(before, g);
  // Each piece is a rectangle: two border loops of 40 edges... 2*(10+5) = 30 each.
  auto loops = border_loops(g);
  ASSERT_EQ(loops.size(), 2u);
  EXPECT_EQ(loops[0].size(), 30u);
  EXPECT_EQ(loops[1].size(), 30u);
}

TEST(CutAlong, IntoTheClothEndsInASlit) {
  Garment g = make_rectangle(1.0, 1.0, 11, 11);
  cut_along(g, edge_path(g, at(g, 0.0, 0.5), at(g, 0.5, 0.5)));
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 1u);
  auto loops = border_loops(g);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_EQ(loops[0].size(), 40u + 2u * 5u);  // the border runs in along the slit and back
}

TEST(CutAlong, InsideTheClothOpensAHole) {
  Garment g = make_rectangle(1.0, 1.0, 11, 11);
  const auto created = cut_along(g, edge_path(g, at(g, 0.3, 0.5), at(g, 0.7, 0.5)));
  EXPECT_EQ(created.size(), 3u);  // the inner vertices; the ends stay whole
  EXPECT_TRUE(g.is_valid());
  EXPECT_EQ(g.count_pieces(), 1u);
  EXPECT_EQ(border_loops(g).size(), 2u);
}

TEST(CutAlong, RefusesAPathThatIsNotAlongEdges) {
  Garment g = make_rectangle(1.0, 1.0, 11, 11);
  EXPECT_THROW(cut_along(g, {at(g, 0, 0), at(g, 1, 1)}), InputError);
  EXPECT_THROW(cut_along(g, {at(g, 0, 0)}), InputError);
  EXPECT_EQ(g.count_pieces(), 1u);
}
