// The paper's model (eqs. 1-3): unit masses, g_ij = k (1 - l_ij / l'_ij) d_ij, local region.
#include "kiji/error.h"
#include "kiji/pattern.h"
#include "kiji/solver.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

using namespace kiji;

namespace {
SolverParams paper(double k = 100.0) {
  SolverParams p;
  p.model = SolverModel::MassSpring;
  p.spring_k = k;
  p.body_collision = false;
  p.self_collision = false;
  return p;
}

// One triangle a=(0,0,0), b=(1,0,0), c=(0,1,0) with b moved to (lab, 0, 0); the other two edges
// get their current lengths as rest lengths, so only edge ab is stretched.
Garment stretched_pair(double lab) {
  Mesh m;
  const Vertex a = m.add_vertex(Point3(0, 0, 0)), b = m.add_vertex(Point3(1, 0, 0)),
               c = m.add_vertex(Point3(0, 1, 0));
  m.add_face(a, b, c);
  Garment g(std::move(m));
  g.set_position(b, Vec3(lab, 0, 0));
  for (Edge e : g.mesh().edges()) {
    const Halfedge h = g.mesh().halfedge(e);
    const bool ab = (g.mesh().source(h) == a && g.mesh().target(h) == b) ||
                    (g.mesh().source(h) == b && g.mesh().target(h) == a);
    if (!ab) g.set_rest_length(e, g.length(e));
  }
  return g;
}
}  // namespace

TEST(MassSpring, SpringForceOfEquation3OnAStretchedPair) {
  const double k = 100.0;
  Solver solver(paper(k));
  // Stretched to 1.5 x its rest length 1: g_ab = k (1 - 1/1.5) d_ab = k/3 towards b.
  Garment g = stretched_pair(1.5);
  std::vector<Vec3> f = solver.spring_forces(g);
  ASSERT_EQ(f.size(), 3u);
  EXPECT_NEAR((f[0] - Vec3(k / 3.0, 0, 0)).norm(), 0.0, 1e-12) << f[0].transpose();
  EXPECT_NEAR((f[1] - Vec3(-k / 3.0, 0, 0)).norm(), 0.0, 1e-12) << f[1].transpose();
  EXPECT_NEAR(f[2].norm(), 0.0, 1e-12) << "c's springs are at rest";
  // Compressed to half: g_ab = k (1 - 1/0.5) d_ab = -k d_ab, pushing the pair apart.
  g = stretched_pair(0.5);
  f = solver.spring_forces(g);
  EXPECT_NEAR((f[0] - Vec3(-k, 0, 0)).norm(), 0.0, 1e-12) << f[0].transpose();
  EXPECT_NEAR((f[1] - Vec3(k, 0, 0)).norm(), 0.0, 1e-12) << f[1].transpose();
  // At rest: no force at all.
  g = stretched_pair(1.0);
  for (const Vec3& v : solver.spring_forces(g)) EXPECT_NEAR(v.norm(), 0.0, 1e-12);
}

TEST(MassSpring, UnitMassesUnderGravityFollowSymplecticEuler) {
  // A cloth at rest length has no spring force: every vertex falls as a unit mass under gravity,
  // v = g dt and x = x0 + g h^2 S (S + 1) / 2 after one step of S substeps h = dt / S.
  SolverParams p = paper();
  p.substeps = 4;
  Solver solver(p);
  Garment g = make_rectangle(0.2, 0.2, 3, 3);
  const double dt = 0.01, h = dt / 4;
  const Garment before = g;
  solver.step(g, dt);
  for (Vertex v : g.mesh().vertices()) {
    const Vec3 expect = before.position(v) + p.gravity * h * h * (4 * 5 / 2.0);
    EXPECT_NEAR((g.position(v) - expect).norm(), 0.0, 1e-12);
    EXPECT_NEAR((g.velocity(v) - p.gravity * dt).norm(), 0.0, 1e-12);
  }
}

TEST(MassSpring, ExternalForceActsOnTheUnitMassForOneStep) {
  SolverParams p = paper();
  p.gravity = Vec3::Zero();
  p.substeps = 1;
  Solver solver(p);
  Garment g = make_rectangle(0.2, 0.2, 3, 3);
  const Vertex v(4);  // the centre
  solver.add_external_force(v, Vec3(0, 0, 2.0));
  solver.step(g, 0.01);
  EXPECT_NEAR(g.velocity(v).z(), 2.0 * 0.01, 1e-12) << "a = f / 1";
  const Vec3 after = g.velocity(v);
  solver.step(g, 0.01);  // the force was for one step only; springs now pull it back
  EXPECT_LT(g.velocity(v).z(), after.z());
}

TEST(MassSpring, ClothPinnedAlongItsTopEdgeFallsAndHangs) {
  // A 0.5 m square held horizontally by one edge: it swings down and hangs below the edge.
  SolverParams p = paper(4000.0);
  p.spring_damping = 2.0;
  p.substeps = 20;
  Solver solver(p);
  const int n = 11;
  Garment g = make_rectangle(0.5, 0.5, n, n);
  // Pattern y -> world -z: the cloth lies in the horizontal plane y = 1; pin the row y = 0.
  for (Vertex v : g.mesh().vertices()) {
    const Vec3 q = g.position(v);
    g.set_position(v, Vec3(q.x(), 1.0, -q.y()));
  }
  std::vector<Vertex> pinned;
  for (int i = 0; i < n; ++i) {
    pinned.push_back(Vertex(i));
    g.set_pinned(Vertex(i), true);
  }
  const Garment start = g;
  for (int s = 0; s < 180; ++s) solver.step(g, 1.0 / 60);
  for (Vertex v : pinned) {
    EXPECT_EQ(g.position(v), start.position(v)) << "pinned vertices do not move at all";
    EXPECT_EQ(g.velocity(v), Vec3::Zero());
  }
  for (Vertex v : g.mesh().vertices()) {
    if (g.pinned(v)) continue;
    EXPECT_LT(g.position(v).y(), 1.0) << "every free vertex is below the pinned edge";
  }
  // The free edge hangs: it is at least the cloth's length below the pins (springs stretch under
  // unit masses) and nearly under them.
  for (int i = 0; i < n; ++i) {
    const Vec3 q = g.position(Vertex((n - 1) * n + i));
    EXPECT_LT(q.y(), 1.0 - 0.5) << "free edge vertex " << i;
    EXPECT_GT(q.z(), -0.15) << "hanging, not sticking out";
  }
}

TEST(MassSpring, LocalRegionHoldsEverythingOutsideStillWhereItWas) {
  SolverParams p = paper(2000.0);
  const int n = 21;
  Garment g = make_rectangle(1.0, 1.0, n, n);
  for (int i = 0; i < n; ++i) g.set_pinned(Vertex((n - 1) * n + i), true);  // top row
  Solver warmup(p);
  for (int s = 0; s < 5; ++s) warmup.step(g, 1.0 / 60);  // everything is moving now

  p.local_center = g.position(Vertex(10 * n + 10));  // the centre vertex
  p.local_radius = 0.2;
  Solver solver(p);
  solver.add_external_force(Vertex(10 * n + 10), Vec3(0, 0, 5.0));
  const Garment before = g;
  solver.step(g, 1.0 / 60);
  int inside = 0, outside = 0;
  for (Vertex v : g.mesh().vertices()) {
    const bool in = (before.position(v) - p.local_center).norm() <= p.local_radius;
    if (in && !g.pinned(v)) {
      ++inside;
      EXPECT_NE(g.position(v), before.position(v)) << "vertex " << v.idx() << " is inside and moves";
    } else if (!in) {
      ++outside;
      // Bit-for-bit where it was (compare the raw doubles), and still: no velocity to resume with.
      for (int k = 0; k < 3; ++k)
        EXPECT_EQ(std::memcmp(&g.position(v)[k], &before.position(v)[k], sizeof(double)), 0);
      EXPECT_EQ(g.velocity(v), Vec3::Zero()) << "vertex " << v.idx() << " is held still";
    }
  }
  EXPECT_GT(inside, 20);
  EXPECT_GT(outside, 300);
  EXPECT_GT(g.position(Vertex(10 * n + 10)).z(), before.position(Vertex(10 * n + 10)).z())
      << "the pulled vertex follows the pull";
}

TEST(MassSpring, ParametersOutOfRangeAreRefusedByName) {
  for (double k : {0.0, -5.0, std::nan(""), double(INFINITY)}) {
    SolverParams p = paper(k);
    try {
      Solver s(p);
      FAIL() << "spring_k " << k << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("spring_k"), std::string::npos) << e.what();
    }
  }
  SolverParams p = paper();
  p.spring_damping = -1;
  EXPECT_THROW(p.validate(), InputError);
  p = paper();
  p.local_radius = -0.1;
  EXPECT_THROW(p.validate(), InputError);
  p = paper();
  p.local_center = Vec3(0, std::nan(""), 0);
  EXPECT_THROW(p.validate(), InputError);
}

TEST(MassSpring, ADampingTooHighForTheStepIsUndoneNotWrittenAsNaN) {
  // The paper's explicit integration of eq. 1's damping is stable only while gamma h stays under 2:
  // at gamma = 1e12 and one substep a step, the velocity changes sign and grows 1.7e10-fold a step,
  // and overflows within 40 steps. The step that would write a non-finite state is refused with
  // SimulationError, the garment as it was; with a stable damping the cloth steps on from there.
  SolverParams p = paper();
  p.spring_damping = 1e12;
  p.substeps = 1;
  Garment g = make_rectangle(0.5, 0.5, 8, 8);
  Solver solver(p);
  int refused = 0;
  Garment last_good = g;
  for (int i = 0; i < 80 && refused == 0; ++i) {
    last_good = g;
    try {
      solver.step(g, 1.0 / 60);
    } catch (const SimulationError& e) {
      ++refused;
      EXPECT_NE(std::string(e.what()).find("undone"), std::string::npos) << e.what();
    }
    for (Vertex v : g.mesh().vertices()) ASSERT_TRUE(all_finite(g.position(v)) && all_finite(g.velocity(v))) << i;
  }
  ASSERT_EQ(refused, 1) << "the overflow was not reported";
  for (Vertex v : g.mesh().vertices()) {
    EXPECT_EQ(g.position(v), last_good.position(v));
    EXPECT_EQ(g.velocity(v), last_good.velocity(v));
  }
  const Garment flat = make_rectangle(0.5, 0.5, 8, 8);
  for (Vertex v : g.mesh().vertices()) g.set_position(v, flat.position(v)), g.velocity(v) = Vec3::Zero();
  solver.set_params(paper());
  EXPECT_NO_THROW(solver.step(g, 1.0 / 60));
  EXPECT_LT(g.position(Vertex(0)).y(), 0) << "the cloth falls again";
}
