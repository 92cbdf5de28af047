// The haptic loop: a device on its own thread, forces from the active tool on the latest snapshot,
// checked by what the device was sent, as the hand holding it would feel it.
#include "kiji/haptics.h"
#include "kiji/pattern.h"
#include "kiji/session.h"

#include "support/test_errors.h"

#include <gtest/gtest.h>

#include <pthread.h>
#include <sched.h>

#include <atomic>
#include <mutex>
#include <stdexcept>
#include <thread>

using namespace kiji;

namespace {

std::shared_ptr<ToolRegistry> plugins() {
  static auto r = [] {
    auto reg = std::make_shared<ToolRegistry>();
    reg->load_plugins({KIJI_PLUGIN_DIR});
    return reg;
  }();
  return r;
}

ToolEvent at(const Vec3& p, Phase phase = Phase::Move) {
  ToolEvent e;
  e.phase = phase;
  e.position = p;
  return e;
}

// A device that plays a path and keeps every force it was sent, in order.
class RecordingDevice : public ScriptedDevice {
 public:
  using ScriptedDevice::ScriptedDevice;
  void set_force(const Vec3& f) override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      forces_.push_back(f);
    }
    ScriptedDevice::set_force(f);
  }
  std::vector<Vec3> forces() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return forces_;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<Vec3> forces_;
};

void wait_for(const ScriptedDevice& d, std::size_t forces) {
  for (int i = 0; i < 5000 && d.forces_received() < forces; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

// The loop with nothing between the tool and the device but the clamp.
HapticOptions plain() {
  HapticOptions o;
  o.smoothing_s = 0;
  o.ramp_s = 0;
  return o;
}

// A session holding a pinched rectangle: the pinch took the vertex at (0.5, 0.5, 0) with a spring
// of `stiffness` N/m (the grid's vertices are 0.05 apart, wider than the grab radius: one vertex).
std::unique_ptr<Session> pinched(double stiffness) {
  auto s = std::make_unique<Session>(plugins());
  s->add_garment(make_rectangle(1.0, 1.0, 21, 21));
  s->set_simulating(false);
  ParamSet p = s->params_for("pinch", {{"stiffness", stiffness}});
  s->apply("pinch", at(Vec3(0.5, 0.5, 0.0), Phase::Begin), &p);
  return s;
}

// A tool whose force callback fails: it throws, or answers NaN.
class FailingTool : public Tool {
 public:
  explicit FailingTool(bool nan) : nan_(nan) {}
  ToolInfo info() const override { return {"failing", "Failing", "fails in its force callback", {}}; }
  Feedback begin(ToolContext&, const ParamSet&, const ToolEvent&) override { return {}; }
  Feedback update(ToolContext&, const ToolEvent&) override { return {}; }
  void end(ToolContext&, const ToolEvent&) override {}
  void cancel(ToolContext&) override {}
  Feedback haptic_force(const HapticSnapshot&, const ToolEvent&) const override {
    if (nan_) return {Vec3(std::nan(""), 0, 0), Vec3::Zero()};
    throw std::runtime_error("the cloth was not where the tool looked");
  }

 private:
  bool nan_;
};

}  // namespace

TEST(HapticSnapshot, HoldsTheClothNearThePointer) {
  Session s(plugins());
  s.add_garment(make_rectangle(1.0, 1.0, 21, 21));
  const HapticSnapshot snap = take_snapshot(s, 0, Vec3(0.5, 0.5, 0), 0.11);
  // Vertices 0.05 apart: within 0.11 of the centre lie the centre, 4 at 0.05, 4 at 0.0707,
  // 4 at 0.1 and 8 at 0.1118 > 0.11: 13 vertices.
  EXPECT_EQ(snap.vertices.size(), 13u);
  for (const Vec3& p : snap.positions) EXPECT_LE((p - Vec3(0.5, 0.5, 0)).norm(), 0.11);
  EXPECT_FALSE(snap.triangles.empty());
  const SurfaceHit hit = snap.nearest(Vec3(0.52, 0.49, 0.03));
  ASSERT_TRUE(hit.hit);
  EXPECT_NEAR(hit.distance, 0.03, 1e-12);
  EXPECT_NEAR(std::abs(hit.normal.z()), 1.0, 1e-12);
  EXPECT_EQ(snap.position_of(Vertex(0)), nullptr);
}

TEST(HapticLoop, LatestSampleIsTheDeviceFromTheMomentItStarts) {
  // The simulation thread reads the hand's position right after start(). A default event there
  // (a pointer at the origin) would drag a held garment metres in one step.
  const Vec3 hand(0.4, 1.6, -0.3);
  ScriptedDevice device([&](double) { return at(hand); });
  for (int run = 0; run < 20; ++run) {
    HapticLoop loop(device);
    loop.start();
    const ToolEvent first = loop.latest_sample();
    loop.stop();
    ASSERT_TRUE(first.position.isApprox(hand)) << "run " << run << ": " << first.position.transpose();
  }
}

TEST(HapticLoop, RunsAtRealTimePriorityWhereTheSystemAllowsIt) {
  // Whether this process may give a thread real-time priority, asked of a thread of its own.
  bool allowed = false;
  std::thread probe([&] {
    sched_param priority{};
    priority.sched_priority = sched_get_priority_min(SCHED_FIFO);
    allowed = pthread_setschedparam(pthread_self(), SCHED_FIFO, &priority) == 0;
  });
  probe.join();
  ScriptedDevice device([&](double) { return at(Vec3(0, 1, 0)); });
  HapticLoop loop(device);
  loop.start();
  wait_for(device, 20);
  loop.stop();
  const HapticStats stats = loop.stats();
  EXPECT_EQ(stats.realtime, allowed) << "the loop says what priority it got";
  EXPECT_GE(stats.ticks, 20u);
}

TEST(HapticLoop, TheDeviceGetsThePinchSpringForTheHandsPlaceAndNothingAfterRelease) {
  auto s = pinched(40.0);
  const Vec3 hand(0.5, 0.5, 0.05);
  RecordingDevice device([&](double) { return at(hand); });
  HapticLoop loop(device, plain());
  loop.set_tool(&s->tool("pinch"));
  loop.publish(std::make_shared<HapticSnapshot>(take_snapshot(*s, 0, hand, 0.1)));
  loop.start();
  wait_for(device, 50);
  // The spring pulls the hand back to the grabbed vertex at (0.5, 0.5, 0): 40 N/m * 0.05 m.
  const std::vector<Vec3> held = device.forces();
  ASSERT_GE(held.size(), 50u);
  for (const Vec3& f : held) ASSERT_TRUE(f.isApprox(Vec3(0, 0, -2.0), 1e-9)) << f.transpose();
  EXPECT_TRUE(loop.latest_force().isApprox(Vec3(0, 0, -2.0), 1e-9));

  s->apply("pinch", at(hand, Phase::End));  // the button is released
  const std::size_t released_at = device.forces_received();
  wait_for(device, released_at + 20);
  loop.stop();
  const std::vector<Vec3> all = device.forces();
  // The tick under way at the release may still send the spring; every one after it sends nothing.
  for (std::size_t i = released_at + 1; i < all.size(); ++i) ASSERT_EQ(all[i], Vec3::Zero()) << "force " << i;
  EXPECT_EQ(all.back(), Vec3::Zero()) << "stop() leaves the device with no force";
}

TEST(HapticLoop, NeverSendsMoreThanTheDevicesMaximum) {
  auto s = pinched(1e5);  // 30 kN at the hand's 0.3 m: far beyond any device
  const Vec3 hand(0.5, 0.5, 0.3);
  RecordingDevice device([&](double) { return at(hand); });
  HapticLoop loop(device);  // the default shaping: smoothed and ramped
  loop.set_tool(&s->tool("pinch"));
  loop.publish(std::make_shared<HapticSnapshot>(take_snapshot(*s, 0, Vec3(0.5, 0.5, 0), 0.5)));
  loop.start();
  wait_for(device, 1300);  // past the one-second ramp
  loop.stop();
  double largest = 0;
  for (const Vec3& f : device.forces()) {
    ASSERT_LE(f.norm(), device.max_force() + 1e-12);
    largest = std::max(largest, f.norm());
  }
  EXPECT_GT(largest, 0.99 * device.max_force()) << "the spring asked for far more; the device got its most";
}

TEST(HapticLoop, RampsForcesUpSmoothlyFromZero) {
  auto s = pinched(40.0);
  const Vec3 hand(0.5, 0.5, 0.05);  // 2 N asked from the first tick
  RecordingDevice device([&](double) { return at(hand); });
  HapticOptions o;
  o.ramp_s = 0.2;
  o.smoothing_s = 0.003;
  HapticLoop loop(device, o);
  loop.set_tool(&s->tool("pinch"));
  loop.publish(std::make_shared<HapticSnapshot>(take_snapshot(*s, 0, hand, 0.1)));
  loop.start();
  wait_for(device, 400);
  loop.stop();
  const std::vector<Vec3> f = device.forces();
  ASSERT_GE(f.size(), 400u);
  EXPECT_LT(f.front().norm(), 0.01) << "the first force is next to nothing, not the spring's 2 N";
  // Along the ramp (a smoothstep over 0.2 s) the force rises by at most 1.5 * 2 N / 0.2 s = 15 N/s:
  // 0.015 N a millisecond. A tick late by a few milliseconds may see a few times that, never a jump.
  for (std::size_t i = 1; i + 1 < f.size(); ++i) {
    ASSERT_LE((f[i] - f[i - 1]).norm(), 0.1) << "tick " << i;
    ASSERT_LE(f[i].norm(), 2.0 + 1e-9);
  }
  EXPECT_TRUE(f[f.size() - 2].isApprox(Vec3(0, 0, -2.0), 1e-6)) << "the full spring once the ramp is over";
}

TEST(HapticLoop, RampsAgainWhenTheDevicesWorkspaceMappingChanges) {
  auto s = pinched(40.0);
  const Vec3 hand(0.5, 0.5, 0.05);
  struct Remapped : RecordingDevice {
    using RecordingDevice::RecordingDevice;
    std::atomic<std::uint64_t> version{0};
    std::uint64_t workspace_version() const override { return version.load(); }
  } device([&](double) { return at(hand); });
  HapticOptions o = plain();
  o.ramp_s = 0.5;
  HapticLoop loop(device, o);
  loop.set_tool(&s->tool("pinch"));
  loop.publish(std::make_shared<HapticSnapshot>(take_snapshot(*s, 0, hand, 0.1)));
  loop.start();
  wait_for(device, 700);
  const std::size_t before = device.forces_received();
  device.version = 1;  // the user fitted the workspace to the body
  wait_for(device, before + 50);
  loop.stop();
  const std::vector<Vec3> f = device.forces();
  EXPECT_TRUE(f[before - 1].isApprox(Vec3(0, 0, -2.0), 1e-6));
  double least_after = 1e9;
  for (std::size_t i = before; i < before + 10; ++i) least_after = std::min(least_after, f[i].norm());
  EXPECT_LT(least_after, 0.05) << "the force starts again from next to nothing";
}

TEST(HapticLoop, AToolWhoseForceCallbackFailsCostsNothingButItsForce) {
  for (bool nan : {false, true}) {
    FailingTool tool(nan);
    RecordingDevice device([&](double) { return at(Vec3(0, 0, 0)); });
    HapticLoop loop(device, plain());
    loop.set_tool(&tool);
    loop.publish(std::make_shared<HapticSnapshot>());
    loop.start();
    wait_for(device, 30);
    loop.stop();  // the loop ran on: the process is alive and the loop stops as usual
    const HapticStats stats = loop.stats();
    EXPECT_GE(stats.tool_errors, 20u) << (nan ? "NaN" : "throw");
    EXPECT_NE(stats.last_error.find(nan ? "not a finite number" : "the cloth was not where the tool looked"),
              std::string::npos)
        << stats.last_error;
    for (const Vec3& f : device.forces()) ASSERT_EQ(f, Vec3::Zero());
  }
}

TEST(HapticLoop, ADeviceThatFailsIsReportedAndTheLoopGoesOn) {
  auto s = pinched(40.0);
  const Vec3 hand(0.5, 0.5, 0.05);
  struct Flaky : InputDevice {
    std::atomic<int> samples{0}, forces{0}, nonzero_after_failure{0};
    bool failed_last = false;
    ToolEvent sample() override {
      const int n = samples++;
      failed_last = n % 3 == 1;
      if (failed_last) throw std::runtime_error("USB read timed out");
      return at(Vec3(0.5, 0.5, 0.05));
    }
    void set_force(const Vec3& f) override {
      if (failed_last && f != Vec3::Zero()) ++nonzero_after_failure;
      if (forces++ % 5 == 4) throw std::runtime_error("USB write timed out");
    }
  } device;
  HapticLoop loop(device, plain());
  loop.set_tool(&s->tool("pinch"));
  loop.publish(std::make_shared<HapticSnapshot>(take_snapshot(*s, 0, hand, 0.1)));
  loop.start();
  for (int i = 0; i < 5000 && device.samples < 60; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  loop.stop();
  const HapticStats stats = loop.stats();
  EXPECT_GE(stats.device_errors, 20u);
  EXPECT_NE(stats.last_error.find("USB"), std::string::npos) << stats.last_error;
  EXPECT_EQ(device.nonzero_after_failure.load(), 0) << "a tick whose sample failed sends zero force";
  EXPECT_TRUE(loop.latest_sample().position.isApprox(hand)) << "the good samples still reach the simulation";
}

TEST(HapticLoop, AQuickPressAndReleaseReachTheSimulationAsTwoChanges) {
  // A click shorter than a simulation step (16 ms), as a mouse sends one: down for 3 ticks of the
  // 1 kHz loop. Counted in samples, not read from the clock: a loaded machine can wake the loop
  // later than a 3 ms window.
  std::atomic<int> samples{0};
  ScriptedDevice device([&](double) {
    const int k = samples++;
    ToolEvent e = at(Vec3(0.1, 0.2, 0.3));
    e.buttons = (k >= 20 && k < 23) ? kButtonPrimary : 0u;
    return e;
  });
  HapticLoop loop(device, plain());
  loop.start();
  wait_for(device, 60);
  loop.stop();
  const std::vector<ToolEvent> changes = loop.take_button_changes();
  ASSERT_EQ(changes.size(), 2u);
  EXPECT_EQ(changes[0].buttons, kButtonPrimary);
  EXPECT_EQ(changes[1].buttons, 0u);
  EXPECT_TRUE(changes[0].position.isApprox(Vec3(0.1, 0.2, 0.3)));
  EXPECT_TRUE(loop.take_button_changes().empty()) << "each change is taken once";
}

TEST(HapticLoop, OptionsOutOfRangeAreRefusedWithTheirName) {
  ScriptedDevice device([&](double) { return at(Vec3::Zero()); });
  HapticOptions o;
  o.force_gain = -1;
  EXPECT_NE(test::input_error([&] { HapticLoop loop(device, o); }).find("force gain"), std::string::npos);
  o = HapticOptions{};
  o.rate_hz = std::nan("");
  EXPECT_NE(test::input_error([&] { HapticLoop loop(device, o); }).find("rate"), std::string::npos);
  HapticLoop loop(device);
  EXPECT_NE(test::input_error([&] { loop.set_force_gain(11); }).find("force gain"), std::string::npos);
}
