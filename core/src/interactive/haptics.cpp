#include "kiji/haptics.h"

#include "base/forced_unwind.h"
#include "kiji/session.h"

#include <sstream>

#include <algorithm>
#if defined(__linux__)
#include <pthread.h>
#include <sched.h>
#endif
#include <cmath>
#include <numeric>
#include <unordered_map>

namespace kiji {

HapticSnapshot take_snapshot(const Session& session, std::size_t garment, const Vec3& center, double radius) {
  HapticSnapshot s;
  const Garment& g = session.garment(garment);
  const Mesh& m = g.mesh();
  s.time = session.time();
  s.garment = garment;
  s.center = center;
  s.radius = radius;
  std::unordered_map<std::uint32_t, int> local;
  const double r2 = radius * radius;
  for (Vertex v : m.vertices()) {
    const Vec3 p = g.position(v);
    if ((p - center).squaredNorm() > r2) continue;
    local.emplace(v.idx(), static_cast<int>(s.vertices.size()));
    s.vertices.push_back(v);
    s.positions.push_back(p);
  }
  std::vector<Face> faces;
  for (Vertex v : s.vertices)
    for (Face f : CGAL::faces_around_target(m.halfedge(v), m))
      if (f != Mesh::null_face()) faces.push_back(f);
  std::sort(faces.begin(), faces.end());
  faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
  for (Face f : faces) {
    std::array<int, 3> t{};
    int k = 0;
    for (Vertex w : CGAL::vertices_around_face(m.halfedge(f), m)) {
      auto it = local.find(w.idx());
      if (it == local.end() || k == 3) {
        k = -1;
        break;
      }
      t[k++] = it->second;
    }
    if (k == 3) s.triangles.push_back(t);
  }
  return s;
}

ScriptedDevice::ScriptedDevice(std::function<ToolEvent(double)> path)
    : path_(std::move(path)), start_(std::chrono::steady_clock::now()) {}

ToolEvent ScriptedDevice::sample() {
  const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  ToolEvent e = path_(t);
  e.time = t;
  return e;
}

void ScriptedDevice::set_force(const Vec3& force) {
  std::lock_guard<std::mutex> lock(mutex_);
  last_force_ = force;
  ++forces_;
}

Vec3 ScriptedDevice::last_force() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_force_;
}

void HapticOptions::validate() const {
  auto check = [](double v, double lo, double hi, const char* name, const char* unit) {
    if (!std::isfinite(v) || v < lo || v > hi) {
      std::ostringstream msg;
      msg << "haptic " << name << " " << v << " is out of range: use " << lo << " to " << hi << unit;
      throw InputError(msg.str());
    }
  };
  check(rate_hz, 100, 10000, "rate", " ticks a second");
  check(force_gain, 0, 10, "force gain", "");
  check(smoothing_s, 0, 0.1, "smoothing", " seconds");
  check(ramp_s, 0, 10, "ramp", " seconds");
}

HapticLoop::HapticLoop(InputDevice& device, double rate_hz)
    : HapticLoop(device, [&] {
        HapticOptions o;
        o.rate_hz = rate_hz;
        return o;
      }()) {}

HapticLoop::HapticLoop(InputDevice& device, const HapticOptions& options)
    : device_(device), options_(options), force_gain_(options.force_gain) {
  options_.validate();
}

HapticLoop::~HapticLoop() { stop(); }

void HapticLoop::set_tool(const Tool* tool) { tool_.store(tool); }

void HapticLoop::quiesce() const {
  // A tick reads the tool inside in_tick_; one that starts after this sees the new tool.
  while (in_tick_.load()) std::this_thread::yield();
}

void HapticLoop::set_force_gain(double gain) {
  HapticOptions o = options_;
  o.force_gain = gain;
  o.validate();
  force_gain_.store(gain);
}

void HapticLoop::publish(std::shared_ptr<const HapticSnapshot> snapshot) {
  std::atomic_store(&snapshot_, std::move(snapshot));
}

ToolEvent HapticLoop::latest_sample() const {
  std::lock_guard<std::mutex> lock(sample_mutex_);
  return sample_;
}

Vec3 HapticLoop::latest_force() const {
  std::lock_guard<std::mutex> lock(sample_mutex_);
  return force_sent_;
}

std::vector<ToolEvent> HapticLoop::take_button_changes() {
  std::vector<ToolEvent> out;
  std::size_t tail = changes_tail_.load(std::memory_order_relaxed);
  const std::size_t head = changes_head_.load(std::memory_order_acquire);
  for (; tail != head; ++tail) out.push_back(changes_[tail % kChanges]);
  changes_tail_.store(tail, std::memory_order_release);
  return out;
}

void HapticLoop::start() {
  if (running_.exchange(true)) return;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    periods_us_.clear();
    force_us_.clear();
    ticks_ = 0;
    elapsed_s_ = 0;
    last_error_.clear();
  }
  tool_errors_ = 0;
  device_errors_ = 0;
  begin_ = last_tick_ = Clock::now();
  ramp_ticks_ = 0;
  workspace_version_ = device_.workspace_version();
  last_buttons_ = 0;
  smoothed_.setZero();
  periods_batch_.clear();
  force_batch_.clear();
  periods_batch_.reserve(1 << 12);
  force_batch_.reserve(1 << 12);
  tick_count_ = 0;
  std::unique_lock<std::mutex> lock(sample_mutex_);
  sampled_ = false;
  if (!device_.has_servo_loop()) {
    thread_ = std::thread([this] { run(); });
    sampled_cv_.wait(lock, [this] { return sampled_; });
    return;
  }
  lock.unlock();
  try {
    device_.start_servo_loop([this] { tick(); });
  } KIJI_RETHROW_FORCED_UNWIND catch (...) {
    running_ = false;
    throw;
  }
  lock.lock();
  if (!sampled_cv_.wait_for(lock, std::chrono::seconds(2), [this] { return sampled_; })) {
    lock.unlock();
    device_.stop_servo_loop();
    running_ = false;
    throw DeviceError("the device's servo loop started but never ran within 2 s: check that no other program "
                      "holds the device, then try again");
  }
}

void HapticLoop::stop() {
  if (!running_.exchange(false)) return;
  if (device_.has_servo_loop()) {
    device_.stop_servo_loop();
  } else if (thread_.joinable()) {
    thread_.join();
  }
  try {
    device_.set_force(Vec3::Zero());
  } KIJI_RETHROW_FORCED_UNWIND catch (...) {
    ++device_errors_;
  }
  std::lock_guard<std::mutex> lock(stats_mutex_);
  periods_us_.insert(periods_us_.end(), periods_batch_.begin(), periods_batch_.end());
  force_us_.insert(force_us_.end(), force_batch_.begin(), force_batch_.end());
  periods_batch_.clear();
  force_batch_.clear();
  ticks_ = tick_count_;
  elapsed_s_ = std::chrono::duration<double>(last_tick_ - begin_).count();
  std::lock_guard<std::mutex> sample_lock(sample_mutex_);
  force_sent_.setZero();
}

void HapticLoop::note_error(std::atomic<std::size_t>& counter, const std::string& message) {
  ++counter;
  // Never wait in a tick: a message that meets the lock taken is dropped (the count is kept).
  std::unique_lock<std::mutex> lock(stats_mutex_, std::try_to_lock);
  if (lock.owns_lock()) last_error_ = message;
}

Vec3 HapticLoop::shape(Vec3 force) {
  const double limit = device_.max_force();
  force *= force_gain_.load(std::memory_order_relaxed);
  if (force.norm() > limit) force *= limit / force.norm();
  if (options_.smoothing_s > 0) {
    const double a = 1.0 - std::exp(-1.0 / (options_.rate_hz * options_.smoothing_s));
    smoothed_ += a * (force - smoothed_);
    // With no force asked the filter's tail would never reach zero: below a millinewton it is zero.
    if (force.isZero(0) && smoothed_.norm() < 1e-3) smoothed_.setZero();
  } else {
    smoothed_ = force;
  }
  const std::uint64_t version = device_.workspace_version();
  if (version != workspace_version_) {
    workspace_version_ = version;
    ramp_ticks_ = 0;
  }
  double ramp = 1.0;
  if (options_.ramp_s > 0) {
    // Counted in ticks, not read from the clock: a tick that comes late (a busy machine, a stalled
    // servo thread) takes the ramp one tick further, never a jump.
    const double x = std::min(double(ramp_ticks_) / (options_.rate_hz * options_.ramp_s), 1.0);
    if (x < 1.0) ++ramp_ticks_;
    ramp = x * x * (3 - 2 * x);  // smoothstep: no jerk where the ramp starts or ends
  }
  return ramp * smoothed_;
}

void HapticLoop::tick() {
  in_tick_.store(true, std::memory_order_seq_cst);
  struct Done {
    std::atomic<bool>& flag;
    ~Done() { flag.store(false, std::memory_order_release); }
  } done{in_tick_};
  const auto tick_start = Clock::now();
  ToolEvent e;
  bool sampled = true;
  try {
    e = device_.sample();
  } catch (const std::exception& error) {
    note_error(device_errors_, std::string("the device's sample failed: ") + error.what());
    sampled = false;
  } KIJI_RETHROW_FORCED_UNWIND catch (...) {
    note_error(device_errors_, "the device's sample failed with an unknown error");
    sampled = false;
  }
  Vec3 force = Vec3::Zero();
  const auto t0 = Clock::now();
  if (sampled) {
    const Tool* tool = tool_.load();
    const std::shared_ptr<const HapticSnapshot> snap = std::atomic_load(&snapshot_);
    if (tool && snap) {
      try {
        force = tool->haptic_force(*snap, e).force;
        if (!force.allFinite()) {
          force.setZero();
          note_error(tool_errors_, "tool '" + tool->info().id + "' gave a force that is not a finite number");
        }
      } catch (const std::exception& error) {
        force.setZero();
        note_error(tool_errors_, std::string("the tool's force callback failed: ") + error.what());
      } KIJI_RETHROW_FORCED_UNWIND catch (...) {
        force.setZero();
        note_error(tool_errors_, "the tool's force callback failed with an unknown error");
      }
    }
  }
  const auto t1 = Clock::now();
  // Never a NaN to a motor, never more than the device takes; a failed sample sends zero.
  Vec3 out = sampled ? shape(force) : Vec3::Zero();
  if (!sampled) smoothed_.setZero();
  try {
    device_.set_force(out);
  } catch (const std::exception& error) {
    note_error(device_errors_, std::string("the device's set_force failed: ") + error.what());
    out.setZero();
  } KIJI_RETHROW_FORCED_UNWIND catch (...) {
    note_error(device_errors_, "the device's set_force failed with an unknown error");
    out.setZero();
  }
  if (sampled) {
    if (e.buttons != last_buttons_) {
      const std::size_t head = changes_head_.load(std::memory_order_relaxed);
      if (head - changes_tail_.load(std::memory_order_acquire) < kChanges) {
        changes_[head % kChanges] = e;
        changes_head_.store(head + 1, std::memory_order_release);
      }
      last_buttons_ = e.buttons;
    }
    std::unique_lock<std::mutex> lock(sample_mutex_, std::defer_lock);
    if (!sampled_) {
      lock.lock();  // once: start() waits for it
      sample_ = e;
      force_sent_ = out;
      sampled_ = true;
      sampled_cv_.notify_all();
    } else if (lock.try_lock()) {
      sample_ = e;
      force_sent_ = out;
    }
  }
  force_batch_.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  periods_batch_.push_back(std::chrono::duration<double, std::micro>(tick_start - last_tick_).count());
  last_tick_ = tick_start;
  ++tick_count_;
  if (force_batch_.size() >= 1024) {  // hand the figures over in batches, when the lock is free at once
    std::unique_lock<std::mutex> lock(stats_mutex_, std::try_to_lock);
    if (lock.owns_lock()) {
      periods_us_.insert(periods_us_.end(), periods_batch_.begin(), periods_batch_.end());
      force_us_.insert(force_us_.end(), force_batch_.begin(), force_batch_.end());
      // The figures of the last minute or so: an app runs for hours.
      constexpr std::size_t kWindow = 1 << 16;
      if (periods_us_.size() > 2 * kWindow) periods_us_.erase(periods_us_.begin(), periods_us_.end() - kWindow);
      if (force_us_.size() > 2 * kWindow) force_us_.erase(force_us_.begin(), force_us_.end() - kWindow);
      ticks_ = tick_count_;
      elapsed_s_ = std::chrono::duration<double>(tick_start - begin_).count();
      periods_batch_.clear();
      force_batch_.clear();
    }
  }
}

void HapticLoop::run() {
  // Above the simulation's threads where the system allows it (see HapticStats::realtime): the
  // loop sleeps most of each millisecond, so it takes little from them.
  bool realtime = false;
#if defined(__linux__)
  sched_param priority{};
  priority.sched_priority = sched_get_priority_min(SCHED_FIFO);
  realtime = pthread_setschedparam(pthread_self(), SCHED_FIFO, &priority) == 0;
#endif
  realtime_.store(realtime);
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / options_.rate_hz));
  auto next = Clock::now() + period;
  while (running_.load(std::memory_order_relaxed)) {
    tick();
    std::this_thread::sleep_until(next);
    next += period;
    // After a stall, start afresh rather than running a burst of catch-up ticks.
    if (Clock::now() > next + 10 * period) next = Clock::now() + period;
  }
}

HapticStats HapticLoop::stats() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  HapticStats s;
  s.realtime = realtime_.load();
  s.tool_errors = tool_errors_.load();
  s.device_errors = device_errors_.load();
  s.last_error = last_error_;
  s.ticks = ticks_;
  s.rate_hz = elapsed_s_ > 0 ? ticks_ / elapsed_s_ : 0;
  if (periods_us_.size() > 1) {
    // The first period includes the thread's start; leave it out.
    const double mean = std::accumulate(periods_us_.begin() + 1, periods_us_.end(), 0.0) / (periods_us_.size() - 1);
    double var = 0;
    for (std::size_t i = 1; i < periods_us_.size(); ++i) var += (periods_us_[i] - mean) * (periods_us_[i] - mean);
    s.period_jitter_us = std::sqrt(var / (periods_us_.size() - 1));
  }
  if (!force_us_.empty()) {
    std::vector<double> f = force_us_;
    const auto median = f.begin() + f.size() / 2;
    std::nth_element(f.begin(), median, f.end());
    s.force_median_us = *median;
    const auto p99 = f.begin() + std::min(f.size() - 1, f.size() * 99 / 100);
    std::nth_element(f.begin(), p99, f.end());
    s.force_p99_us = *p99;
  }
  return s;
}

}  // namespace kiji
