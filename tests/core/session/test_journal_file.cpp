// Journal files: strokes saved and read back exactly, replayed on a fresh session to the same garment,
// and bad files refused with a message naming the problem.
#include "kiji/error.h"
#include "kiji/journal_file.h"
#include "kiji/pattern.h"
#include "kiji/session.h"
#include "kiji/session_file.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

using namespace kiji;

namespace {

// A tool built into the test: lifts the vertex under the pointer by `height` at the end of a stroke.
class Lift : public Tool {
 public:
  ToolInfo info() const override {
    return {"lift", "Lift", "Lifts a vertex.",
            {ParamSpec::real("height", 0.1, 0.0, 1.0, "m", "Height", "How far."),
             ParamSpec::integer("times", 1, 1, 5, "Times", "How often."),
             ParamSpec::color("tint", Vec3(0.1, 0.2, 0.3), "Tint", "Unused."),
             ParamSpec::choice("way", "up", {"up", "down"}, "Way", "Which way."),
             ParamSpec::boolean("flag", false, "Flag", "Unused.")}};
  }
  Feedback begin(ToolContext&, const ParamSet& p, const ToolEvent& e) override {
    hit_ = e.hit;
    lift_ = p.get_float("height") * double(p.get_int("times")) * (p.get_string("way") == "up" ? 1 : -1);
    return {};
  }
  Feedback update(ToolContext&, const ToolEvent&) override { return {}; }
  void end(ToolContext& s, const ToolEvent&) override {
    if (!hit_.hit) return;
    Garment& g = s.garment(hit_.garment);
    g.set_position(hit_.nearest, g.position(hit_.nearest) + Vec3(0, lift_, 0));
  }
  void cancel(ToolContext&) override {}

 private:
  SurfaceHit hit_;
  double lift_ = 0;
};

std::unique_ptr<Session> session() {
  auto registry = std::make_shared<ToolRegistry>();
  registry->add("lift", [] { return std::make_unique<Lift>(); });
  auto s = std::make_unique<Session>(registry);
  s->add_garment(make_rectangle(1.0, 1.0, 6, 6));
  SolverParams p;
  p.gravity = Vec3(0, -1, 0);
  s->set_solver_params(p);
  return s;
}

Stroke stroke(const Vec3& at, double t0) {
  Stroke s(3);
  for (int i = 0; i < 3; ++i) {
    s[i].phase = i == 0 ? Phase::Begin : (i == 2 ? Phase::End : Phase::Move);
    s[i].time = t0 + i / 60.0;
    s[i].position = at + Vec3(0, 0, 0.001 * i);
    s[i].pressure = 0.1 * (i + 1) + 1.0 / 3.0;  // not exact in decimal: must still round-trip
  }
  return s;
}

std::string tmp(const std::string& name) { return std::string(KIJI_TEST_TMP) + "/" + name; }

}  // namespace

TEST(JournalFile, SavedStrokesReadBackExactlyAndReplayToTheSameGarment) {
  auto a = session();
  a->run("lift", a->params_for("lift", {{"height", 0.05}, {"times", 2LL}, {"tint", Vec3(1, 0, 0.5)},
                                        {"way", std::string("down")}, {"flag", true}}),
         stroke(Vec3(0.2, 0.2, 0), 0.0));
  a->run("lift", a->params_for("lift"), stroke(Vec3(0.8, 0.6, 0), 0.5));
  const Garment after_two = a->garment(0);
  a->run("lift", a->params_for("lift"), stroke(Vec3(0.4, 0.4, 0), 0.7));
  a->undo();  // undone strokes are not saved
  save_journal(*a, tmp("journal.json"));
  const auto strokes = load_journal(tmp("journal.json"));
  ASSERT_EQ(strokes.size(), 2u);
  const auto saved = journal_strokes(a->journal());
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(strokes[i].tool, "lift");
    EXPECT_TRUE(strokes[i].params == saved[i].params);
    ASSERT_EQ(strokes[i].events.size(), saved[i].events.size());
    for (std::size_t k = 0; k < saved[i].events.size(); ++k) {
      const ToolEvent &x = strokes[i].events[k], &y = saved[i].events[k];
      EXPECT_EQ(x.phase, y.phase);
      EXPECT_EQ(x.time, y.time);
      EXPECT_EQ(x.position, y.position);
      EXPECT_EQ(x.pressure, y.pressure);
      EXPECT_EQ(x.buttons, y.buttons);
      EXPECT_EQ(x.orientation.coeffs(), y.orientation.coeffs());
    }
  }
  EXPECT_TRUE(std::holds_alternative<long long>(strokes[0].params.at("times")));
  EXPECT_TRUE(std::holds_alternative<Vec3>(strokes[0].params.at("tint")));

  auto b = session();
  std::size_t calls = 0;
  EXPECT_EQ(replay(*b, strokes, [&](std::size_t done, std::size_t total) {
              ++calls;
              EXPECT_LE(done, total);
              return true;
            }),
            2u);
  EXPECT_EQ(calls, 6u);
  const Garment &ga = after_two, &gb = b->garment(0);
  for (Vertex v : ga.mesh().vertices()) EXPECT_EQ(ga.position(v), gb.position(v));
  EXPECT_EQ(b->journal().entries().size(), 3u) << "the garment and the two strokes";
}

TEST(JournalFile, ReplayStoppedByProgressCancelsTheStrokeInProgress) {
  auto a = session();
  a->run("lift", a->params_for("lift"), stroke(Vec3(0.2, 0.2, 0), 0.0));
  auto b = session();
  const std::size_t steps = b->journal().entries().size();
  EXPECT_EQ(replay(*b, journal_strokes(a->journal()), [](std::size_t done, std::size_t) { return done < 2; }), 0u);
  EXPECT_FALSE(b->stroke_active());
  EXPECT_EQ(b->journal().entries().size(), steps) << "the stopped stroke left no step in the undo history";
}

TEST(JournalFile, BadFilesAreRefusedSayingWhy) {
  auto expect_error = [](const std::string& text, const std::string& part) {
    {
      std::ofstream(tmp("bad.json")) << text;
    }
    try {
      load_journal(tmp("bad.json"));
      ADD_FAILURE() << "no error for " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  EXPECT_THROW(load_journal(tmp("missing.json")), InputError);
  expect_error("{", "not valid JSON");
  expect_error(R"({"format": "other", "version": 1})", "not a Kiji journal");
  expect_error(R"({"format": "kiji-journal", "version": 3, "operations": []})", "version 3");
  expect_error(R"({"format": "kiji-journal", "version": 2, "strokes": []})", "no list of operations");
  expect_error(R"({"format": "kiji-journal", "version": 1, "strokes": [{"tool": "lift", "events": [
               {"phase": "begin", "time": 0, "position": [0, 0, 0], "buttons": -5}]}]})", "'buttons'");
  expect_error(R"({"format": "kiji-journal", "version": 1, "strokes": [{"tool": "lift", "events": [
               {"phase": "begin", "time": 0, "position": [0, 0, 0], "buttons": 1e30}]}]})", "'buttons'");
  expect_error(R"({"format": "kiji-journal", "version": 2, "operations": [{"step": 0, "user": 0,
               "kind": "add_garment", "garment": "AAA!"}]})", "operation 0: 'garment' is not base64");
  expect_error(R"({"format": "kiji-journal", "version": 2, "operations": [{"step": -1, "user": 0,
               "kind": "undo"}]})", "'step'");
  expect_error(R"({"format": "kiji-journal", "version": 1, "strokes": [{"tool": "lift", "events": []}]})",
               "stroke 0: has no events");
  expect_error(R"({"format": "kiji-journal", "version": 1, "strokes": [{"tool": "lift", "events": [
               {"phase": "sideways", "time": 0, "position": [0, 0, 0]}]}]})", "unknown phase");
  expect_error(R"({"format": "kiji-journal", "version": 1, "strokes": [{"tool": "lift", "events": [
               {"phase": "move", "time": 0, "position": [0, 0, 0]}]}]})", "begin");
  // What a damaged disk or a peer could hand over, each said where and why.
  expect_error(R"({"format": "kiji-journal", "version": 1, "strokes": [{"tool": "lift", "events": [
               {"phase": "begin", "time": 0, "position": [0, 0, 0], "orientation": [0, 0, 0, 0]}]}]})",
               "stroke 0, event 0: the event's orientation (0, 0, 0, 0) is not a unit quaternion");
  expect_error(R"({"format": "kiji-journal", "version": 1, "strokes": [{"tool": "lift", "events": [
               {"phase": "begin", "time": 0, "position": [1e308, 0, 0]}]}]})",
               "stroke 0, event 0: the event's position (1e+308, 0, 0) is outside the world's bounds");
  expect_error(R"({"format": "kiji-journal", "version": 2, "operations": [{"step": 0, "user": 0, "kind": "tool",
               "tool": "lift", "event": {"phase": "move", "time": 0, "position": [0, 0, 0], "pressure": 0.5,
               "ray": [0, 0, -5000]}}]})",
               "operation 0, its event: the event's ray (0, 0, -5000) is outside the world's bounds");
  expect_error(R"({"format": "kiji-journal", "version": 2, "operations": [{"step": 0, "user": 0,
               "kind": "set_pick_radius", "radius": 0}]})", "operation 0: the pick radius is 0 m");
  // A time before the clock is the session's to refuse, when the replay reaches it.
  {
    std::ofstream(tmp("past.json")) << R"({"format": "kiji-journal", "version": 2, "operations": [
        {"step": 0, "user": 0, "kind": "set_simulating", "simulating": false},
        {"step": 30, "user": 0, "kind": "tool", "tool": "lift", "params": {}, "event":
         {"phase": "begin", "time": -5, "position": [0, 0, 0]}}]})";
  }
  try {
    auto registry = std::make_shared<ToolRegistry>();
    registry->add("lift", [] { return std::make_unique<Lift>(); });
    Session fresh(registry);
    replay_file(fresh, tmp("past.json"));
    ADD_FAILURE() << "an event at -5 s was replayed";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("its time -5 s is before the session's clock (0.5 s"), std::string::npos)
        << e.what();
  }
  auto s = session();
  const std::size_t steps = s->journal().entries().size();
  EXPECT_THROW(replay(*s, {{"lasso", {}, stroke(Vec3::Zero(), 0)}}), InputError);
  EXPECT_THROW(replay(*s, {{"lift", {{"height", 9.0}}, stroke(Vec3::Zero(), 0)}}), InputError);
  EXPECT_EQ(s->journal().entries().size(), steps) << "nothing replayed when a stroke is bad";
}

// A journal an earlier build saved (tests/fixtures/saved/journal.json, of the session in
// session.kiji beside it): its operations are those of the session file, bit for bit, and saved
// again they make the same file (but for the version of Kiji that wrote it).
TEST(JournalFile, AJournalSavedByAnEarlierBuildReadsBackAndSavesToTheSameFile) {
  const std::string dir = KIJI_TEST_SAVED;
  const JournalFile file = read_journal_file(dir + "/journal.json");
  ASSERT_EQ(file.version, 2);
  const std::vector<Operation> from_session = load_session(dir + "/session.kiji");
  ASSERT_EQ(file.operations.size(), from_session.size());
  for (std::size_t i = 0; i < from_session.size(); ++i)
    EXPECT_EQ(encode_operation(file.operations[i]), encode_operation(from_session[i])) << "operation " << i;

  auto text = [](const std::string& path) {
    std::ifstream in(path);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  };
  const std::string saved = text(dir + "/journal.json");
  const std::string path = std::string(KIJI_TEST_TMP) + "/journal_saved_again.json";
  save_journal(file.operations, path);
  std::string again = text(path);
  // The line that names the Kiji that wrote it, as the earlier file has it.
  const std::size_t at = again.find("\n \"kiji\": "), end = again.find('\n', at + 1);
  const std::size_t was = saved.find("\n \"kiji\": "), was_end = saved.find('\n', was + 1);
  ASSERT_NE(at, std::string::npos);
  ASSERT_NE(was, std::string::npos);
  again.replace(at, end - at, saved.substr(was, was_end - was));
  EXPECT_EQ(again, saved);
}

// The substeps while a hand holds are saved with the solver's settings and come back; a journal
// saved before them has none (a hand's step took the ordinary substeps), so it replays as it did.
TEST(JournalFile, HeldSubstepsComeBackAndAnEarlierJournalHasNone) {
  SolverParams held;
  held.held_substeps = 40;
  SolverParams none = held;
  none.held_substeps = 0;
  save_journal({Operation{0, 0, op::SetSolverParams{held}}, Operation{1, 0, op::SetSolverParams{none}}},
               tmp("held.json"));
  const JournalFile file = read_journal_file(tmp("held.json"));
  ASSERT_EQ(file.operations.size(), 2u);
  EXPECT_EQ(std::get<op::SetSolverParams>(file.operations[0].data).params.held_substeps, 40);
  EXPECT_EQ(std::get<op::SetSolverParams>(file.operations[1].data).params.held_substeps, 0);
  const JournalFile earlier = read_journal_file(std::string(KIJI_TEST_SAVED) + "/journal.json");
  for (const Operation& op : earlier.operations)
    if (const auto* p = std::get_if<op::SetSolverParams>(&op.data)) EXPECT_EQ(p->params.held_substeps, 0) << "step " << op.step;
}

// The floor under the body is saved with the solver's settings and comes back; a journal saved
// before the floor existed has none, so it replays as it did then.
TEST(JournalFile, TheFloorSettingComesBackAndAnEarlierJournalHasNone) {
  SolverParams on;
  on.floor = true;
  SolverParams off = on;
  off.floor = false;
  save_journal({Operation{0, 0, op::SetSolverParams{on}}, Operation{1, 0, op::SetSolverParams{off}}},
               tmp("floor.json"));
  const JournalFile file = read_journal_file(tmp("floor.json"));
  ASSERT_EQ(file.operations.size(), 2u);
  EXPECT_TRUE(std::get<op::SetSolverParams>(file.operations[0].data).params.floor);
  EXPECT_FALSE(std::get<op::SetSolverParams>(file.operations[1].data).params.floor);

  const JournalFile earlier = read_journal_file(std::string(KIJI_TEST_SAVED) + "/journal.json");
  int settings = 0;
  for (const Operation& op : earlier.operations)
    if (const auto* p = std::get_if<op::SetSolverParams>(&op.data)) {
      ++settings;
      EXPECT_FALSE(p->params.floor) << "step " << op.step;
    }
  EXPECT_GT(settings, 0) << "the saved journal sets the solver";
}
