#include "kiji/simulation_loop.h"

#include "base/forced_unwind.h"
#include "kiji/session.h"

#include <chrono>
#include <cmath>
#include <future>
#include <sstream>

namespace kiji {

namespace {

using Clock = std::chrono::steady_clock;

double seconds(Clock::time_point t) { return std::chrono::duration<double>(t.time_since_epoch()).count(); }

std::string error_text(const std::exception_ptr& error) {
  try {
    std::rethrow_exception(error);
  } catch (const std::exception& e) {
    return e.what();
  } KIJI_RETHROW_FORCED_UNWIND catch (...) {
    return "an unknown error";
  }
}

}  // namespace

SimulationLoop::SimulationLoop(std::shared_ptr<Session> session, double rate_hz)
    : session_(std::move(session)), rate_hz_(rate_hz) {
  if (!session_) throw InputError("a simulation loop needs a session");
  std::lock_guard<std::recursive_mutex> lock(session_->mutex());
  // A change of rate is an operation of the session: made only when there is one.
  if (session_->frame_rate() != rate_hz) session_->set_frame_rate(rate_hz);  // validates the rate
  // Operations applied by another thread (a peer's, a console's) change what the UI must draw.
  listener_ = session_->add_listener([this](const Operation&) {
    if (std::this_thread::get_id() != loop_thread_.load()) changed_elsewhere_.store(true);
  });
}

SimulationLoop::~SimulationLoop() {
  stop();
  std::lock_guard<std::recursive_mutex> lock(session_->mutex());
  session_->remove_listener(listener_);
}

std::unique_lock<std::recursive_mutex> SimulationLoop::hold() {
  ++holders_waiting_;
  std::unique_lock<std::recursive_mutex> lock(session_->mutex());
  --holders_waiting_;
  return lock;
}

std::unique_lock<std::recursive_mutex> SimulationLoop::lock_session() {
  // Another thread asking for the session goes first: the loop would otherwise take the lock back
  // at once whenever a step runs late.
  while (holders_waiting_.load() > 0) std::this_thread::sleep_for(std::chrono::microseconds(200));
  return std::unique_lock<std::recursive_mutex>(session_->mutex());
}

void SimulationLoop::start() {
  if (running_.exchange(true)) return;
  {
    auto lock = lock_session();
    publish(*session_);
  }
  thread_ = std::thread([this] { run(); });
  thread_id_ = thread_.get_id();
}

void SimulationLoop::stop() {
  if (!running_.exchange(false)) return;
  if (thread_.joinable()) thread_.join();
  auto lock = lock_session();
  Session& s = *session_;
  if (stroke_button_ && stroke_open(s)) end_stroke(s, last_move_, Phase::Cancel);
  if (fed_) {
    fed_->set_tool(nullptr);
    fed_->publish(nullptr);
    fed_->quiesce();  // the session's tools may go once this returns
    fed_ = nullptr;
  }
  // Work posted but never run: run it now, so that nothing asked for is silently lost.
  std::deque<Work> left;
  {
    std::lock_guard<std::mutex> q(queue_mutex_);
    left.swap(queue_);
  }
  for (Work& w : left) {
    try {
      w.fn(s);
    } KIJI_RETHROW_FORCED_UNWIND catch (...) {
      report((w.what.empty() ? "" : w.what + ": ") + error_text(std::current_exception()));
    }
  }
}

void SimulationLoop::post(std::function<void(Session&)> work, std::string what) {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  queue_.push_back(Work{std::move(work), std::move(what)});
}

void SimulationLoop::call(std::function<void(Session&)> work) {
  if (!running_.load()) {
    auto lock = lock_session();
    work(*session_);
    edited_ = true;
    publish(*session_);
    return;
  }
  auto done = std::make_shared<std::promise<void>>();
  std::future<void> result = done->get_future();
  post([this, work = std::move(work), done](Session& s) {
    try {
      work(s);
      // The frame shows the work's result by the time the caller goes on.
      edited_ = true;
      publish(s);
      done->set_value();
    } KIJI_RETHROW_FORCED_UNWIND catch (...) {
      done->set_exception(std::current_exception());
    }
  });
  result.get();
}

void SimulationLoop::attach(HapticLoop* haptics) {
  {
    std::lock_guard<std::mutex> lock(settings_mutex_);
    haptics_ = haptics;
    settings_changed_ = true;
  }
  // Done on the simulation thread before this returns, so that a detached loop may go at once.
  call([this](Session& s) { apply_settings(s); });
}

void SimulationLoop::set_tool(std::uint32_t button, const std::string& tool, const ParamSet& params) {
  std::lock_guard<std::mutex> lock(settings_mutex_);
  tools_[button == kButtonSecondary ? 1 : 0] = ToolChoice{tool, params};
  settings_changed_ = true;
}

void SimulationLoop::set_haptic_radius(double metres) {
  if (!std::isfinite(metres) || metres <= 0 || metres > 100)
    throw InputError("haptic radius must be a positive number of metres, at most 100");
  std::lock_guard<std::mutex> lock(settings_mutex_);
  haptic_radius_ = metres;
}

std::shared_ptr<const SceneFrame> SimulationLoop::frame() const { return std::atomic_load(&frame_); }

SimulationStats SimulationLoop::stats() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  return stats_;
}

std::vector<std::string> SimulationLoop::take_messages() {
  std::lock_guard<std::mutex> lock(messages_mutex_);
  std::vector<std::string> out;
  out.swap(messages_);
  return out;
}

void SimulationLoop::report(const std::string& message) {
  std::lock_guard<std::mutex> lock(messages_mutex_);
  if (messages_.size() < 100) messages_.push_back(message);
}

void SimulationLoop::publish_now() {
  auto lock = lock_session();
  publish(*session_);
  // The work that asked goes on after this frame: what it changes next is the tick's to publish.
  edited_ = true;
}

void SimulationLoop::run() {
  loop_thread_.store(std::this_thread::get_id());
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate_hz_));
  auto next = Clock::now() + period;
  while (running_.load()) {
    const auto t0 = Clock::now();
    tick();
    const auto t1 = Clock::now();
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.steps;
      recent_.push_back(Tick{seconds(t1), std::chrono::duration<double>(t1 - t0).count(), publishing_});
      while (!recent_.empty() && recent_.front().at < seconds(t1) - 1.0) recent_.pop_front();
      double sum = 0, publishing = 0;
      for (const Tick& r : recent_) sum += r.seconds, publishing += r.publishing;
      const double span = recent_.size() > 1 ? recent_.back().at - recent_.front().at : 0;
      stats_.steps_per_second = span > 0 ? (recent_.size() - 1) / span : 0;
      stats_.step_ms = recent_.empty() ? 0 : 1000 * sum / recent_.size();
      stats_.publish_ms = recent_.empty() ? 0 : 1000 * publishing / recent_.size();
    }
    std::this_thread::sleep_until(next);
    next += period;
    // A step that ran late starts the schedule afresh: no burst of catch-up steps.
    if (Clock::now() > next) next = Clock::now() + period;
  }
}

void SimulationLoop::tick() {
  std::deque<Work> work;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    work.swap(queue_);
  }
  auto lock = lock_session();
  Session& s = *session_;
  for (Work& w : work) {
    // Set before the work, so that work which publishes its own frame (call()) leaves nothing new
    // for the end of the tick to publish.
    edited_ = true;
    try {
      w.fn(s);
    } KIJI_RETHROW_FORCED_UNWIND catch (...) {
      report((w.what.empty() ? "" : w.what + ": ") + error_text(std::current_exception()));
    }
  }
  if (changed_elsewhere_.exchange(false)) edited_ = true;
  // Work may have ended the stroke (an undo cancels it).
  if (stroke_button_ && !stroke_open(s)) {
    stroke_button_ = 0;
    stroke_tool_.clear();
  }
  handle_device(s);
  // A paused session (Session::simulating()) still steps: its clock goes on, its cloth stands. A
  // shared one (gated) is stepped by its peer, on the clock the peers share.
  if (stepping_.load() && !s.gated()) {
    try {
      s.step();
    } KIJI_RETHROW_FORCED_UNWIND catch (...) {
      report("simulation step: " + error_text(std::current_exception()));
    }
  }
  // A paused scene that nothing touched is the frame already published: the UI has nothing to redraw.
  if (!edited_ && !s.simulating() && frame_ && frame_->simulating == s.simulating()) {
    const bool pointer_still = !fed_ || (frame_->has_pointer && fed_->latest_sample().position == frame_->pointer.position &&
                                         fed_->latest_sample().buttons == frame_->pointer.buttons &&
                                         fed_->latest_force() == frame_->force);
    if (pointer_still) return;
  }
  publish(s);
}

void SimulationLoop::apply_settings(Session& s) {
  std::lock_guard<std::mutex> lock(settings_mutex_);
  if (back_to_primary_) {
    back_to_primary_ = false;
    settings_changed_ = true;
  }
  if (!settings_changed_) return;
  settings_changed_ = false;
  HapticLoop* haptics = haptics_;
  if (fed_ && fed_ != haptics) {
    if (stroke_button_ && stroke_open(s)) end_stroke(s, last_move_, Phase::Cancel);
    fed_->set_tool(nullptr);
    fed_->publish(nullptr);
    fed_->quiesce();
    buttons_ = 0;
  }
  fed_ = haptics;
  const Tool* feel = nullptr;
  if (haptics && !tools_[0].id.empty()) {
    try {
      feel = &s.tool(tools_[0].id);
    } KIJI_RETHROW_FORCED_UNWIND catch (...) {
      report("tool '" + tools_[0].id + "': " + error_text(std::current_exception()));
    }
  }
  if (haptics && !stroke_button_) haptics->set_tool(feel);
}

void SimulationLoop::handle_device(Session& s) {
  apply_settings(s);
  HapticLoop* haptics = fed_;
  if (!haptics) {
    if (stroke_button_ && stroke_open(s)) end_stroke(s, last_move_, Phase::Cancel);
    buttons_ = 0;
    return;
  }
  for (const ToolEvent& change : haptics->take_button_changes()) {
    const std::uint32_t pressed = change.buttons & ~buttons_;
    const std::uint32_t released = buttons_ & ~change.buttons;
    buttons_ = change.buttons;
    if (stroke_button_ && (released & stroke_button_)) {
      end_stroke(s, change, Phase::End);
    } else if (!stroke_button_ && (pressed & kButtonPrimary)) {
      begin_stroke(s, change, kButtonPrimary);
    } else if (!stroke_button_ && (pressed & kButtonSecondary)) {
      begin_stroke(s, change, kButtonSecondary);
    }
  }
  if (!stroke_button_) return;
  // A shared session applies the stroke's begin when its turn comes: only then is it known
  // whether it took hold of cloth.
  if (holds_pending_ && s.stroke_active()) {
    holds_pending_ = false;
    stroke_holds_cloth_ = held_cloth(s) > held_before_;
  }
  const ToolEvent sample = haptics->latest_sample();
  if (sample.position == last_move_.position && sample.ray == last_move_.ray &&
      sample.orientation.coeffs() == last_move_.orientation.coeffs())
    return;
  ToolEvent move = sample;
  move.phase = Phase::Move;
  move.time = s.time();
  move.buttons = stroke_button_;
  try {
    s.apply(stroke_tool_, move);
    last_move_ = move;
  } KIJI_RETHROW_FORCED_UNWIND catch (...) {
    report("'" + stroke_tool_ + "' stroke: " + error_text(std::current_exception()) +
           " (the stroke was undone)");
    stroke_button_ = 0;
    back_to_primary_ = true;
  }
  edited_ = true;
}

void SimulationLoop::begin_stroke(Session& s, const ToolEvent& sample, std::uint32_t button) {
  ToolChoice choice;
  {
    std::lock_guard<std::mutex> lock(settings_mutex_);
    choice = tools_[button == kButtonSecondary ? 1 : 0];
    if (choice.id.empty()) choice = tools_[0];
  }
  if (choice.id.empty()) return;  // no tool chosen: the button does nothing
  ToolEvent begin = sample;
  begin.phase = Phase::Begin;
  begin.time = s.time();
  begin.buttons = button;
  try {
    Tool& tool = s.tool(choice.id);
    const SurfaceHit hit = s.pick(begin.position, begin.ray);
    stroke_garment_ = hit.hit ? hit.garment : 0;
    held_before_ = held_cloth(s);
    s.apply(tool, begin, &choice.params);
    holds_pending_ = !s.stroke_active();  // proposed to the peers, not applied yet
    stroke_holds_cloth_ = !holds_pending_ && held_cloth(s) > held_before_;
    stroke_button_ = button;
    stroke_tool_ = choice.id;
    last_move_ = begin;
    if (fed_) fed_->set_tool(&tool);
  } KIJI_RETHROW_FORCED_UNWIND catch (...) {
    report("'" + choice.id + "' stroke: " + error_text(std::current_exception()) + " (nothing was changed)");
  }
  edited_ = true;
}

void SimulationLoop::end_stroke(Session& s, const ToolEvent& sample, Phase phase) {
  ToolEvent end = sample;
  end.phase = phase;
  end.time = s.time();
  end.buttons = stroke_button_;
  const std::string tool = stroke_tool_;
  stroke_button_ = 0;
  stroke_tool_.clear();
  holds_pending_ = false;
  try {
    if (stroke_open(s)) s.apply(tool, end);
  } KIJI_RETHROW_FORCED_UNWIND catch (...) {
    report("'" + tool + "' stroke: " + error_text(std::current_exception()) + " (the stroke was undone)");
  }
  // Back to feeling the primary tool (its stroke settings are over).
  back_to_primary_ = true;
  edited_ = true;
}

bool SimulationLoop::stroke_open(const Session& s) { return !s.stroke_tool().empty(); }

std::size_t SimulationLoop::held_cloth(Session& s) const {
  // Whether a tool takes hold of the cloth: a new attachment or a newly pinned vertex.
  if (stroke_garment_ >= s.garment_count()) return 0;
  const Garment& g = s.garment(stroke_garment_);
  std::size_t pinned = 0;
  for (Vertex v : g.mesh().vertices()) pinned += g.pinned(v);
  return pinned + s.solver(stroke_garment_).attachment_count();
}

void SimulationLoop::publish(Session& s) {
  const auto start = Clock::now();
  struct Timed {
    const Clock::time_point& start;
    double& out;
    ~Timed() { out = std::chrono::duration<double>(Clock::now() - start).count(); }
  } timed{start, publishing_};
  std::shared_ptr<SceneFrame> f;
  try {
    f = builder_.build(s, edited_);
  } KIJI_RETHROW_FORCED_UNWIND catch (...) {
    report("drawing the scene: " + error_text(std::current_exception()));
    return;
  }
  edited_ = false;
  f->stroke_holds_cloth = stroke_button_ && stroke_holds_cloth_;
  HapticLoop* haptics = fed_;
  if (haptics) {
    const ToolEvent sample = haptics->latest_sample();
    f->has_pointer = true;
    f->pointer = sample;
    f->force = haptics->latest_force();
    f->hit = s.pick(sample.position, sample.ray);
    double radius;
    {
      std::lock_guard<std::mutex> lock(settings_mutex_);
      radius = haptic_radius_;
    }
    if (s.garment_count() > 0) {
      // The cloth the stroke holds, or the cloth under the pointer, or the first garment.
      std::size_t g = f->hit.hit ? f->hit.garment : 0;
      if (stroke_button_ && stroke_garment_ < s.garment_count()) g = stroke_garment_;
      const Vec3 centre = f->hit.hit && sample.ray.squaredNorm() > 0 ? f->hit.point : sample.position;
      haptics->publish(std::make_shared<HapticSnapshot>(take_snapshot(s, g, centre, radius)));
    } else {
      haptics->publish(nullptr);
    }
  }
  std::atomic_store(&frame_, std::shared_ptr<const SceneFrame>(std::move(f)));
}

}  // namespace kiji
