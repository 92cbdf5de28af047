#include "kiji/haptics.h"

#include "geometry.h"
#include "kiji/session.h"

#include <algorithm>
#if defined(__linux__)
#include <pthread.h>
#include <sched.h>
#endif
#include <cmath>
#include <numeric>
#include <unordered_map>

namespace kiji {

const Vec3* HapticSnapshot::position_of(Vertex v) const {
  const auto it = std::lower_bound(vertices.begin(), vertices.end(), v);
  if (it == vertices.end() || *it != v) return nullptr;
  return &positions[static_cast<std::size_t>(it - vertices.begin())];
}

SurfaceHit HapticSnapshot::nearest(const Vec3& p) const {
  SurfaceHit best;
  for (const auto& t : triangles) {
    const Vec3 &a = positions[t[0]], &b = positions[t[1]], &c = positions[t[2]];
    const geom::ClosestPoint cp = geom::closest_on_triangle(p, a, b, c);
    const double d = (cp.point - p).norm();
    if (d >= best.distance) continue;
    best.hit = true;
    best.garment = garment;
    best.point = cp.point;
    best.distance = d;
    best.barycentric = Vec3(cp.b0, cp.b1, cp.b2);
    const Vec3 n = (b - a).cross(c - a);
    best.normal = n.norm() > 0 ? Vec3(n.normalized()) : Vec3(0, 1, 0);
    int k = 0;
    best.barycentric.maxCoeff(&k);
    best.nearest = vertices[t[k]];
  }
  return best;
}

Feedback haptic_model_force(const HapticModel& model, const HapticSnapshot& snapshot, const ToolEvent& event) {
  Feedback f;
  if (const auto* spring = std::get_if<HapticSpring>(&model)) {
    if (spring->vertices.empty() || snapshot.garment != spring->garment) return f;
    const double k = spring->stiffness / double(spring->vertices.size());
    for (std::size_t i = 0; i < spring->vertices.size(); ++i)
      if (const Vec3* x = snapshot.position_of(spring->vertices[i]))
        f.force += k * (*x - spring->offsets[i] - event.position);
  } else if (const auto* push = std::get_if<HapticPush>(&model)) {
    const SurfaceHit hit = snapshot.nearest(event.position);
    if (!hit.hit || hit.distance > push->touch) return f;
    Vec3 n = hit.normal;
    if ((event.position - hit.point).dot(n) < 0) n = -n;
    f.force = push->stiffness * (push->touch - hit.distance) * n;
  }
  return f;
}

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

HapticLoop::HapticLoop(InputDevice& device, double rate_hz) : device_(device), rate_hz_(rate_hz) {}

HapticLoop::~HapticLoop() { stop(); }

void HapticLoop::set_tool(const Tool* tool) { tool_.store(tool); }

void HapticLoop::publish(std::shared_ptr<const HapticSnapshot> snapshot) {
  std::atomic_store(&snapshot_, std::move(snapshot));
}

ToolEvent HapticLoop::latest_sample() const {
  std::lock_guard<std::mutex> lock(sample_mutex_);
  return sample_;
}

void HapticLoop::start() {
  if (running_.exchange(true)) return;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    periods_us_.clear();
    force_us_.clear();
    ticks_ = 0;
    elapsed_s_ = 0;
  }
  std::unique_lock<std::mutex> lock(sample_mutex_);
  sampled_ = false;
  thread_ = std::thread([this] { run(); });
  sampled_cv_.wait(lock, [this] { return sampled_; });
}

void HapticLoop::stop() {
  if (!running_.exchange(false)) return;
  if (thread_.joinable()) thread_.join();
  device_.set_force(Vec3::Zero());
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
  using clock = std::chrono::steady_clock;
  const auto period = std::chrono::duration_cast<clock::duration>(std::chrono::duration<double>(1.0 / rate_hz_));
  const auto begin = clock::now();
  auto next = begin + period;
  auto last = begin;
  std::vector<double> periods, forces;
  periods.reserve(1 << 16);
  forces.reserve(1 << 16);
  std::size_t ticks = 0;
  while (running_.load(std::memory_order_relaxed)) {
    const ToolEvent e = device_.sample();
    {
      std::lock_guard<std::mutex> lock(sample_mutex_);
      sample_ = e;
      if (!sampled_) {
        sampled_ = true;
        sampled_cv_.notify_all();
      }
    }
    Vec3 force = Vec3::Zero();
    const auto t0 = clock::now();
    const Tool* tool = tool_.load();
    const std::shared_ptr<const HapticSnapshot> snap = std::atomic_load(&snapshot_);
    if (tool && snap) force = tool->haptic_force(*snap, e).force;
    const auto t1 = clock::now();
    // Clamp to what the device can render, as CHAI3D does, and never send a NaN to a motor.
    const double limit = device_.max_force();
    if (!force.allFinite()) force.setZero();
    if (force.norm() > limit) force *= limit / force.norm();
    device_.set_force(force);
    forces.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    const auto now = clock::now();
    periods.push_back(std::chrono::duration<double, std::micro>(now - last).count());
    last = now;
    ++ticks;
    if (forces.size() >= 4096) {  // hand the figures over in batches: no lock every tick
      std::lock_guard<std::mutex> lock(stats_mutex_);
      periods_us_.insert(periods_us_.end(), periods.begin(), periods.end());
      force_us_.insert(force_us_.end(), forces.begin(), forces.end());
      ticks_ = ticks;
      elapsed_s_ = std::chrono::duration<double>(now - begin).count();
      periods.clear();
      forces.clear();
    }
    std::this_thread::sleep_until(next);
    next += period;
    // After a stall, start afresh rather than running a burst of catch-up ticks.
    if (clock::now() > next + 10 * period) next = clock::now() + period;
  }
  std::lock_guard<std::mutex> lock(stats_mutex_);
  periods_us_.insert(periods_us_.end(), periods.begin(), periods.end());
  force_us_.insert(force_us_.end(), forces.begin(), forces.end());
  ticks_ = ticks;
  elapsed_s_ = std::chrono::duration<double>(clock::now() - begin).count();
}

HapticStats HapticLoop::stats() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  HapticStats s;
  s.realtime = realtime_.load();
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
    std::sort(f.begin(), f.end());
    s.force_median_us = f[f.size() / 2];
    s.force_p99_us = f[std::min(f.size() - 1, f.size() * 99 / 100)];
  }
  return s;
}

}  // namespace kiji
