// The session: every change is an operation in one log, so that a log replayed on a new session
// gives the same garments bit for bit; several users' strokes at once; a new body replacing the old
// one; undo bounded by bytes; what a session refuses.
#include "kiji/error.h"
#include "kiji/journal_file.h"
#include "kiji/pattern.h"
#include "kiji/session.h"
#include "kiji/session_file.h"
#include "support/test_shapes.h"
#include "support/test_strokes.h"

#include <gtest/gtest.h>

#include <atomic>
#include <functional>
#include <mutex>
#include <thread>

using namespace kiji;

namespace {

using test::line;
using test::plugins;

std::string tmp(const std::string& name) { return std::string(KIJI_TEST_TMP) + "/" + name; }

// The whole state a user can see, in a line: the clock, and a hash of every garment's binary form.
std::string state(const Session& s) {
  std::string out = std::to_string(s.steps()) + " steps, " + std::to_string(s.time()) + " s, " +
                    (s.simulating() ? "simulating" : "paused");
  for (std::size_t i = 0; i < s.garment_count(); ++i)
    out += ", garment " + std::to_string(i) + " " + std::to_string(hash_bytes(encode_garment(s.garment(i))));
  return out;
}

// A design session that uses every kind of change a session has: garments added, edited and
// removed, a body, solver parameters, the frame rate, pausing, the pick radius, strokes of four
// tools, undo and redo, and time passing.
void design(Session& s) {
  s.add_garment(make_rectangle_spaced(0.6, 0.6, 0.03));
  s.set_body(test::make_sphere(0.2, Vec3(0.3, 0.3, -0.25), 2));
  SolverParams p;
  p.gravity = Vec3(0, 0, -9.81);
  p.substeps = 6;
  s.set_solver_params(p);
  for (int i = 0; i < 20; ++i) s.step();
  s.run("pinch", s.params_for("pinch", {{"stiffness", 200.0}}),
        line(Vec3(0.05, 0.05, -0.05), Vec3(0.0, 0.0, 0.1), 12, s.time() + 0.01));
  s.set_simulating(false);
  s.run("cut", s.params_for("cut"), line(Vec3(-0.05, 0.31, 0.0), Vec3(0.65, 0.29, 0.0), 30, s.time()));
  s.set_simulating(true);
  s.set_frame_rate(90);
  for (int i = 0; i < 10; ++i) s.step();
  Garment moved = s.garment(0);
  moved.transform(Eigen::Affine3d(Eigen::Translation3d(0, 0, 0.02)));
  s.set_garment(0, moved);
  s.set_pick_radius(0.08);
  s.run("paint", s.params_for("paint", {{"resolution", 64LL}, {"radius", 0.05}}),
        line(Vec3(0.1, 0.1, 0.0), Vec3(0.5, 0.1, 0.0), 8, s.time()));
  s.undo();
  s.redo();
  s.add_garment(make_rectangle(0.2, 0.2, 5, 5));
  s.undo();  // the second garment goes again
  s.add_garment(make_rectangle(0.3, 0.2, 6, 5));
  s.remove_garment(1);
  for (int i = 0; i < 15; ++i) s.step();
}

}  // namespace

TEST(Session, EveryKindOfChangeReplaysToTheSameGarmentsBitForBit) {
  Session a(plugins());
  design(a);
  Session twin(plugins());
  design(twin);
  ASSERT_EQ(state(twin), state(a)) << "the same design twice gives the same garments";
  std::vector<std::string> kinds;
  for (const Operation& op : a.journal().operations()) kinds.push_back(operation_kind(op.data));
  for (const char* kind : {"tool", "add_garment", "remove_garment", "set_garment", "set_body", "set_solver_params",
                           "set_frame_rate", "set_simulating", "set_pick_radius", "undo", "redo"})
    EXPECT_NE(std::find(kinds.begin(), kinds.end(), kind), kinds.end()) << "the design used no " << kind;
  EXPECT_EQ(a.garment(0).count_pieces(), 2u) << "the cut went across";

  // From the log in memory, from the JSON journal, and from the session file.
  Session b(plugins());
  const std::vector<Operation> saved = operations_to_save(a);
  EXPECT_STREQ(operation_kind(saved.back().data), "advance") << "the steps after the last change";
  replay(b, saved);
  EXPECT_EQ(state(b), state(a));
  EXPECT_EQ(b.journal().operations().size(), saved.size());

  save_journal(a, tmp("every_change.json"));
  Session c(plugins());
  EXPECT_EQ(replay_file(c, tmp("every_change.json")), saved.size());
  EXPECT_EQ(state(c), state(a));

  save_session(a, tmp("every_change.kiji"));
  Session d(plugins());
  replay(d, load_session(tmp("every_change.kiji")));
  EXPECT_EQ(state(d), state(a));
  // The same steps afterwards too (the solvers were left in the same state).
  for (int i = 0; i < 5; ++i) a.step(), d.step();
  EXPECT_EQ(state(d), state(a));
}

TEST(Session, ReplayContinuesASessionSetUpTheSameWayAndRefusesOneThatDiffers) {
  Session a(plugins());
  a.add_garment(make_rectangle(0.5, 0.5, 9, 9));
  a.run("pinch", a.params_for("pinch"), line(Vec3(0, 0, 0), Vec3(0, 0, 0.1), 5, 0.1));
  Session same(plugins());
  same.add_garment(make_rectangle(0.5, 0.5, 9, 9));
  EXPECT_EQ(replay(same, a.journal().operations()), a.journal().operations().size());
  EXPECT_EQ(state(same), state(a));
  Session other(plugins());
  other.add_garment(make_rectangle(0.5, 0.5, 8, 8));
  try {
    replay(other, a.journal().operations());
    ADD_FAILURE() << "a session with another garment took the journal";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("operation 0"), std::string::npos) << e.what();
  }
}

TEST(Session, TwoUsersStrokeAtOnceEachWithTheirOwnTool) {
  Session a(plugins());
  a.add_garment(make_rectangle(1.0, 1.0, 11, 11));
  SolverParams p;
  p.gravity = Vec3::Zero();
  a.set_solver_params(p);
  const Stroke one = line(Vec3(0, 0, 0), Vec3(0, 0, 0.2), 10, 0.0);
  const Stroke two = line(Vec3(1, 1, 0), Vec3(1, 1, 0.3), 10, 0.0);
  const ParamSet params = a.params_for("pinch");
  for (std::size_t i = 0; i < one.size(); ++i) {
    a.apply("pinch", one[i], &params, 1);
    a.apply("pinch", two[i], &params, 2);
    if (i == 3) {
      EXPECT_TRUE(a.stroke_active(1) && a.stroke_active(2));
      EXPECT_EQ(a.active_users(), (std::vector<UserId>{1, 2}));
    }
  }
  EXPECT_FALSE(a.stroke_active(1) || a.stroke_active(2));
  const Garment& g = a.garment(0);
  double z0 = 0, z1 = 0;
  for (Vertex v : g.mesh().vertices()) {
    if ((g.position(v).head<2>() - Vec2(0, 0)).norm() < 0.05) z0 = std::max(z0, g.position(v).z());
    if ((g.position(v).head<2>() - Vec2(1, 1)).norm() < 0.05) z1 = std::max(z1, g.position(v).z());
  }
  EXPECT_GT(z0, 0.1) << "user 1's corner was lifted";
  EXPECT_GT(z1, 0.15) << "user 2's corner was lifted";
  EXPECT_EQ(a.journal().entries().size(), 3u) << "the garment and both strokes";
  Session b(plugins());
  replay(b, operations_to_save(a));
  EXPECT_EQ(state(b), state(a));
  // A user's second begin during their own stroke is refused; another user's is not.
  const Stroke again = line(Vec3(0, 0, 0), Vec3(0, 0, 0.2), 10, a.time());
  a.apply("pinch", again[0], &params, 1);
  EXPECT_THROW(a.apply("cut", again[0], &params, 1), InputError);
  const ParamSet cut = a.params_for("cut");
  a.apply("cut", line(Vec3(0.5, -0.1, 0), Vec3(0.5, 1.1, 0), 1, a.time())[0], &cut, 3);
  EXPECT_EQ(a.active_tool(3), "cut");
}

// What an app's simulation thread and a script (Python with the GIL released) do to one session:
// each use under Session::mutex(). The result is the same as the log replayed on one thread, and the
// script's stroke did what it does alone. ThreadSanitizer runs this test (scripts/sanitize.sh tsan).
TEST(Session, TwoThreadsShareOneSessionThroughItsLock) {
  auto s = std::make_shared<Session>(plugins());
  s->add_garment(make_rectangle(0.6, 0.6, 13, 13));
  SolverParams p;
  p.gravity = Vec3::Zero();
  s->set_solver_params(p);
  std::atomic<bool> script_done{false};
  std::size_t vertices_seen = 0;
  std::thread simulation([&] {
    while (!script_done) {
      std::lock_guard<std::recursive_mutex> lock(s->mutex());
      s->step();
    }
  });
  std::thread script([&] {
    ParamSet params;
    {
      std::lock_guard<std::recursive_mutex> lock(s->mutex());
      params = s->params_for("pinch", {{"stiffness", 300.0}});
    }
    for (int i = 0; i <= 20; ++i) {
      std::lock_guard<std::recursive_mutex> lock(s->mutex());
      ToolEvent e;
      e.phase = i == 0 ? Phase::Begin : (i == 20 ? Phase::End : Phase::Move);
      e.time = s->time() + 1.0 / 60;
      e.position = Vec3(0, 0, 0.01 * i);
      e.buttons = kButtonPrimary;
      s->apply("pinch", e, i == 0 ? &params : nullptr);
      vertices_seen = s->garment(0).mesh().number_of_vertices();  // a read between steps, as g.positions
    }
    script_done = true;
  });
  script.join();
  simulation.join();

  EXPECT_EQ(vertices_seen, 13u * 13u) << "the script read the whole garment between steps";
  EXPECT_GT(s->steps(), 20u) << "both threads stepped the clock";
  // The corner vertex itself, wherever it went: with no gravity, the cloth flung up keeps drifting for
  // as many steps as the simulation thread took after the release.
  const Garment& g = s->garment(0);
  EXPECT_GT(g.position(Vertex(0)).z(), 0.1) << "the pinched corner followed the pointer up";
  Session again(plugins());
  replay(again, operations_to_save(*s));
  EXPECT_EQ(state(again), state(*s)) << "the log of the shared session replays to the same garment";
}

TEST(Session, ANewBodyReplacesTheOldOneForCollision) {
  Session s(plugins());
  s.add_garment(make_rectangle(0.4, 0.4, 9, 9));
  Garment g = s.garment(0);
  g.transform(Eigen::Affine3d(Eigen::Translation3d(-0.2, -0.2, 0.3)));
  s.set_garment(0, g);
  SolverParams p;
  p.gravity = Vec3(0, 0, -9.81);
  s.set_solver_params(p);
  s.set_body(test::make_sphere(0.1, Vec3(0, 0, 0), 2));
  for (int i = 0; i < 5; ++i) s.step();
  // A floor far below replaces the sphere: the cloth now falls past where the sphere was.
  s.set_body(Body::from_triangles({{-2, -2, -1}, {2, -2, -1}, {2, 2, -1}, {-2, 2, -1}}, {{{0, 1, 2}}, {{0, 2, 3}}},
                                  "deep floor"));
  for (int i = 0; i < 90; ++i) s.step();
  const ClothMeasures m = s.solver(0).measure(s.garment(0));
  EXPECT_LT(s.garment(0).bounds().max().z(), 0.0) << "the cloth fell through where the old sphere was";
  EXPECT_LT(m.max_penetration, 0.01);
  EXPECT_EQ(s.body()->name(), "deep floor");
}

TEST(Session, AnEventOrOperationFarInTheFutureIsRefusedAndChangesNothing) {
  Session s(plugins());
  s.add_garment(make_rectangle(0.4, 0.4, 5, 5));
  const std::string before = state(s);
  ToolEvent e;
  e.phase = Phase::Begin;
  e.time = 1e9;
  const ParamSet params = s.params_for("pinch");
  EXPECT_THROW(s.apply("pinch", e, &params), InputError);
  EXPECT_THROW(s.perform({std::uint64_t(1) << 50, 0, op::SetSimulating{false}}), InputError);
  EXPECT_THROW(s.advance_to(std::numeric_limits<double>::infinity()), InputError);
  EXPECT_EQ(state(s), before);
  EXPECT_FALSE(s.stroke_active());
  e.pressure = 2.0;
  e.time = 0;
  EXPECT_THROW(s.apply("pinch", e, &params), InputError);
}

TEST(Session, AnEventFromDamageOrAPeerIsRefusedWithTheReasonAndChangesNothing) {
  Session s(plugins());
  s.add_garment(make_rectangle(0.4, 0.4, 5, 5));
  for (int i = 0; i < 30; ++i) s.step();  // the clock at 0.5 s
  const std::string before = state(s);
  const std::size_t ops = s.journal().operations().size();
  const ParamSet params = s.params_for("pinch");
  const auto refusal = [&](const std::function<void(ToolEvent&)>& edit) {
    ToolEvent e;
    e.phase = Phase::Begin;
    e.time = s.time();
    e.position = Vec3(0.2, 0.2, 0);
    edit(e);
    try {
      s.apply("pinch", e, &params);
    } catch (const InputError& error) {
      return std::string(error.what());
    }
    return std::string("taken");
  };
  EXPECT_EQ(refusal([](ToolEvent& e) { e.orientation = Eigen::Quaterniond(0, 0, 0, 0); }),
            "a 'pinch' event was refused: the event's orientation (0, 0, 0, 0) is not a unit quaternion (its length "
            "is 0): give (w, x, y, z) of length 1");
  EXPECT_EQ(refusal([](ToolEvent& e) { e.time = -5; }),
            "a 'pinch' event was refused: its time -5 s is before the session's clock (0.5 s, and its last step began "
            "at 0.483333 s): an event comes at the clock's time or later");
  EXPECT_EQ(refusal([](ToolEvent& e) { e.position = Vec3(1e308, 0, 0); }),
            "a 'pinch' event was refused: the event's position (1e+308, 0, 0) is outside the world's bounds (1000 m "
            "from the origin on each axis)");
  EXPECT_EQ(refusal([](ToolEvent& e) { e.pressure = 2; }),
            "a 'pinch' event was refused: the event's pressure is 2: it must be from 0 to 1");
  // The same through perform(), as a replay or a peer hands them over.
  ToolEvent damaged;
  damaged.phase = Phase::Begin;
  damaged.time = -5;
  EXPECT_THROW(s.perform({s.steps(), 0, op::ToolInput{"pinch", params.values(), damaged}}), InputError);
  EXPECT_EQ(state(s), before);
  EXPECT_EQ(s.journal().operations().size(), ops);
  EXPECT_FALSE(s.stroke_active());
  // A pen sampled faster than the clock steps: its events come within the step just taken.
  const Stroke fast = line(Vec3(0.2, 0.2, 0), Vec3(0.2, 0.2, 0.05), 20, s.time() + 0.001, 0.001);
  s.run("pinch", params, fast);
  EXPECT_FALSE(s.stroke_active());
  EXPECT_EQ(s.journal().entries().size(), 2u) << "the garment, and the stroke";
}

TEST(Session, AReplayOnASessionWhoseClockRanOnIsRefusedBeforeAnythingChanges) {
  // An app's session set up as the journal's was, whose simulation thread then stepped before the
  // replay: the journal's next operation cannot come at its step any more.
  Session a(plugins());
  a.add_garment(make_rectangle(0.5, 0.5, 9, 9));
  a.step();
  a.run("pinch", a.params_for("pinch"), line(Vec3(0, 0, 0), Vec3(0, 0, 0.1), 5, a.time()));
  const std::vector<Operation> journal = operations_to_save(a);
  Session ran_on(plugins());
  ran_on.add_garment(make_rectangle(0.5, 0.5, 9, 9));
  ran_on.step();
  ran_on.step();
  const std::string before = state(ran_on);
  try {
    replay(ran_on, journal);
    ADD_FAILURE() << "a session whose clock had passed the journal's next operation took it";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "the journal's operation 1 (tool) came at step 1, and this session's clock is at step 2: time ran on "
              "after it was set up. Replay the journal on a new session, whose clock has not run");
  }
  EXPECT_EQ(state(ran_on), before);
  EXPECT_EQ(ran_on.journal().operations().size(), 1u);
  // Steps that go back are a damaged journal, refused before the first is applied.
  std::vector<Operation> back = journal;
  back[1].step = 40;
  Session fresh(plugins());
  EXPECT_THROW(replay(fresh, back), InputError);
  EXPECT_EQ(fresh.garment_count(), 0u);
  // A new session replays it, every time the same.
  Session b(plugins());
  replay(b, journal);
  EXPECT_EQ(state(b), state(a));
}

TEST(Session, StrokesOfAnotherClockReplayFromThisOneKeepingTheirTimesApart) {
  Session a(plugins());
  a.add_garment(make_rectangle(0.5, 0.5, 9, 9));
  SolverParams still;
  still.gravity = Vec3::Zero();
  a.set_solver_params(still);
  a.run("pinch", a.params_for("pinch"), line(Vec3(0, 0, 0), Vec3(0, 0, 0.1), 10, 0.1));
  const auto strokes = journal_strokes(a.journal());
  Session b(plugins());
  b.add_garment(make_rectangle(0.5, 0.5, 9, 9));
  b.set_solver_params(still);
  for (int i = 0; i < 120; ++i) b.step();  // 2 s on, past the stroke's times
  const double start = b.time();
  EXPECT_EQ(replay(b, strokes), 1u);
  EXPECT_NEAR(b.time() - start, 10.0 / 60.0, 1e-9) << "the stroke took its time, from the clock on";
  double apart = 0;
  for (Vertex v : a.garment(0).mesh().vertices())
    apart = std::max(apart, (a.garment(0).position(v) - b.garment(0).position(v)).norm());
  EXPECT_LT(apart, 1e-6) << "with no gravity, the same lift";
  EXPECT_GT(b.garment(0).bounds().max().z(), 0.05);
}

TEST(Session, AnOperationThatCannotApplyIsRefusedBeforeAnythingChanges) {
  Session s(plugins());
  s.add_garment(make_rectangle(0.4, 0.4, 5, 5));
  const std::size_t ops = s.journal().operations().size();
  EXPECT_THROW(s.perform({0, 0, op::RemoveGarment{3}}), InputError);
  EXPECT_THROW(s.perform({0, 0, op::SetGarment{0, std::make_shared<const std::string>("not a garment")}}), InputError);
  EXPECT_THROW(s.perform({0, 0, op::SetFrameRate{-1}}), InputError);
  op::ToolInput t;
  t.tool = "lasso";
  EXPECT_THROW(s.perform({0, 0, t}), InputError);
  EXPECT_EQ(s.journal().operations().size(), ops);
}

TEST(Session, ListenersSeeEveryOperationAndTheirErrorsReachTheCaller) {
  Session s(plugins());
  std::vector<std::string> seen;
  const int id = s.add_listener([&](const Operation& op) { seen.push_back(operation_kind(op.data)); });
  s.add_garment(make_rectangle(0.4, 0.4, 5, 5));
  s.set_simulating(false);
  s.run("pin", s.params_for("pin"), line(Vec3(0, 0, 0), Vec3(0.1, 0, 0), 2, 0));
  EXPECT_EQ(seen, (std::vector<std::string>{"add_garment", "set_simulating", "tool", "tool", "tool"}));
  s.remove_listener(id);
  s.add_listener([](const Operation&) { throw InputError("the disk is full"); });
  EXPECT_THROW(s.set_simulating(true), InputError);
  EXPECT_TRUE(s.simulating()) << "applied all the same";
}

TEST(Session, UndoHistoryStaysWithinItsByteLimitAndKeepsATextureOnce) {
  Session s(plugins());
  s.add_garment(make_rectangle(1.0, 1.0, 41, 41));
  SolverParams p;
  p.gravity = Vec3::Zero();
  s.set_solver_params(p);
  s.run("paint", s.params_for("paint", {{"resolution", 1024LL}, {"radius", 0.05}}),
        line(Vec3(0.2, 0.2, 0), Vec3(0.8, 0.2, 0), 6, 0));
  const std::size_t texture = 1024u * 1024u * 4u;
  const std::size_t garment = garment_bytes(s.garment(0), false);
  for (int i = 0; i < 10; ++i)
    s.run("pinch", s.params_for("pinch"), line(Vec3(0.5, 0.5, 0), Vec3(0.5, 0.5, 0.01 * i), 3, s.time()));
  // 12 steps of history, each with two garment copies, and the painted texture held once (plus the
  // blank one before the paint).
  EXPECT_EQ(s.journal().entries().size(), 12u);
  EXPECT_LT(s.journal().history_bytes(), 24 * garment + 2 * texture + texture / 2);
  // The solver's records are counted with the garment (a margin, a hold and more a vertex).
  Garment bare = s.garment(0);
  ASSERT_TRUE(bare.step_record());
  bare.set_step_record(nullptr);
  bare.set_sleep_record(nullptr);
  EXPECT_GE(garment, garment_bytes(bare, false) + 17 * bare.mesh().number_of_vertices());
  s.set_history_limit(8 * garment + 2 * texture);
  EXPECT_LE(s.journal().history_bytes(), 8 * garment + 2 * texture);
  EXPECT_LT(s.journal().entries().size(), 12u);
  EXPECT_GT(s.journal().dropped(), 0u);
  // What is left still undoes exactly.
  const Garment before_last = s.journal().entries().back().before.garments()[0];
  ASSERT_TRUE(s.undo());
  EXPECT_EQ(encode_garment(s.garment(0)), encode_garment(before_last));
  EXPECT_THROW(s.set_history_limit(1000), InputError);
}
