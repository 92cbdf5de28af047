// Force feedback at the rate a hand feels: a haptic loop on its own thread at 1 kHz, reading the
// device, asking the active tool for a force on a small snapshot of the cloth near the pointer, and
// writing the force back, while the simulation runs at 60 Hz on another thread.
//
// The loop never touches the session: the simulation publishes a HapticSnapshot after each step
// (publish_snapshot), and the loop reads the latest one without locking (an atomic shared pointer).
#pragma once

#include "kiji/tool.h"
#include "kiji/tool_event.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <variant>
#include <vector>

namespace kiji {

class Session;

// The cloth near the pointer, as it was after a simulation step.
struct HapticSnapshot {
  double time = 0;
  std::size_t garment = 0;
  Vec3 center{0, 0, 0};
  double radius = 0;
  std::vector<Vertex> vertices;             // the vertices within radius of center, in index order
  std::vector<Vec3> positions;              // their positions
  std::vector<std::array<int, 3>> triangles;  // faces whose three vertices are all in, as local indices

  // Where `v` was, or nullptr if it is not in the snapshot (a binary search of `vertices`).
  const Vec3* position_of(Vertex v) const;
  // The snapshot's cloth surface point nearest p (hit = false if the snapshot has no triangle).
  SurfaceHit nearest(const Vec3& p) const;
};

// Force models the haptic loop computes by itself from a snapshot: what a tool declares when its own
// code cannot answer a thousand times a second (a tool written in Python).
// The grabbed cloth pulls the hand, as pinch's spring does: the sum over the grabbed vertices of
// (stiffness / n) (x_v - offset_v - pointer), each vertex held at the offset from the pointer at
// which it was taken. Vertices the snapshot does not hold add nothing.
struct HapticSpring {
  std::size_t garment = 0;
  std::vector<Vertex> vertices;  // sorted
  std::vector<Vec3> offsets;     // vertex - pointer when taken, one a vertex
  double stiffness = 0;          // N/m in all, shared among the vertices
};
// The cloth pushes the pen back out along its normal, as paint's touch does: stiffness (touch - d) n
// when the pen is within `touch` metres of the snapshot's surface, on whichever side it is.
struct HapticPush {
  double touch = 0.005;     // m
  double stiffness = 300;   // N/m
};
using HapticModel = std::variant<std::monostate, HapticSpring, HapticPush>;
// The model's force for a pointer; none for std::monostate.
Feedback haptic_model_force(const HapticModel& model, const HapticSnapshot& snapshot, const ToolEvent& event);

// Takes the snapshot of garment `g` of the session around `center`.
HapticSnapshot take_snapshot(const Session& session, std::size_t garment, const Vec3& center, double radius);

// A haptic pointing device, in the manner of CHAI3D's generic device. The base class is a harmless
// null device that stays at the origin and ignores forces.
class InputDevice {
 public:
  virtual ~InputDevice() = default;
  virtual std::string name() const { return "null device"; }
  // Reads the device's current state (position in world metres, orientation, buttons).
  virtual ToolEvent sample() { return ToolEvent{}; }
  // The force the device should render, already clamped to max_force().
  virtual void set_force(const Vec3& force) {}
  virtual double max_force() const { return 3.3; }  // newtons (a Phantom Omni's peak)
};

// A device that plays back a path (for tests, benchmarks and replay): sample() returns the point of
// the path at the time elapsed since the loop started, and it records the forces it was sent.
class ScriptedDevice : public InputDevice {
 public:
  // `path(t)` gives the pointer at t seconds.
  explicit ScriptedDevice(std::function<ToolEvent(double)> path);
  std::string name() const override { return "scripted device"; }
  ToolEvent sample() override;
  void set_force(const Vec3& force) override;
  Vec3 last_force() const;
  std::size_t forces_received() const { return forces_.load(); }

 private:
  std::function<ToolEvent(double)> path_;
  std::chrono::steady_clock::time_point start_;
  mutable std::mutex mutex_;
  Vec3 last_force_ = Vec3::Zero();
  std::atomic<std::size_t> forces_{0};
};

// Timing of the haptic loop, for benchmarks and the app's status line.
struct HapticStats {
  std::size_t ticks = 0;
  double rate_hz = 0;           // achieved ticks per second
  double period_jitter_us = 0;  // standard deviation of the period
  double force_median_us = 0;   // time of the tool's force callback
  double force_p99_us = 0;
  // The loop's thread runs at real-time priority (SCHED_FIFO, the lowest such), above the
  // simulation's threads: on two cores busy with a 20,000-vertex simulation its period wavered by
  // 120-520 us (standard deviation) without it and 9-62 us with it. A user without the right to it
  // (root, CAP_SYS_NICE, or an `rtprio` limit in /etc/security/limits.conf) gets a normal thread,
  // and false here.
  bool realtime = false;
};

class HapticLoop {
 public:
  HapticLoop(InputDevice& device, double rate_hz = 1000.0);
  ~HapticLoop();  // stops the thread
  HapticLoop(const HapticLoop&) = delete;
  HapticLoop& operator=(const HapticLoop&) = delete;

  // The tool whose haptic_force is asked (nullptr: no force). Set from the simulation thread.
  void set_tool(const Tool* tool);
  // A new snapshot for the loop to read (called by the simulation thread after each step).
  void publish(std::shared_ptr<const HapticSnapshot> snapshot);
  // The latest device sample (for the simulation thread to turn into ToolEvents at its own rate).
  // Valid from the moment start() returns: start() waits for the loop's first sample, so the
  // simulation never reads a default event (a pointer at the origin) as where the hand is.
  ToolEvent latest_sample() const;

  void start();
  void stop();
  bool running() const { return running_.load(); }
  HapticStats stats() const;

 private:
  void run();

  InputDevice& device_;
  double rate_hz_;
  std::atomic<const Tool*> tool_{nullptr};
  std::shared_ptr<const HapticSnapshot> snapshot_;  // accessed with std::atomic_load/store
  std::atomic<bool> running_{false};
  std::atomic<bool> realtime_{false};
  std::thread thread_;
  mutable std::mutex sample_mutex_;
  std::condition_variable sampled_cv_;
  bool sampled_ = false;  // the loop has stored its first sample (guarded by sample_mutex_)
  ToolEvent sample_;
  mutable std::mutex stats_mutex_;
  std::vector<double> periods_us_, force_us_;
  std::size_t ticks_ = 0;
  double elapsed_s_ = 0;
};

}  // namespace kiji
