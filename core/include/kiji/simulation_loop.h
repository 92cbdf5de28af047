// The simulation thread of an interactive session (an app, a script that keeps a scene running):
// at a fixed rate it applies the queued work, turns the pointing device's samples into tool
// strokes, steps the session, and publishes what the UI draws (a SceneFrame) and what the haptic
// loop feels (a HapticSnapshot around the pointer). The UI and the haptic thread never wait for a
// step: they read the latest publication.
//
// Every use of the session here holds Session::mutex() for one step or one piece of work; another
// thread that uses the session (a script console) holds it through hold(), and the loop waits.
#pragma once

#include "kiji/haptics.h"
#include "kiji/params.h"
#include "kiji/scene_frame.h"

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace kiji {

class Session;

struct SimulationStats {
  std::uint64_t steps = 0;      // since start
  double steps_per_second = 0;  // over the last second or so
  double step_ms = 0;           // mean time of a tick (work, tools, the step, publication) over the same
  double publish_ms = 0;        // of which publishing: the frame, the pick under the pointer, the snapshot
};

class SimulationLoop {
 public:
  // A loop for `session` at `rate_hz` steps a second (1 to 10,000; the session's frame rate is set
  // to it, so that a step is 1 / rate_hz of simulated time and simulated time keeps to real time
  // while the loop keeps up).
  explicit SimulationLoop(std::shared_ptr<Session> session, double rate_hz = 60);
  ~SimulationLoop();  // stops the thread (a stroke in progress is cancelled)
  SimulationLoop(const SimulationLoop&) = delete;
  SimulationLoop& operator=(const SimulationLoop&) = delete;

  void start();
  void stop();
  bool running() const { return running_.load(); }
  const std::shared_ptr<Session>& session() const { return session_; }

  // Work for the simulation thread, run in the order posted between steps, under the session's
  // lock. What it throws is caught and reported through take_messages() (prefixed by `what`); the
  // Session's own calls leave it as it was when they throw.
  void post(std::function<void(Session&)> work, std::string what = {});
  // Runs work on the simulation thread (or at once if the loop is not running) and waits for it;
  // rethrows what it throws. When it returns, frame() shows the work done. Not from the simulation
  // thread itself.
  void call(std::function<void(Session&)> work);
  // From work running on the simulation thread: publish a frame now (a long drape shows its
  // progress), and whether stop() was asked for meanwhile (long work should end early).
  void publish_now();
  bool stop_requested() const { return !running_.load(); }

  // The pointing device: its haptic loop's button changes start and end strokes, its samples move
  // them, and the loop is given the tool and the snapshot to feel. Null: no device. Takes effect
  // before it returns (a stroke of the device detached is cancelled), so that the haptic loop
  // detached may be destroyed at once; a haptic loop attached must outlive the attachment.
  void attach(HapticLoop* haptics);
  // The tool a button's strokes use (kButtonPrimary or kButtonSecondary), with its parameters; the
  // haptic loop feels the primary one's.
  void set_tool(std::uint32_t button, const std::string& tool, const ParamSet& params);
  // Radius of the cloth around the pointer that the haptic loop gets each step, metres.
  void set_haptic_radius(double metres);

  // Whether the loop steps the session at all (it still runs work and tools, and publishes). Off
  // while an app sets its scene up, so that the clock starts at zero when the user (or a replayed
  // journal) does. Pausing the cloth is the session's own setting (Session::set_simulating), not this.
  // While the session is shared with peers (Session::gated) the loop never steps it, whatever this
  // says: the peer steps the shared clock; the device's strokes go to the peer as proposals.
  void set_stepping(bool on) { stepping_.store(on); }
  bool stepping() const { return stepping_.load(); }

  // The latest frame (never null once start() has returned).
  std::shared_ptr<const SceneFrame> frame() const;
  SimulationStats stats() const;
  // Messages for the user since the last call: work or a stroke that failed, and why.
  std::vector<std::string> take_messages();

  // The session's lock for another thread; the loop waits while it is held.
  std::unique_lock<std::recursive_mutex> hold();

 private:
  struct Work {
    std::function<void(Session&)> fn;
    std::string what;
  };
  void run();
  void tick();
  void apply_settings(Session& s);
  void handle_device(Session& s);
  void begin_stroke(Session& s, const ToolEvent& sample, std::uint32_t button);
  void end_stroke(Session& s, const ToolEvent& sample, Phase phase);
  void publish(Session& s);
  void report(const std::string& message);
  // A stroke of the device's user is in progress as the user sees it (a shared session's included,
  // proposed but not yet applied).
  static bool stroke_open(const Session& s);
  std::size_t held_cloth(Session& s) const;  // pinned vertices and attachments of the stroke's garment
  std::unique_lock<std::recursive_mutex> lock_session();

  std::shared_ptr<Session> session_;
  double rate_hz_;
  std::atomic<bool> running_{false};
  std::atomic<bool> stepping_{true};
  std::thread thread_;
  std::thread::id thread_id_;

  std::mutex queue_mutex_;
  std::deque<Work> queue_;

  std::atomic<int> holders_waiting_{0};
  int listener_ = -1;
  std::atomic<bool> changed_elsewhere_{false};  // an operation applied by another thread (a peer's)
  std::atomic<std::thread::id> loop_thread_{};

  // The device and the strokes it makes (simulation thread only, but for the settings).
  std::mutex settings_mutex_;
  HapticLoop* haptics_ = nullptr;
  struct ToolChoice {
    std::string id;
    ParamSet params;
  };
  ToolChoice tools_[2];  // primary, secondary
  double haptic_radius_ = 0.1;
  bool settings_changed_ = true;

  std::uint32_t buttons_ = 0;      // as the last button change left them
  std::uint32_t stroke_button_ = 0;  // the button whose stroke is in progress (0: none)
  std::string stroke_tool_;
  ToolEvent last_move_;
  std::size_t stroke_garment_ = 0;
  bool stroke_holds_cloth_ = false;
  bool holds_pending_ = false;     // the stroke's begin waits for its turn in the peers' order
  std::size_t held_before_ = 0;
  HapticLoop* fed_ = nullptr;      // the haptic loop last given a tool
  bool edited_ = true;             // a tool or work ran since the last frame
  bool back_to_primary_ = false;   // a stroke ended: the haptic loop feels the primary tool again

  SceneFrameBuilder builder_;
  std::shared_ptr<const SceneFrame> frame_;  // std::atomic_load/store
  mutable std::mutex stats_mutex_;
  SimulationStats stats_;
  struct Tick {
    double at, seconds, publishing;
  };
  std::deque<Tick> recent_;  // the last second's ticks
  double publishing_ = 0;    // seconds the last publish() took
  std::mutex messages_mutex_;
  std::vector<std::string> messages_;
};

}  // namespace kiji
