// The simulation thread of an interactive session: frames for the UI, strokes from a device, work
// from other threads, and a session that stays whole when something fails.
#include "kiji/journal_file.h"
#include "kiji/pattern.h"
#include "kiji/session.h"
#include "kiji/simulation_loop.h"

#include "support/wait.h"

#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <stdexcept>
#include <thread>

using namespace kiji;

namespace {

std::shared_ptr<ToolRegistry> plugins() {
  static auto r = [] {
    auto reg = std::make_shared<ToolRegistry>();
    reg->load_plugins({KIJI_PLUGIN_DIR});
    reg->add("explode", [] {
      struct Explode : Tool {
        ToolInfo info() const override { return {"explode", "Explode", "throws as the stroke begins", {}}; }
        Feedback begin(ToolContext&, const ParamSet&, const ToolEvent&) override {
          throw std::runtime_error("the tool's own bug");
        }
        Feedback update(ToolContext&, const ToolEvent&) override { return {}; }
        void end(ToolContext&, const ToolEvent&) override {}
        void cancel(ToolContext&) override {}
      };
      return std::make_unique<Explode>();
    });
    return reg;
  }();
  return r;
}

void sleep_ms(int ms) { std::this_thread::sleep_for(std::chrono::milliseconds(ms)); }

using test::wait_until;

// A 1 m square, vertices 0.05 apart, held at two corners: flat (in the z = 0 plane) it would hang
// still from them, so it is laid level (in the plane y = 1) and swings down.
std::shared_ptr<Session> hanging_cloth() {
  auto s = std::make_shared<Session>(plugins());
  Garment g = make_rectangle(1.0, 1.0, 21, 21);
  for (Vertex v : g.mesh().vertices())
    if (g.position(v).y() > 0.999 && (g.position(v).x() < 0.001 || g.position(v).x() > 0.999)) g.set_pinned(v, true);
  g.transform(Eigen::Translation3d(0, 1, 0) * Eigen::AngleAxisd(-M_PI / 2, Vec3::UnitX()) * Eigen::Translation3d(0, -1, 0));
  s->add_garment(std::move(g));
  return s;
}

Vec3 frame_point(const GarmentFrame& g, std::size_t render_vertex) {
  return Vec3(g.positions[3 * render_vertex], g.positions[3 * render_vertex + 1], g.positions[3 * render_vertex + 2]);
}

}  // namespace

TEST(SceneFrame, HoldsWhatAViewportDrawsOfTheGarment) {
  Session s(plugins());
  s.add_garment(make_rectangle(1.0, 1.0, 21, 21));
  SceneFrameBuilder builder;
  const auto f = builder.build(s, true);
  ASSERT_EQ(f->garments.size(), 1u);
  const GarmentFrame& g = f->garments[0];
  const GarmentTopology& t = *g.topology;
  EXPECT_EQ(t.mesh_vertex.size(), 441u) << "a flat pattern has one uv a vertex: no vertex is drawn twice";
  EXPECT_EQ(t.triangles.size(), 3u * 800);
  EXPECT_EQ(t.edges.size(), 2u * s.garment(0).mesh().number_of_edges());
  EXPECT_EQ(t.points.size(), 441u);
  EXPECT_EQ(f->vertices, 441u);
  EXPECT_EQ(f->faces, 800u);
  for (std::size_t i = 0; i < t.mesh_vertex.size(); ++i) {
    const Vec3 p = s.garment(0).position(Vertex(t.mesh_vertex[i]));
    ASSERT_TRUE(frame_point(g, i).isApprox(p, 1e-6));
    ASSERT_NEAR(std::abs(g.normals[3 * i + 2]), 1.0f, 1e-6) << "the flat cloth faces +z or -z";
  }
  EXPECT_TRUE(g.bounds.sizes().isApprox(Vec3(1, 1, 0)));
  EXPECT_EQ(g.texture, nullptr);

  // Unchanged topology and texture are shared with the next frame; a paint stroke makes a texture,
  // and a cut a new topology.
  const auto f2 = builder.build(s, false);
  EXPECT_EQ(f2->garments[0].topology, g.topology);
  ParamSet paint = s.params_for("paint", {{"resolution", 64LL}});
  s.run("paint", paint, Stroke{[] { ToolEvent e; e.phase = Phase::Begin; e.position = Vec3(0.5, 0.5, 0.001); return e; }()});
  const auto f3 = builder.build(s, true);
  ASSERT_NE(f3->garments[0].texture, nullptr);
  EXPECT_EQ(f3->garments[0].texture->width, 64);
  const auto f4 = builder.build(s, true);
  EXPECT_EQ(f4->garments[0].texture, f3->garments[0].texture) << "compared, found equal, shared";
  Stroke cut;
  for (int i = 0; i <= 20; ++i) {
    ToolEvent e;
    e.phase = i == 0 ? Phase::Begin : (i == 20 ? Phase::End : Phase::Move);
    e.position = Vec3(-0.05 + 1.1 * i / 20.0, 0.52, 0.001);
    cut.push_back(e);
  }
  s.run("cut", s.params_for("cut"), cut);
  ASSERT_EQ(s.garment(0).count_pieces(), 2u);
  const auto f5 = builder.build(s, false);
  EXPECT_NE(f5->garments[0].topology, f4->garments[0].topology);
  EXPECT_GT(f5->garments[0].topology->mesh_vertex.size(), 441u) << "the cut's new vertices are drawn";
}

TEST(SimulationLoop, PublishesFramesOfTheFallingClothAtItsRate) {
  auto s = hanging_cloth();
  SimulationLoop loop(s, 60);
  loop.start();
  const auto first = loop.frame();
  ASSERT_NE(first, nullptr);
  // A busy machine may run it slower than 60 steps a second; it keeps publishing as it steps.
  ASSERT_TRUE(wait_until([&] { return loop.frame()->number > first->number + 10 && loop.frame()->time > 0.2; }))
      << "frames stopped at " << loop.frame()->number;
  const auto later = loop.frame();
  loop.stop();
  // The cloth swings down under gravity from its corners.
  EXPECT_LT(later->garments[0].bounds.min().y(), first->garments[0].bounds.min().y() - 0.01);
  EXPECT_GT(loop.stats().steps, 10u);
}

TEST(SimulationLoop, TheUIReadsFramesWhileTheSessionIsHeldElsewhere) {
  auto s = hanging_cloth();
  SimulationLoop loop(s, 60);
  loop.start();
  std::uint64_t held_at = 0, after_hold = 0;
  {
    auto lock = loop.hold();  // a script console runs a statement
    held_at = loop.frame()->number;
    // From another thread, as the UI would: frame() answers while the session is held.
    auto read = std::async(std::launch::async, [&] { return loop.frame()->number; });
    ASSERT_EQ(read.wait_for(std::chrono::seconds(2)), std::future_status::ready);
    sleep_ms(100);
    after_hold = loop.frame()->number;
  }
  EXPECT_LE(after_hold, held_at + 1) << "the loop waits while the session is held";
  ASSERT_TRUE(wait_until([&] { return loop.frame()->number > after_hold + 3; })) << "and goes on after";
}

TEST(SimulationLoop, WorkRunsInOrderAndItsFailureIsAMessage) {
  auto s = hanging_cloth();
  SimulationLoop loop(s, 60);
  loop.start();
  std::vector<int> order;
  loop.post([&](Session&) { order.push_back(1); });
  loop.post([&](Session&) { throw InputError("frame rate 0 is out of range"); }, "set the frame rate");
  loop.post([&](Session&) { order.push_back(3); });
  loop.call([&](Session&) { order.push_back(4); });
  EXPECT_EQ(order, (std::vector<int>{1, 3, 4}));
  const auto messages = loop.take_messages();
  ASSERT_EQ(messages.size(), 1u);
  EXPECT_EQ(messages[0], "set the frame rate: frame rate 0 is out of range");
  EXPECT_THROW(loop.call([](Session& session) { session.garment(7); }), InputError);
  EXPECT_TRUE(loop.running());
}

TEST(SimulationLoop, ADevicesButtonsMakeAStrokeOfTheChosenTool) {
  auto s = hanging_cloth();
  {
    auto lock = std::lock_guard<std::recursive_mutex>(s->mutex());
    s->set_simulating(false);  // the cloth stays where the pen finds it
  }
  // The pen presses on the cloth's middle at 0.1 s, pulls it 0.1 m up, lets go at 0.4 s.
  ScriptedDevice device([](double t) {
    ToolEvent e;
    const double u = std::clamp((t - 0.1) / 0.25, 0.0, 1.0);
    e.position = Vec3(0.5, 1.0 + 0.1 * u, 0.5);
    e.buttons = (t > 0.1 && t < 0.4) ? kButtonPrimary : 0u;
    return e;
  });
  HapticLoop haptics(device);
  SimulationLoop loop(s, 60);
  loop.set_tool(kButtonPrimary, "pinch", s->params_for("pinch", {{"stiffness", 500.0}}));
  loop.attach(&haptics);
  haptics.start();
  loop.start();
  ASSERT_TRUE(wait_until([&] { return device.forces_received() > 600; }));
  loop.stop();
  haptics.stop();
  const std::vector<JournalStroke> strokes = journal_strokes(s->journal());
  ASSERT_EQ(strokes.size(), 1u);
  const JournalStroke& stroke = strokes[0];
  EXPECT_EQ(stroke.tool, "pinch");
  EXPECT_GT(stroke.events.size(), 5u);
  EXPECT_EQ(stroke.events.front().phase, Phase::Begin);
  EXPECT_EQ(stroke.events.back().phase, Phase::End);
  const JournalEntry& entry = s->journal().entries().back();
  EXPECT_TRUE(entry.events.front().hit.hit) << "the pen pressed on the cloth";
  EXPECT_EQ(std::get<double>(stroke.params.at("stiffness")), 500.0) << "the panel's parameters";
}

TEST(SimulationLoop, AToolThatFailsLeavesTheSessionAsItWasAndTheLoopRunning) {
  auto s = hanging_cloth();
  ScriptedDevice device([](double t) {
    ToolEvent e;
    e.position = Vec3(0.5, 1.0, 0.5);
    // Held from 0.05 s on, not for a window a slow start could miss: the tool fails at its begin.
    e.buttons = t > 0.05 ? kButtonPrimary : 0u;
    return e;
  });
  HapticLoop haptics(device);
  SimulationLoop loop(s, 60);
  loop.set_tool(kButtonPrimary, "explode", ParamSet{});
  loop.attach(&haptics);
  haptics.start();
  loop.start();
  std::vector<std::string> messages;
  ASSERT_TRUE(wait_until([&] {
    for (auto& m : loop.take_messages()) messages.push_back(m);
    return !messages.empty();
  }));
  const std::uint64_t n = loop.frame()->number;
  EXPECT_TRUE(wait_until([&] { return loop.frame()->number > n + 3; })) << "the loop goes on";
  loop.stop();
  haptics.stop();
  EXPECT_NE(messages[0].find("'explode' stroke: the tool's own bug"), std::string::npos) << messages[0];
  EXPECT_FALSE(s->stroke_active());
  EXPECT_TRUE(journal_strokes(s->journal()).empty());
}

TEST(SimulationLoop, APausedSessionKeepsItsClothStill) {
  auto s = hanging_cloth();
  SimulationLoop loop(s, 60);
  loop.start();
  loop.call([](Session& session) { session.set_simulating(false); });
  const auto a = loop.frame();
  const std::uint64_t ticks = loop.stats().steps;
  ASSERT_TRUE(wait_until([&] { return loop.stats().steps > ticks + 5; }));
  const auto b = loop.frame();
  EXPECT_FALSE(b->simulating);
  EXPECT_EQ(a->garments[0].positions, b->garments[0].positions);
  EXPECT_EQ(b->number, a->number) << "nothing changed: no new frame for the UI to draw";
  loop.call([](Session& session) { session.set_simulating(true); });
  ASSERT_TRUE(wait_until([&] { return loop.frame()->number > b->number + 3; })) << "and frames again once it runs";
}

TEST(SimulationLoop, WorkThatShowsItsProgressHasItsLastChangeShownToo) {
  // As Kiji Studio's drape: long work publishes frames as it goes, then changes the garment once more
  // (the coarse drape sets the draped garment at its end); a paused scene must still show that.
  auto s = hanging_cloth();
  SimulationLoop loop(s, 60);
  loop.start();
  loop.call([](Session& session) { session.set_simulating(false); });
  std::atomic<bool> done{false};
  loop.post([&](Session& session) {
    loop.publish_now();
    Garment g = session.garment(0);
    for (Vertex v : g.mesh().vertices()) g.set_position(v, g.position(v) + Vec3(0, 0, 0.5));
    session.set_garment(0, g);
    done = true;
  }, "move");
  ASSERT_TRUE(wait_until([&] { return done.load(); }));
  double z;
  {
    std::lock_guard<std::recursive_mutex> lock(s->mutex());
    z = s->garment(0).bounds().max().z();
  }
  ASSERT_TRUE(wait_until([&] {
    const auto f = loop.frame();
    return f && std::abs(f->garments[0].bounds.max().z() - z) < 1e-6;
  })) << "the frame still shows the garment as the work's progress frame had it";
}

TEST(SimulationLoop, ASharedSessionIsSteppedByItsPeerAndTheDevicesStrokesAreProposed) {
  auto s = hanging_cloth();
  // A stand-in for a peer: the gate collects what the session's user does; the "network" thread
  // applies it a few steps later, in order, and alone steps the clock.
  std::vector<Operation> proposed;
  int gate_owner = 0;
  {
    std::lock_guard<std::recursive_mutex> lock(s->mutex());
    s->set_simulating(false);  // the cloth stays where the pen finds it
    s->set_gate([&](const Operation& op) { proposed.push_back(op); }, &gate_owner);
  }
  std::atomic<bool> peer_running{true};
  std::atomic<std::uint64_t> peer_steps{0};
  std::size_t applied = 0;
  std::thread peer([&] {
    while (peer_running.load()) {
      {
        std::lock_guard<std::recursive_mutex> lock(s->mutex());
        for (; applied < proposed.size(); ++applied) s->perform(proposed[applied]);
        s->step(&gate_owner);
        ++peer_steps;
      }
      sleep_ms(16);
    }
  });
  ScriptedDevice device([](double t) {
    ToolEvent e;
    const double u = std::clamp((t - 0.1) / 0.25, 0.0, 1.0);
    e.position = Vec3(0.5, 1.0 + 0.1 * u, 0.5);
    e.buttons = (t > 0.1 && t < 0.4) ? kButtonPrimary : 0u;
    return e;
  });
  HapticLoop haptics(device);
  SimulationLoop loop(s, 60);
  loop.set_tool(kButtonPrimary, "pinch", s->params_for("pinch", {{"stiffness", 500.0}}));
  loop.attach(&haptics);
  haptics.start();
  loop.start();
  ASSERT_TRUE(wait_until([&] { return device.forces_received() > 600; }));
  const auto shared_frame = loop.frame();
  std::uint64_t steps_shared = 0, stepped_by_peer = 0;
  {
    auto lock = loop.hold();
    steps_shared = s->steps();
    stepped_by_peer = peer_steps.load();
    EXPECT_TRUE(s->stroke_tool().empty()) << "the stroke ended with the button";
    EXPECT_EQ(applied, proposed.size());
  }
  EXPECT_EQ(steps_shared, stepped_by_peer) << "every step of the shared clock was the peer's";
  EXPECT_TRUE(loop.take_messages().empty()) << "the loop neither stepped nor failed while shared";
  const std::vector<JournalStroke> strokes = journal_strokes(s->journal());
  ASSERT_EQ(strokes.size(), 1u) << "the pen's stroke went through the gate and was applied in its turn";
  EXPECT_EQ(strokes[0].events.front().phase, Phase::Begin);
  EXPECT_EQ(strokes[0].events.back().phase, Phase::End);
  EXPECT_GT(strokes[0].events.size(), 5u);
  // The frames stop once the paused cloth is still, so their clock is where the peer's was then.
  EXPECT_GT(shared_frame->time, 0.0) << "the frames follow the clock the peer steps";
  EXPECT_LE(shared_frame->time, steps_shared / 60.0 + 1e-9) << "and no clock of the loop's own";

  // The peer goes: the session is the user's again, and the loop steps it.
  peer_running = false;
  peer.join();
  {
    auto lock = loop.hold();
    s->clear_gate();
  }
  ASSERT_TRUE(wait_until([&] {
    auto lock = loop.hold();
    return s->steps() > steps_shared + 5;
  }));
  loop.stop();
  haptics.stop();
}
