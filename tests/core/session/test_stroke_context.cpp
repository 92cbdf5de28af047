// The ToolContext a session gives its tools: what a stroke may do (read the scene, edit the garments
// in place, hold the cloth through the solver), each call reaching the session's own garments and
// solvers, with bad input an InputError that undoes the stroke and leaves the session going.
#include "kiji/error.h"
#include "kiji/pattern.h"
#include "kiji/session.h"
#include "support/test_shapes.h"
#include "support/test_strokes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>

using namespace kiji;

namespace {

// A tool whose calls run what the test gives it.
struct Calls {
  std::function<void(ToolContext&, const ToolEvent&)> begin, update, end;
  std::function<void(ToolContext&)> cancel;
};

class Hooked : public Tool {
 public:
  explicit Hooked(std::shared_ptr<Calls> calls) : calls_(std::move(calls)) {}
  ToolInfo info() const override { return {"hooked", "Hooked", "Runs what the test gives it.", {}}; }
  Feedback begin(ToolContext& c, const ParamSet&, const ToolEvent& e) override {
    if (calls_->begin) calls_->begin(c, e);
    return {};
  }
  Feedback update(ToolContext& c, const ToolEvent& e) override {
    if (calls_->update) calls_->update(c, e);
    return {};
  }
  void end(ToolContext& c, const ToolEvent& e) override {
    if (calls_->end) calls_->end(c, e);
  }
  void cancel(ToolContext& c) override {
    if (calls_->cancel) calls_->cancel(c);
  }

 private:
  std::shared_ptr<Calls> calls_;
};

std::vector<Vec3> positions(const Garment& g) {
  std::vector<Vec3> out;
  for (Vertex v : g.mesh().vertices()) out.push_back(g.position(v));
  return out;
}

struct Scene {
  std::shared_ptr<Calls> calls = std::make_shared<Calls>();
  std::unique_ptr<Session> session;
  Scene() {
    auto registry = std::make_shared<ToolRegistry>();
    registry->add("hooked", [c = calls] { return std::make_unique<Hooked>(c); });
    session = std::make_unique<Session>(registry);
    session->add_garment(make_rectangle(1.0, 1.0, 11, 11));
    SolverParams p;
    p.gravity = Vec3(0, 0, 0);
    session->set_solver_params(p);
  }
  void stroke(const Vec3& a, const Vec3& b, int events = 10) {
    session->run("hooked", session->params_for("hooked"), test::line(a, b, events));
  }
};

}  // namespace

// What the tool reads is the session's, at the time of the event being applied.
TEST(ToolContext, ReadsTheSessionAtTheEventsTime) {
  Scene s;
  s.session->set_body(test::make_floor());
  s.session->set_pick_radius(0.2);
  int calls = 0;
  auto check = [&](ToolContext& c, const ToolEvent& e) {
    ++calls;
    EXPECT_EQ(c.garment_count(), 1u);
    EXPECT_EQ(&c.garment(0), &s.session->garment(0));
    EXPECT_EQ(&c.solver(0), &s.session->solver(0));
    EXPECT_EQ(c.body(), s.session->body());
    EXPECT_EQ(c.time(), s.session->time());
    EXPECT_NEAR(c.time(), e.time, 1.0 / 60);
    EXPECT_EQ(c.steps(), s.session->steps());
    EXPECT_EQ(c.frame_rate(), 60.0);
    EXPECT_EQ(c.pick_radius(), 0.2);
    EXPECT_EQ(c.solver_params().gravity, Vec3(0, 0, 0));
    const SurfaceHit hit = c.pick(e.position);
    EXPECT_TRUE(hit.hit);
    EXPECT_EQ(hit.nearest, e.hit.nearest);
    EXPECT_EQ(hit.point, e.hit.point);
  };
  s.calls->begin = check;
  s.calls->update = check;
  s.calls->end = check;
  s.stroke(Vec3(0.5, 0.5, 0.01), Vec3(0.6, 0.5, 0.01), 5);
  EXPECT_EQ(calls, 6);
}

// A hand holds the cloth while the stroke lasts and pulls it along; the local region keeps the rest
// of the cloth where it is; both end with the stroke, and the solver has the session's parameters.
TEST(ToolContext, AHandAndALocalRegionHoldTheClothWhileTheStrokeLasts) {
  Scene s;
  SolverParams own;
  own.gravity = Vec3(0, 0, -9.81);  // across the cloth, which lies in the plane z = 0
  own.local_radius = 5.0;  // the session's own region: everything within 5 m of (1, 2, 3)
  own.local_center = Vec3(1, 2, 3);
  s.session->set_solver_params(own);
  Garment& g = s.session->garment(0);
  const Vertex held(60), far(0);  // the middle vertex of the 11 x 11 grid; a corner
  const Vec3 held_at = g.position(held), far_at = g.position(far);
  int hand = -1;
  s.calls->begin = [&](ToolContext& c, const ToolEvent& e) {
    ASSERT_EQ(e.hit.nearest, held);
    hand = c.attach(0, held, e.position, 500.0);
    c.set_local_region(0, e.position, 0.25);
  };
  s.calls->update = [&](ToolContext& c, const ToolEvent& e) {
    c.move(0, hand, e.position);
    c.set_local_region(0, e.position, 0.25);
    EXPECT_EQ(c.solver(0).attachment_count(), 1u);
    EXPECT_EQ(c.solver(0).params().local_radius, 0.25);
    EXPECT_EQ(c.solver(0).params().local_center, e.position);
  };
  s.calls->end = [&](ToolContext& c, const ToolEvent&) {
    c.release(0, hand);
    c.end_local_region(0);
  };
  s.stroke(held_at, held_at + Vec3(0, 0, 0.2), 30);

  // The cloth beyond the region is held, so the hand lifts a membrane fixed on a 0.25 m circle:
  // 5 % of stretch (the strain limit) lets its middle come about 8 cm out of its plane.
  EXPECT_GT(g.position(held).z(), 0.06) << "the hand pulled the cloth along";
  EXPECT_EQ(g.position(far), far_at) << "outside the local region the cloth did not fall";
  const Solver& solver = s.session->solver(0);
  EXPECT_EQ(solver.attachment_count(), 0u);
  EXPECT_EQ(solver.params().local_radius, 5.0);
  EXPECT_EQ(solver.params().local_center, Vec3(1, 2, 3));
}

// A force on a vertex moves it in the next step only.
TEST(ToolContext, AForcePushesTheClothForTheNextStep) {
  Scene s;
  Garment& g = s.session->garment(0);
  const Vertex v(60);
  const Vec3 start = g.position(v);
  s.calls->begin = [&](ToolContext& c, const ToolEvent&) { c.add_force(0, v, Vec3(0, 0, 2.0)); };
  s.stroke(start, start, 1);
  s.session->step();
  EXPECT_GT(g.position(v).z(), start.z());
}

// What a tool gets wrong is an InputError saying what was wrong; the stroke is undone and the session
// goes on.
TEST(ToolContext, BadInputIsAnInputErrorAndTheStrokeIsUndone) {
  struct Case {
    std::function<void(ToolContext&)> call;
    std::string expect;
  };
  const Case cases[] = {
      {[](ToolContext& c) { c.garment(3); }, "garment 3 does not exist: the session has 1"},
      {[](ToolContext& c) { c.attach(2, Vertex(0), Vec3::Zero(), 1.0); }, "garment 2 does not exist"},
      {[](ToolContext& c) { c.attach(0, Vertex(500), Vec3::Zero(), 1.0); },
       "takes vertex 500, which the garment does not have"},
      {[](ToolContext& c) { c.attach(0, Vertex(5), Vec3(0, std::nan(""), 0), 1.0); }, "target point is not finite"},
      {[](ToolContext& c) { c.attach(0, Vertex(5), Vec3::Zero(), -1.0); }, "stiffness is -1"},
      {[](ToolContext& c) { c.add_force(0, Vertex(500), Vec3::Zero()); }, "pushes vertex 500"},
      {[](ToolContext& c) { c.add_force(0, Vertex(5), Vec3(HUGE_VAL, 0, 0)); }, "force on the cloth is not finite"},
      {[](ToolContext& c) { c.set_local_region(0, Vec3::Zero(), -0.5); }, "'local_radius' is -0.5"},
      {[](ToolContext& c) { c.set_local_region(0, Vec3(std::nan(""), 0, 0), 0.5); }, "'local_center'"},
  };
  for (const Case& k : cases) {
    Scene s;
    const std::vector<Vec3> before = positions(s.session->garment(0));
    s.calls->begin = [&](ToolContext& c, const ToolEvent&) {
      c.garment(0).set_position(Vertex(60), Vec3(9, 9, 9));  // half-done, and to be undone
      k.call(c);
    };
    try {
      s.stroke(Vec3(0.5, 0.5, 0), Vec3(0.5, 0.5, 0.1));
      ADD_FAILURE() << "no error, expected: " << k.expect;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(k.expect), std::string::npos) << e.what();
    }
    EXPECT_FALSE(s.session->stroke_active());
    EXPECT_EQ(positions(s.session->garment(0)), before);
    EXPECT_EQ(s.session->solver(0).attachment_count(), 0u);
    s.calls->begin = nullptr;
    s.stroke(Vec3(0.5, 0.5, 0), Vec3(0.5, 0.5, 0.1));  // the session goes on
    EXPECT_EQ(s.session->journal().entries().size(), 2u);
  }
}
