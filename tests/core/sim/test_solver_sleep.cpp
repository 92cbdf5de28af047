// Sleeping: cloth at rest is held still and not computed, and wakes whenever something disturbs it.
#include "kiji/error.h"
#include "kiji/operation.h"
#include "kiji/pattern.h"
#include "kiji/session.h"
#include "kiji/solver.h"
#include "kiji/topology.h"

#include "support/test_errors.h"
#include "support/test_shapes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

using namespace kiji;

namespace {

// A cloth 1 m square of 65 x 65 vertices (four blocks of about a thousand) lying flat on the floor
// at its thickness: at rest from the first step.
Garment cloth_on_floor() {
  Garment g = make_rectangle(1.0, 1.0, 65, 65);
  const double th = g.material().thickness;
  for (Vertex v : g.mesh().vertices()) {
    const Vec3 q = g.position(v);
    g.set_position(v, Vec3(q.x() - 0.5, th, -q.y() + 0.5));
  }
  return g;
}

void run(Solver& s, Garment& g, int steps) {
  for (int i = 0; i < steps; ++i) s.step(g, 1.0 / 60);
}

// Lets the cloth lie still for a second (sleep_after is 0.5 s) and checks that all of it sleeps.
void sleep_on(Solver& s, Garment& g) {
  run(s, g, 60);
  ASSERT_EQ(s.measure(g).sleeping, g.mesh().number_of_vertices()) << "at rest on the floor for 1 s";
}

// Lets the cloth fall asleep under a solver of its own (sleep_on): the garment keeps where it slept.
void sleep_alone(const Body& floor, Garment& g) {
  Solver s;
  s.set_body(&floor);
  sleep_on(s, g);
}

// The largest distance between the same vertex in two garments.
double largest_gap(const Garment& a, const Garment& b) {
  double gap = 0;
  for (Vertex v : a.mesh().vertices()) gap = std::max(gap, (a.position(v) - b.position(v)).norm());
  return gap;
}

// The vertices asleep after one step of a new solver (a new session, an undo) on the garment.
std::size_t asleep_after_a_step(const Body& floor, Garment& g) {
  Solver fresh;
  fresh.set_body(&floor);
  fresh.step(g, 1.0 / 60);
  return fresh.measure(g).sleeping;
}
}  // namespace

TEST(Sleep, ClothAtRestFallsAsleepAndStaysExactlyWhereItIs) {
  const Body floor = test::make_floor();
  Garment g = cloth_on_floor();
  Solver solver;
  solver.set_body(&floor);
  run(solver, g, 20);
  EXPECT_EQ(solver.measure(g).sleeping, 0u) << "asleep before it was calm for sleep_after (0.5 s)";
  run(solver, g, 40);
  ASSERT_EQ(solver.measure(g).sleeping, g.mesh().number_of_vertices()) << "at rest on the floor for 1 s";
  const Garment before = g;
  run(solver, g, 30);
  EXPECT_EQ(largest_gap(g, before), 0.0) << "a sleeping cloth does not move at all";
  for (Vertex v : g.mesh().vertices()) ASSERT_EQ(g.velocity(v), Vec3::Zero());

  // Turned off, nothing sleeps.
  Garment h = cloth_on_floor();
  SolverParams p;
  p.sleep_after = 0;
  Solver awake(p);
  awake.set_body(&floor);
  run(awake, h, 90);
  EXPECT_EQ(awake.measure(h).sleeping, 0u);
}

TEST(Sleep, HandsWakeTheClothAndTheClothTheyPullFollowsAsIfAwake) {
  // A sleeping cloth is lifted 0.3 m by one edge (a hand on each vertex of it) over a second. The
  // hands' blocks wake at once and the rest as the pull reaches them: the cloth ends as a cloth
  // that never slept does.
  const Body floor = test::make_floor();
  Garment asleep = cloth_on_floor(), never = cloth_on_floor();
  SolverParams off;
  off.sleep_after = 0;
  Solver s1, s2(off);
  s1.set_body(&floor);
  s2.set_body(&floor);
  ASSERT_NO_FATAL_FAILURE(sleep_on(s1, asleep));
  run(s2, never, 60);
  std::vector<int> h1, h2;
  for (int k = 0; k < 65; ++k) {  // the first row: the edge at z = +0.5
    h1.push_back(s1.add_attachment(Vertex(k), asleep.position(Vertex(k)), 50.0));
    h2.push_back(s2.add_attachment(Vertex(k), never.position(Vertex(k)), 50.0));
  }
  const Vec3 start = asleep.position(Vertex(0));
  for (int i = 1; i <= 60; ++i) {
    for (int k = 0; k < 65; ++k) {
      const Vec3 target(start.x() + k / 64.0, start.y() + 0.3 * i / 60.0, start.z());
      s1.move_attachment(h1[k], target);
      s2.move_attachment(h2[k], target);
    }
    s1.step(asleep, 1.0 / 60);
    s2.step(never, 1.0 / 60);
  }
  const Vertex far(65 * 64);  // the opposite edge
  EXPECT_GT(asleep.position(Vertex(32)).y(), 0.25) << "the lifted edge";
  EXPECT_LT(asleep.position(far).z() - never.position(far).z(), 0.01);
  EXPECT_LT(largest_gap(asleep, never), 0.01) << "every vertex within 1 cm of where a cloth that never slept is";
  EXPECT_LT(s1.measure(asleep).max_strain, s2.measure(never).max_strain + 0.02) << "sleeping cloth held nothing back";
}

TEST(Sleep, AnEditOfASleepingVertexWakesItsCloth) {
  // A script lifts one vertex of a sleeping cloth 5 cm: it falls back, it is not left floating.
  const Body floor = test::make_floor();
  Garment g = cloth_on_floor();
  Solver solver;
  solver.set_body(&floor);
  ASSERT_NO_FATAL_FAILURE(sleep_on(solver, g));
  const Vertex v(65 * 32 + 32);  // the middle
  g.set_position(v, g.position(v) + Vec3(0, 0.05, 0));
  solver.step(g, 1.0 / 60);
  EXPECT_LT(g.position(v).y(), 0.05) << "it fell (or was pulled back by its edges)";
  EXPECT_LT(solver.measure(g).sleeping, g.mesh().number_of_vertices());
  run(solver, g, 30);
  EXPECT_LT(g.position(v).y(), 0.01) << "back on the floor";

  // Pinning a vertex of a sleeping cloth and moving it (the sew tool's drag) wakes it the same way.
  ASSERT_NO_FATAL_FAILURE(sleep_on(solver, g));
  const Vertex c(0);
  g.set_pinned(c, true);
  g.set_position(c, g.position(c) + Vec3(0, 0.1, 0));
  run(solver, g, 10);
  const Vertex next(1);
  EXPECT_GT(g.position(next).y(), 0.02) << "its neighbour is pulled up after it";
}

TEST(Sleep, NewPhysicsWakesEverything) {
  // Gravity turned sideways under a sleeping cloth (as a changed material or body would): it all
  // wakes and moves.
  const Body floor = test::make_floor();
  Garment g = cloth_on_floor();
  Solver solver;
  solver.set_body(&floor);
  ASSERT_NO_FATAL_FAILURE(sleep_on(solver, g));
  SolverParams p = solver.params();
  p.gravity = Vec3(9.81, 0, 0);
  solver.set_params(p);
  const Garment before = g;
  run(solver, g, 10);
  EXPECT_EQ(solver.measure(g).sleeping, 0u);
  for (Vertex v : g.mesh().vertices()) ASSERT_GT(g.position(v).x(), before.position(v).x() + 0.01);
}

TEST(Sleep, ANewSolverFindsTheClothAsleepWhereItSleptAndWakesOnlyWhatChanged) {
  // A garment taken to a new solver (a new session, an undo) keeps sleeping where it slept: nothing
  // of it moves or is computed until something disturbs it.
  const Body floor = test::make_floor();
  Garment g = cloth_on_floor();
  ASSERT_NO_FATAL_FAILURE(sleep_alone(floor, g));
  const std::size_t all = g.mesh().number_of_vertices();
  {
    Garment copy = g;
    Solver fresh;
    fresh.set_body(&floor);
    run(fresh, copy, 10);
    EXPECT_EQ(fresh.measure(copy).sleeping, all) << "the whole cloth asleep from the new solver's first step";
    EXPECT_EQ(largest_gap(copy, g), 0.0);
  }
  {
    // One vertex of the copy raised 1 mm (less than sleep_distance, so that its motion wakes no
    // neighbour): its block wakes and it settles back; the rest sleeps on.
    Garment copy = g;
    const Vertex v(65 * 32 + 32);
    const double th = copy.material().thickness;
    copy.set_position(v, copy.position(v) + Vec3(0, 0.001, 0));
    Solver fresh;
    fresh.set_body(&floor);
    fresh.step(copy, 1.0 / 60);
    EXPECT_LT(fresh.measure(copy).sleeping, all);
    EXPECT_GT(fresh.measure(copy).sleeping, 0u) << "the blocks away from the edit sleep on";
    run(fresh, copy, 30);
    EXPECT_LT(copy.position(v).y(), th + 0.0002) << "back on the floor, not left floating";
  }
  {
    // A pin let go in the copy wakes its block the same way.
    Garment pinned = cloth_on_floor();
    pinned.set_pinned(Vertex(0), true);
    Solver hold;
    hold.set_body(&floor);
    ASSERT_NO_FATAL_FAILURE(sleep_on(hold, pinned));
    Garment copy = pinned;
    copy.set_pinned(Vertex(0), false);
    const std::size_t sleeping = asleep_after_a_step(floor, copy);
    EXPECT_LT(sleeping, all) << "the block of the pin let go is awake";
    EXPECT_GT(sleeping, 0u);
  }
  {
    // Other physics (here the friction) in the copy: nothing of the record holds, all wakes.
    Garment copy = g;
    Material m = copy.material();
    m.friction = 0.9;
    copy.set_material(m);
    EXPECT_EQ(asleep_after_a_step(floor, copy), 0u);
  }
}

TEST(Sleep, AGarmentsBytesCarryWhereItSleeps) {
  // A settled garment added to a session (which keeps it as its bytes give it back, as a replay or
  // a peer does), or brought back by a checkpoint, sleeps on: it costs nothing until touched.
  const Body floor = test::make_floor();
  Garment g = cloth_on_floor();
  ASSERT_NO_FATAL_FAILURE(sleep_alone(floor, g));
  const std::size_t all = g.mesh().number_of_vertices();
  {
    Garment copy = decode_garment(encode_garment(g));
    EXPECT_EQ(asleep_after_a_step(floor, copy), all) << "decoded, the whole cloth sleeps from the first step";
    EXPECT_EQ(largest_gap(copy, g), 0.0);
    EXPECT_EQ(encode_garment(copy), encode_garment(g)) << "its bytes again give the same bytes";
  }
  {
    Session s;
    s.set_body(floor);
    s.add_garment(g);
    s.step();
    EXPECT_EQ(s.solver(0).measure(s.garment(0)).sleeping, all) << "added to a session";
    s.perform({s.steps(), 0, op::Checkpoint{}});  // every peer's state, encoded and loaded again
    s.step();
    EXPECT_EQ(s.solver(0).measure(s.garment(0)).sleeping, all) << "after a checkpoint";
    EXPECT_EQ(largest_gap(s.garment(0), g), 0.0);
  }
  {
    // A vertex moved after the cloth fell asleep: its bytes leave it out, so its block wakes.
    Garment moved = g;
    const Vertex v(65 * 32 + 32);
    moved.set_position(v, moved.position(v) + Vec3(0, 0.001, 0));
    Garment copy = decode_garment(encode_garment(moved));
    const std::size_t sleeping = asleep_after_a_step(floor, copy);
    EXPECT_LT(sleeping, all);
    EXPECT_GT(sleeping, 0u) << "the blocks away from the moved vertex sleep on";
  }
  {
    // Bytes from before the record was part of them (they end after the tacks) decode, awake.
    const std::string bytes = encode_garment(cloth_on_floor());
    Garment old = decode_garment(std::string_view(bytes).substr(0, bytes.size() - 4));
    EXPECT_EQ(old.mesh().number_of_vertices(), all);
    EXPECT_EQ(asleep_after_a_step(floor, old), 0u);
  }
  {
    // A sleeping vertex that does not exist, or out of order, is malformed data, said so. (Without
    // the step record, which would follow the sleeping vertices.)
    Garment unstepped = g;
    unstepped.set_step_record(nullptr);
    std::string bytes = encode_garment(unstepped);
    const std::size_t last = bytes.size() - 4;
    const std::uint32_t huge = 1u << 30;
    std::string bad = bytes;
    bad.replace(last, 4, reinterpret_cast<const char*>(&huge), 4);  // the bytes are little-endian
    std::string why = test::input_error([&] { decode_garment(bad); });
    EXPECT_NE(why.find("a sleeping vertex does not exist"), std::string::npos) << why;
    const std::uint32_t zero = 0;
    bad = bytes;
    bad.replace(last, 4, reinterpret_cast<const char*>(&zero), 4);
    why = test::input_error([&] { decode_garment(bad); });
    EXPECT_NE(why.find("not in ascending order"), std::string::npos) << why;
  }
}

TEST(Sleep, ATopologyEditWakesOnlyTheClothAroundIt) {
  // A slit cut near one corner of a sleeping cloth: the solver rebuilds its arrays, but only the
  // block the cut goes through wakes (blocks are about a thousand vertices; this cloth has four).
  const Body floor = test::make_floor();
  Garment g = cloth_on_floor();
  Solver solver;
  solver.set_body(&floor);
  ASSERT_NO_FATAL_FAILURE(sleep_on(solver, g));
  const std::size_t all = g.mesh().number_of_vertices();
  cut_along(g, edge_path(g, Vertex(65 * 5 + 3), Vertex(65 * 5 + 12)));
  const std::size_t after_cut = g.mesh().number_of_vertices();
  ASSERT_GT(after_cut, all) << "the cut split the vertices along it";
  solver.step(g, 1.0 / 60);
  const std::size_t awake = after_cut - solver.measure(g).sleeping;
  // Awake: at least the ten vertices along the cut and the copies it made of them; at most the
  // cut's block and a little: a third of the cloth holds one block, not two.
  EXPECT_GE(awake, 10 + (after_cut - all));
  EXPECT_LT(awake, all / 3) << awake << " of " << after_cut << " vertices woke for a slit in one corner";
}

TEST(Sleep, ParametersOutOfRangeAreRefusedByName) {
  for (double bad : {-1.0, std::nan(""), double(INFINITY)}) {
    SolverParams p;
    p.sleep_after = bad;
    try {
      Solver s(p);
      FAIL() << "sleep_after = " << bad << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("sleep_after"), std::string::npos) << e.what();
    }
  }
  for (double bad : {0.0, -0.001, 2.0, std::nan("")}) {
    SolverParams p;
    p.sleep_distance = bad;
    try {
      Solver s(p);
      FAIL() << "sleep_distance = " << bad << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("sleep_distance"), std::string::npos) << e.what();
    }
  }
}
