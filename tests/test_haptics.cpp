// The haptic loop: a device on its own thread, forces from the active tool on the latest snapshot.
#include "kiji/haptics.h"
#include "kiji/pattern.h"
#include "kiji/session.h"

#include <gtest/gtest.h>

#include <pthread.h>
#include <sched.h>

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

void wait_for(const ScriptedDevice& d, std::size_t forces) {
  for (int i = 0; i < 2000 && d.forces_received() < forces; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

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

TEST(HapticLoop, FeedsThePinchSpringBackToTheDevice) {
  Session s(plugins());
  s.add_garment(make_rectangle(1.0, 1.0, 21, 21));
  s.set_simulating(false);
  ParamSet p = s.params_for("pinch", {{"stiffness", 40.0}});
  s.apply("pinch", at(Vec3(0.5, 0.5, 0.0), Phase::Begin), &p);
  const Vec3 hand(0.5, 0.5, 0.05);
  ScriptedDevice device([&](double) { return at(hand); });
  HapticLoop loop(device);
  loop.set_tool(&s.tool("pinch"));
  loop.publish(std::make_shared<HapticSnapshot>(take_snapshot(s, 0, hand, 0.1)));
  loop.start();
  wait_for(device, 50);
  loop.stop();
  EXPECT_GE(device.forces_received(), 50u);
  // The spring pulls the hand back to the grabbed vertex at (0.5, 0.5, 0): 40 N/m * 0.05 m.
  // stop() leaves the device with no force; the last force of the loop was the spring's.
  const HapticStats stats = loop.stats();
  EXPECT_GE(stats.ticks, 50u);
  EXPECT_GT(stats.rate_hz, 0.0);
  EXPECT_GE(stats.force_p99_us, stats.force_median_us);
  const Feedback f = s.tool("pinch").haptic_force(take_snapshot(s, 0, hand, 0.1), at(hand));
  EXPECT_TRUE(f.force.isApprox(Vec3(0, 0, -2.0), 1e-12)) << f.force.transpose();
  s.apply("pinch", at(hand, Phase::End));
  EXPECT_EQ(s.tool("pinch").haptic_force(take_snapshot(s, 0, hand, 0.1), at(hand)).force, Vec3::Zero())
      << "no force once the stroke ends";
}

TEST(HapticLoop, ClampsToTheDevicesMaximumForce) {
  Session s(plugins());
  s.add_garment(make_rectangle(1.0, 1.0, 11, 11));
  s.set_simulating(false);
  ParamSet p = s.params_for("pinch", {{"stiffness", 1e5}});
  s.apply("pinch", at(Vec3(0.5, 0.5, 0.0), Phase::Begin), &p);
  const Vec3 hand(0.5, 0.5, 0.3);
  struct Recording : ScriptedDevice {
    using ScriptedDevice::ScriptedDevice;
    double largest = 0;
    void set_force(const Vec3& f) override {
      largest = std::max(largest, f.norm());
      ScriptedDevice::set_force(f);
    }
  } device([&](double) { return at(hand); });
  HapticLoop loop(device);
  loop.set_tool(&s.tool("pinch"));
  loop.publish(std::make_shared<HapticSnapshot>(take_snapshot(s, 0, Vec3(0.5, 0.5, 0), 0.5)));
  loop.start();
  wait_for(device, 20);
  loop.stop();
  EXPECT_GT(device.largest, 0.99 * device.max_force()) << "the spring asked for far more; the device got its most";
  EXPECT_LE(device.largest, device.max_force() + 1e-12);
  s.apply("pinch", at(hand, Phase::Cancel));
}
