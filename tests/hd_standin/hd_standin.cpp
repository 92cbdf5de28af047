// A stand-in for OpenHaptics' libHD: a shared library with the HD functions a servo loop uses and
// the vendor's values, so that Kiji's Phantom backend runs, through dlopen as with the real one, in
// tests and on machines without a device. It plays a pen path from a file, renders nothing, and
// records every call that matters and every force it is sent.
//
// Set by environment variables, read when the device is initialised (the path: when the scheduler
// starts):
//   KIJI_HD_STANDIN_PATH  the pen's path: lines "t x y z buttons" (seconds since the scheduler
//                         started; millimetres in the device frame; HD_CURRENT_BUTTONS bits),
//                         linear between lines, held after the last; '#' starts a comment.
//   KIJI_HD_STANDIN_LOG   where to write the record when the device is disabled (and at exit):
//                         "call <name> <t>" for init, enable, start and stop of the scheduler,
//                         schedule, unschedule and disable; "force <t> <fx> <fy> <fz>" for each
//                         servo frame's force as the device rendered it (zero while force output
//                         is off); "error <t> <code>" for errors raised.
//   KIJI_HD_STANDIN_FAIL  "init" (hdInitDevice fails: HD_DEVICE_FAULT), "scheduler"
//                         (hdStartScheduler fails: HD_TIMER_ERROR), "comm:<n>" (the servo frame
//                         after n frames raises HD_COMM_ERROR, as a pulled cable would).
//   KIJI_HD_STANDIN_DEVICE the configuration name it answers to besides HD_DEFAULT_DEVICE
//                         (default "Default Device").
// Its device is a Phantom Omni: 3.3 N peak, 0.88 N continuous, 0.7 N/mm, a usable workspace of
// 160 x 120 x 70 mm.
#include "HD/hd.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <mutex>
#include <pthread.h>
#include <sched.h>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#define HD_EXPORT extern "C" __attribute__((visibility("default")))

namespace {

using Clock = std::chrono::steady_clock;

constexpr HHD kDevice = 1;
constexpr double kMaxForce = 3.3, kMaxContinuousForce = 0.88, kMaxStiffness = 0.7;
constexpr double kUsable[6] = {-80, -60, -35, 80, 60, 35};
constexpr double kMaxWorkspace[6] = {-105, -85, -50, 105, 85, 50};

struct Key {
  double t;
  double p[3];
  int buttons;
};

struct Callback {
  HDSchedulerHandle handle;
  HDSchedulerCallback fn;
  void* data;
  HDushort priority;
  bool synchronous;
  bool done;
};

struct State {
  std::mutex mutex;  // everything below but the servo frame's own fields
  bool initialised = false;
  bool force_output = false;
  std::string answers_to = "Default Device";
  std::string fail;
  long comm_fail_after = -1;
  std::vector<Key> path;
  std::string log_path;
  std::vector<std::string> log;
  Clock::time_point origin = Clock::now(), scheduler_start = Clock::now();

  std::mutex callbacks_mutex;  // held while the scheduler runs a tick
  std::vector<Callback> callbacks;
  HDSchedulerHandle next_handle = 1;
  std::condition_variable callbacks_cv;
  std::thread scheduler;
  std::atomic<bool> running{false};
  long frames = 0;

  // The servo frame (scheduler thread).
  bool in_frame = false;
  double frame_time = 0;
  double frame_force[3] = {0, 0, 0};

  ~State() {
    running = false;
    if (scheduler.joinable()) scheduler.join();
    write_log();
  }

  double now() const { return std::chrono::duration<double>(Clock::now() - origin).count(); }
  void note(const std::string& line) {
    std::lock_guard<std::mutex> lock(mutex);
    log.push_back(line);
  }
  void call(const char* name) {
    std::ostringstream s;
    s << "call " << name << " " << now();
    note(s.str());
  }
  void write_log() {
    std::lock_guard<std::mutex> lock(mutex);
    if (log_path.empty()) return;
    std::ofstream out(log_path);
    for (const std::string& l : log) out << l << "\n";
  }
};

State& state() {
  static State s;
  return s;
}

thread_local std::vector<HDErrorInfo> errors;  // most recent last; hdGetError pops it

void push_error(HDerror code, int internal = 0) {
  errors.push_back(HDErrorInfo{code, internal, kDevice});
  std::ostringstream s;
  s << "error " << state().now() << " 0x" << std::hex << code;
  state().note(s.str());
}

std::vector<Key> read_path(const std::string& file) {
  std::vector<Key> keys;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream s(line);
    Key k{};
    if (s >> k.t >> k.p[0] >> k.p[1] >> k.p[2] >> k.buttons) keys.push_back(k);
  }
  std::sort(keys.begin(), keys.end(), [](const Key& a, const Key& b) { return a.t < b.t; });
  return keys;
}

// The pen at t seconds since the scheduler started.
Key pen_at(double t) {
  const std::vector<Key>& path = state().path;
  Key k{t, {0, 0, 0}, 0};
  if (path.empty()) return k;
  if (t <= path.front().t) return path.front();
  if (t >= path.back().t) return path.back();
  const auto next = std::upper_bound(path.begin(), path.end(), t, [](double v, const Key& a) { return v < a.t; });
  const Key& b = *next;
  const Key& a = *(next - 1);
  const double w = b.t > a.t ? (t - a.t) / (b.t - a.t) : 1.0;
  for (int i = 0; i < 3; ++i) k.p[i] = a.p[i] + w * (b.p[i] - a.p[i]);
  k.buttons = a.buttons;
  return k;
}

double frame_seconds() {
  State& s = state();
  return s.in_frame ? s.frame_time : std::chrono::duration<double>(Clock::now() - s.scheduler_start).count();
}

void scheduler_loop() {
  State& s = state();
  // The vendor's scheduler thread runs at a real-time priority: so does this one, where allowed.
  sched_param priority{};
  priority.sched_priority = sched_get_priority_min(SCHED_FIFO);
  pthread_setschedparam(pthread_self(), SCHED_FIFO, &priority);
  const auto period = std::chrono::microseconds(1000);
  auto next = Clock::now() + period;
  while (s.running.load()) {
    {
      std::lock_guard<std::mutex> lock(s.callbacks_mutex);
      std::stable_sort(s.callbacks.begin(), s.callbacks.end(),
                       [](const Callback& a, const Callback& b) { return a.priority > b.priority; });
      for (Callback& c : s.callbacks) {
        if (c.done) continue;
        if (c.fn(c.data) == HD_CALLBACK_DONE) c.done = true;
      }
      // Finished asynchronous ones leave; finished synchronous ones wait for their caller.
      s.callbacks.erase(std::remove_if(s.callbacks.begin(), s.callbacks.end(),
                                       [](const Callback& c) { return c.done && !c.synchronous; }),
                        s.callbacks.end());
    }
    s.callbacks_cv.notify_all();
    std::this_thread::sleep_until(next);
    next += period;
    if (Clock::now() > next + 10 * period) next = Clock::now() + period;
  }
}

}  // namespace

HD_EXPORT HHD hdInitDevice(HDstring name) {
  State& s = state();
  {
    std::lock_guard<std::mutex> lock(s.mutex);
    if (const char* v = std::getenv("KIJI_HD_STANDIN_DEVICE"); v && *v) s.answers_to = v;
    s.fail = std::getenv("KIJI_HD_STANDIN_FAIL") ? std::getenv("KIJI_HD_STANDIN_FAIL") : "";
    s.comm_fail_after = s.fail.rfind("comm:", 0) == 0 ? std::atol(s.fail.c_str() + 5) : -1;
    s.log_path = std::getenv("KIJI_HD_STANDIN_LOG") ? std::getenv("KIJI_HD_STANDIN_LOG") : "";
    s.path.clear();
    s.log.clear();
  }
  s.call("hdInitDevice");
  if (s.fail == "init") {
    push_error(HD_DEVICE_FAULT, 97);
    return HD_INVALID_HANDLE;
  }
  if (name && s.answers_to != name) {
    push_error(HD_COMM_CONFIG_ERROR, 11);
    return HD_INVALID_HANDLE;
  }
  std::lock_guard<std::mutex> lock(s.mutex);
  if (s.initialised) {
    errors.push_back(HDErrorInfo{HD_DEVICE_ALREADY_INITIATED, 0, kDevice});
    return HD_INVALID_HANDLE;
  }
  s.initialised = true;
  s.force_output = false;
  return kDevice;
}

HD_EXPORT void hdMakeCurrentDevice(HHD h) {
  if (h != kDevice || !state().initialised) push_error(HD_BAD_HANDLE);
}

HD_EXPORT HHD hdGetCurrentDevice(void) { return state().initialised ? kDevice : HD_INVALID_HANDLE; }

HD_EXPORT void hdDisableDevice(HHD h) {
  State& s = state();
  if (h != kDevice || !s.initialised) {
    push_error(HD_BAD_HANDLE);
    return;
  }
  s.call("hdDisableDevice");
  {
    std::lock_guard<std::mutex> lock(s.mutex);
    s.initialised = false;
    s.force_output = false;
  }
  s.write_log();
}

HD_EXPORT void hdBeginFrame(HHD h) {
  State& s = state();
  if (h != kDevice) return push_error(HD_BAD_HANDLE);
  if (s.in_frame) return push_error(HD_ILLEGAL_BEGIN);
  s.in_frame = true;
  s.frame_time = std::chrono::duration<double>(Clock::now() - s.scheduler_start).count();
  s.frame_force[0] = s.frame_force[1] = s.frame_force[2] = 0;
}

HD_EXPORT void hdEndFrame(HHD h) {
  State& s = state();
  if (h != kDevice) return push_error(HD_BAD_HANDLE);
  if (!s.in_frame) return push_error(HD_ILLEGAL_END);
  s.in_frame = false;
  const long frame = s.frames++;
  std::ostringstream line;
  line.precision(9);
  const bool on = s.force_output;
  line << "force " << s.frame_time << " " << (on ? s.frame_force[0] : 0.0) << " " << (on ? s.frame_force[1] : 0.0)
       << " " << (on ? s.frame_force[2] : 0.0);
  s.note(line.str());
  if (s.comm_fail_after >= 0 && frame >= s.comm_fail_after) push_error(HD_COMM_ERROR, 5);
}

HD_EXPORT HDErrorInfo hdGetError(void) {
  if (errors.empty()) return HDErrorInfo{HD_SUCCESS, 0, state().initialised ? kDevice : HD_INVALID_HANDLE};
  const HDErrorInfo e = errors.back();
  errors.pop_back();
  return e;
}

HD_EXPORT HDstring hdGetErrorString(HDerror code) {
  switch (code) {
    case HD_SUCCESS: return "No error";
    case HD_INVALID_ENUM: return "Invalid enumerant";
    case HD_INVALID_VALUE: return "Invalid value";
    case HD_INVALID_OPERATION: return "Invalid operation";
    case HD_BAD_HANDLE: return "Invalid device handle";
    case HD_EXCEEDED_MAX_FORCE: return "Exceeded the maximum force";
    case HD_DEVICE_FAULT: return "Device fault (stand-in: told to fail)";
    case HD_DEVICE_ALREADY_INITIATED: return "Device already initiated";
    case HD_COMM_ERROR: return "Communication error";
    case HD_COMM_CONFIG_ERROR: return "Communication configuration error: no device of that name";
    case HD_TIMER_ERROR: return "Timer error (stand-in: told to fail)";
    case HD_ILLEGAL_BEGIN: return "Illegal begin frame";
    case HD_ILLEGAL_END: return "Illegal end frame";
    default: return "Unknown error";
  }
}

HD_EXPORT void hdEnable(HDenum cap) {
  if (cap == HD_FORCE_OUTPUT) {
    state().call("hdEnable(HD_FORCE_OUTPUT)");
    std::lock_guard<std::mutex> lock(state().mutex);
    state().force_output = true;
  } else if (cap != HD_MAX_FORCE_CLAMPING && cap != HD_FORCE_RAMPING && cap != HD_SOFTWARE_FORCE_LIMIT) {
    push_error(HD_INVALID_ENUM);
  }
}

HD_EXPORT void hdDisable(HDenum cap) {
  if (cap == HD_FORCE_OUTPUT) {
    state().call("hdDisable(HD_FORCE_OUTPUT)");
    std::lock_guard<std::mutex> lock(state().mutex);
    state().force_output = false;
  }
}

HD_EXPORT HDboolean hdIsEnabled(HDenum cap) { return cap == HD_FORCE_OUTPUT && state().force_output; }

HD_EXPORT void hdGetDoublev(HDenum name, HDdouble* v) {
  const Key pen = pen_at(frame_seconds());
  switch (name) {
    case HD_CURRENT_POSITION:
    case HD_LAST_POSITION:
      std::copy(pen.p, pen.p + 3, v);
      return;
    case HD_CURRENT_VELOCITY: {
      const double dt = 0.001;
      const Key before = pen_at(frame_seconds() - dt);
      for (int i = 0; i < 3; ++i) v[i] = (pen.p[i] - before.p[i]) / dt;
      return;
    }
    case HD_CURRENT_TRANSFORM: {
      const double m[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, pen.p[0], pen.p[1], pen.p[2], 1};
      std::copy(m, m + 16, v);
      return;
    }
    case HD_CURRENT_FORCE: std::copy(state().frame_force, state().frame_force + 3, v); return;
    case HD_NOMINAL_MAX_FORCE: *v = kMaxForce; return;
    case HD_NOMINAL_MAX_CONTINUOUS_FORCE: *v = kMaxContinuousForce; return;
    case HD_NOMINAL_MAX_STIFFNESS: *v = kMaxStiffness; return;
    case HD_USABLE_WORKSPACE_DIMENSIONS: std::copy(kUsable, kUsable + 6, v); return;
    case HD_MAX_WORKSPACE_DIMENSIONS: std::copy(kMaxWorkspace, kMaxWorkspace + 6, v); return;
    case HD_UPDATE_RATE: *v = 1000; return;
    default: push_error(HD_INVALID_ENUM);
  }
}

HD_EXPORT void hdGetFloatv(HDenum name, HDfloat* v) {
  double d[16];
  hdGetDoublev(name, d);
  const int n = name == HD_CURRENT_TRANSFORM ? 16 : (name == HD_USABLE_WORKSPACE_DIMENSIONS || name == HD_MAX_WORKSPACE_DIMENSIONS) ? 6 : 3;
  for (int i = 0; i < n; ++i) v[i] = static_cast<float>(d[i]);
}

HD_EXPORT void hdGetIntegerv(HDenum name, HDint* v) {
  switch (name) {
    case HD_CURRENT_BUTTONS:
    case HD_LAST_BUTTONS: *v = pen_at(frame_seconds()).buttons; return;
    case HD_CURRENT_SAFETY_SWITCH:
    case HD_CURRENT_INKWELL_SWITCH: *v = 0; return;
    case HD_INPUT_DOF: *v = 6; return;
    case HD_OUTPUT_DOF: *v = 3; return;
    case HD_UPDATE_RATE: *v = 1000; return;
    default: push_error(HD_INVALID_ENUM);
  }
}

HD_EXPORT void hdGetBooleanv(HDenum name, HDboolean* v) {
  HDint i = 0;
  hdGetIntegerv(name, &i);
  *v = i != 0;
}

HD_EXPORT void hdGetLongv(HDenum name, HDlong* v) {
  HDint i = 0;
  hdGetIntegerv(name, &i);
  *v = i;
}

HD_EXPORT HDstring hdGetString(HDenum name) {
  switch (name) {
    case HD_DEVICE_MODEL_TYPE: return "PHANTOM Omni (stand-in)";
    case HD_DEVICE_VENDOR: return "Kiji test stand-in for SensAble Technologies";
    default: push_error(HD_INVALID_ENUM); return nullptr;
  }
}

HD_EXPORT void hdSetDoublev(HDenum name, const HDdouble* v) {
  State& s = state();
  if (name != HD_CURRENT_FORCE) return push_error(HD_INVALID_ENUM);
  if (!s.in_frame) return push_error(HD_INVALID_OPERATION);
  double f[3] = {v[0], v[1], v[2]};
  const double n = std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
  if (!std::isfinite(n)) return push_error(HD_INVALID_VALUE);
  if (n > kMaxForce) {
    push_error(HD_EXCEEDED_MAX_FORCE);
    for (double& x : f) x *= kMaxForce / n;
  }
  std::copy(f, f + 3, s.frame_force);
}

HD_EXPORT void hdSetFloatv(HDenum name, const HDfloat* v) {
  const double d[3] = {v[0], v[1], v[2]};
  hdSetDoublev(name, d);
}

HD_EXPORT HDenum hdCheckCalibration(void) { return HD_CALIBRATION_OK; }
HD_EXPORT void hdUpdateCalibration(HDenum) {}

HD_EXPORT void hdStartScheduler(void) {
  State& s = state();
  s.call("hdStartScheduler");
  if (s.fail == "scheduler") return push_error(HD_TIMER_ERROR, 3);
  if (s.running.exchange(true)) return;
  // The path plays from here: its times count from the scheduler's start.
  const char* path = std::getenv("KIJI_HD_STANDIN_PATH");
  {
    std::lock_guard<std::mutex> lock(s.mutex);
    s.path = path && *path ? read_path(path) : std::vector<Key>{};
  }
  s.scheduler_start = Clock::now();
  s.scheduler = std::thread(scheduler_loop);
}

HD_EXPORT void hdStopScheduler(void) {
  State& s = state();
  s.call("hdStopScheduler");
  if (!s.running.exchange(false)) return;
  if (s.scheduler.joinable()) s.scheduler.join();
}

HD_EXPORT void hdSetSchedulerRate(HDulong) {}

HD_EXPORT HDSchedulerHandle hdScheduleAsynchronous(HDSchedulerCallback fn, void* data, HDushort priority) {
  State& s = state();
  std::ostringstream line;
  line << "call hdScheduleAsynchronous " << s.now() << " priority " << priority;
  s.note(line.str());
  std::lock_guard<std::mutex> lock(s.callbacks_mutex);
  const HDSchedulerHandle h = s.next_handle++;
  s.callbacks.push_back(Callback{h, fn, data, priority, false, false});
  return h;
}

HD_EXPORT void hdScheduleSynchronous(HDSchedulerCallback fn, void* data, HDushort priority) {
  State& s = state();
  if (!s.running.load()) {  // no scheduler thread: run it here, once
    fn(data);
    return;
  }
  std::unique_lock<std::mutex> lock(s.callbacks_mutex);
  const HDSchedulerHandle h = s.next_handle++;
  s.callbacks.push_back(Callback{h, fn, data, priority, true, false});
  s.callbacks_cv.wait(lock, [&] {
    const auto it = std::find_if(s.callbacks.begin(), s.callbacks.end(), [&](const Callback& c) { return c.handle == h; });
    return it == s.callbacks.end() || it->done || !s.running.load();
  });
  s.callbacks.erase(std::remove_if(s.callbacks.begin(), s.callbacks.end(), [&](const Callback& c) { return c.handle == h; }),
                    s.callbacks.end());
}

HD_EXPORT void hdUnschedule(HDSchedulerHandle h) {
  State& s = state();
  s.call("hdUnschedule");
  std::lock_guard<std::mutex> lock(s.callbacks_mutex);
  const auto it = std::find_if(s.callbacks.begin(), s.callbacks.end(), [&](const Callback& c) { return c.handle == h; });
  if (it == s.callbacks.end()) {
    errors.push_back(HDErrorInfo{HD_INVALID_VALUE, 0, kDevice});
    return;
  }
  s.callbacks.erase(it);
}

HD_EXPORT HDboolean hdWaitForCompletion(HDSchedulerHandle h, HDWaitCode code) {
  State& s = state();
  std::unique_lock<std::mutex> lock(s.callbacks_mutex);
  auto scheduled = [&] {
    return std::any_of(s.callbacks.begin(), s.callbacks.end(), [&](const Callback& c) { return c.handle == h && !c.done; });
  };
  if (code == HD_WAIT_CHECK_STATUS) return scheduled();
  s.callbacks_cv.wait(lock, [&] { return !scheduled() || !s.running.load(); });
  return HD_FALSE;
}

HD_EXPORT HDdouble hdGetSchedulerTimeStamp(void) { return frame_seconds(); }
