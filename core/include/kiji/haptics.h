// Force feedback at the rate a hand feels: a haptic loop at 1 kHz (its own thread, or the device
// driver's servo loop), reading the device, asking the active tool for a force on a small snapshot
// of the cloth near the pointer, and writing the force back, while the simulation runs at 60 Hz on
// another thread.
//
// The loop never touches the session: the simulation publishes a HapticSnapshot after each step
// (publish), and the loop reads the latest one without locking (an atomic shared pointer). The
// snapshot and the force models tools share with the loop are in kiji/haptic_force.h.
#pragma once

#include "kiji/error.h"
#include "kiji/haptic_force.h"
#include "kiji/tool.h"
#include "kiji/tool_event.h"

#include <atomic>
#include <chrono>
#include <array>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace kiji {

class Session;

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
  // The force the device should render, in world axes, already clamped to max_force().
  virtual void set_force(const Vec3& force) {}
  // The largest force the loop sends (newtons): for a Phantom, its nominal continuous maximum.
  virtual double max_force() const { return 3.3; }  // a Phantom Omni's peak

  // A device whose driver runs its own servo loop (OpenHaptics' scheduler) calls `tick` from that
  // loop once a period, between reading the device and writing its force; the haptic loop then runs
  // no thread of its own. Others are polled by the haptic loop's thread. start_servo_loop throws
  // DeviceError when the driver's loop cannot start.
  virtual bool has_servo_loop() const { return false; }
  virtual void start_servo_loop(std::function<void()> tick) {}
  virtual void stop_servo_loop() {}

  // The device's usable workspace in its own axes, metres (empty: it has none, as a mouse).
  virtual Box3 workspace() const { return Box3(); }
  // Changes whenever the device's mapping into the world changes, so that the haptic loop ramps its
  // forces up again: the pen must not jump when the same force means a new place.
  virtual std::uint64_t workspace_version() const { return 0; }
};

// A device driver refused or failed: the message names the call, the driver's error code and its
// own description, and what to do. The session is never affected.
class DeviceError : public Error {
 public:
  DeviceError(const std::string& message, unsigned code = 0) : Error(message), code_(code) {}
  unsigned code() const { return code_; }  // the driver's error code (0: none, e.g. no library)

 private:
  unsigned code_;
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

// How the haptic loop shapes the force it sends. The tool's force is a virtual coupling: a spring
// from the pen to the cloth as the last simulation step left it (the snapshot), so between two
// steps, a frame apart, it jumps where the cloth jumped. The loop low-pass filters it, clamps it to
// the device's maximum, and ramps it up from zero after start and after a change of the device's
// workspace mapping, so the pen never jumps in the hand.
struct HapticOptions {
  double rate_hz = 1000;     // ticks a second of the loop's own thread (a servo-driven device keeps its own)
  double force_gain = 1.0;   // the tool's force is multiplied by this (0 to 10)
  double smoothing_s = 0.003;  // time constant of the force's low-pass filter, seconds (0: none)
  double ramp_s = 1.0;       // seconds (of ticks at rate_hz) to ramp forces from zero to full (0: none)
  // Throws InputError naming the option out of range.
  void validate() const;
};

// Timing of the haptic loop, for benchmarks and the app's status line.
struct HapticStats {
  std::size_t ticks = 0;
  double rate_hz = 0;           // achieved ticks per second
  double period_jitter_us = 0;  // standard deviation of the period
  double force_median_us = 0;   // time of the tool's force callback
  double force_p99_us = 0;
  // The loop's thread runs at real-time priority (SCHED_FIFO, the lowest such), above the
  // simulation's threads, which would otherwise take the cores it needs and make its period waver
  // by a tenth of it or more (docs/benchmarks.md). A user without the right to it
  // (root, CAP_SYS_NICE, or an `rtprio` limit in /etc/security/limits.conf) gets a normal thread,
  // and false here. A servo-driven device's loop runs at its driver's priority.
  bool realtime = false;
  // Failures caught in the loop: each tick they happen in sends zero force instead, and the loop
  // goes on. A tool's force callback that threw or returned a non-finite force; a device whose
  // sample or set_force threw.
  std::size_t tool_errors = 0;
  std::size_t device_errors = 0;
  std::string last_error;  // the latest one's message (empty: none)
};

class HapticLoop {
 public:
  explicit HapticLoop(InputDevice& device, double rate_hz = 1000.0);
  HapticLoop(InputDevice& device, const HapticOptions& options);  // validates the options
  ~HapticLoop();  // stops the loop
  HapticLoop(const HapticLoop&) = delete;
  HapticLoop& operator=(const HapticLoop&) = delete;

  // The tool whose haptic_force is asked (nullptr: no force). Set from the simulation thread.
  void set_tool(const Tool* tool);
  // Returns once no tick still uses a tool or snapshot set before the call (a tick under way
  // finishes): after set_tool(nullptr) and this, the old tool may be destroyed.
  void quiesce() const;
  // A new snapshot for the loop to read (called by the simulation thread after each step).
  void publish(std::shared_ptr<const HapticSnapshot> snapshot);
  // The latest device sample (for the simulation thread to turn into ToolEvents at its own rate).
  // Valid from the moment start() returns: start() waits for the loop's first sample, so the
  // simulation never reads a default event (a pointer at the origin) as where the hand is.
  ToolEvent latest_sample() const;
  // The force last sent to the device (world axes, newtons).
  Vec3 latest_force() const;
  // The samples at which the device's buttons changed since the last call, oldest first: a press
  // and release quicker than a simulation step still reach it as two events. Up to 256 are kept.
  std::vector<ToolEvent> take_button_changes();
  // The force gain (0 to 10) from now on; throws InputError out of range.
  void set_force_gain(double gain);

  // Starts the loop: the device's own servo loop if it has one, else a thread at rate_hz. Throws
  // DeviceError if the device's servo loop fails to start or never ticks (within 2 s).
  void start();
  // Stops it; the device's last force is zero.
  void stop();
  bool running() const { return running_.load(); }
  HapticStats stats() const;

 private:
  void run();
  void tick();
  Vec3 shape(Vec3 force);
  void note_error(std::atomic<std::size_t>& counter, const std::string& message);

  InputDevice& device_;
  HapticOptions options_;
  std::atomic<double> force_gain_;
  std::atomic<const Tool*> tool_{nullptr};
  std::shared_ptr<const HapticSnapshot> snapshot_;  // accessed with std::atomic_load/store
  std::atomic<bool> running_{false};
  std::atomic<bool> realtime_{false};
  std::thread thread_;

  // The latest sample and force, written by the ticking thread when it can take the lock at once
  // (a tick never waits), read by the others.
  mutable std::mutex sample_mutex_;
  std::condition_variable sampled_cv_;
  bool sampled_ = false;  // the loop has stored its first sample
  ToolEvent sample_;
  Vec3 force_sent_ = Vec3::Zero();

  // Button changes: a ring written by the ticking thread, read by one consumer.
  static constexpr std::size_t kChanges = 256;
  std::array<ToolEvent, kChanges> changes_;
  std::atomic<std::size_t> changes_head_{0}, changes_tail_{0};

  // The ticking thread's own state (one thread ticks at a time).
  using Clock = std::chrono::steady_clock;
  Clock::time_point begin_, last_tick_;
  std::uint64_t ramp_ticks_ = 0;  // ticks since the ramp began
  std::uint32_t last_buttons_ = 0;
  std::uint64_t workspace_version_ = 0;
  Vec3 smoothed_ = Vec3::Zero();
  std::vector<double> periods_batch_, force_batch_;
  std::size_t tick_count_ = 0;
  std::atomic<bool> in_tick_{false};

  std::atomic<std::size_t> tool_errors_{0}, device_errors_{0};
  mutable std::mutex stats_mutex_;
  std::vector<double> periods_us_, force_us_;
  std::size_t ticks_ = 0;
  double elapsed_s_ = 0;
  std::string last_error_;
};

}  // namespace kiji
