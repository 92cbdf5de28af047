#include "kiji/phantom.h"

#include "interactive/devices/hd_api.h"

#include <dlfcn.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <thread>

namespace kiji {

namespace {

const char* error_name(unsigned code) {
  switch (code) {
    case hd::kSuccess: return "HD_SUCCESS";
    case hd::kInvalidEnum: return "HD_INVALID_ENUM";
    case hd::kInvalidValue: return "HD_INVALID_VALUE";
    case hd::kInvalidOperation: return "HD_INVALID_OPERATION";
    case hd::kBadHandle: return "HD_BAD_HANDLE";
    case hd::kWarmMotors: return "HD_WARM_MOTORS";
    case hd::kExceededMaxForce: return "HD_EXCEEDED_MAX_FORCE";
    case hd::kExceededMaxVelocity: return "HD_EXCEEDED_MAX_VELOCITY";
    case hd::kForceError: return "HD_FORCE_ERROR";
    case hd::kDeviceFault: return "HD_DEVICE_FAULT";
    case hd::kDeviceAlreadyInitiated: return "HD_DEVICE_ALREADY_INITIATED";
    case hd::kCommError: return "HD_COMM_ERROR";
    case hd::kCommConfigError: return "HD_COMM_CONFIG_ERROR";
    case hd::kTimerError: return "HD_TIMER_ERROR";
    case hd::kIllegalBegin: return "HD_ILLEGAL_BEGIN";
    case hd::kIllegalEnd: return "HD_ILLEGAL_END";
    case hd::kInvalidPriority: return "HD_INVALID_PRIORITY";
    case hd::kSchedulerFull: return "HD_SCHEDULER_FULL";
    case hd::kInvalidLicense: return "HD_INVALID_LICENSE";
    default: return "HD error";
  }
}

std::string hex(unsigned code) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%04X", code);
  return buf;
}

double seconds_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

// The opened library and its function table. Never closed: CHAI3D found dlclose of libHD unsafe
// (the driver leaves threads behind), and a second device reuses the loaded library.
struct PhantomDevice::Library {
  std::string path;
  hd::Functions fn{};
};

std::vector<std::string> PhantomDevice::library_candidates(const std::string& explicit_path) {
  if (!explicit_path.empty()) return {explicit_path};
  if (const char* env = std::getenv("KIJI_HD_LIBRARY"); env && *env) return {env};
  return {"libHD.so", "libHD.so.3.4", "libHD.so.3.0", "libHD.so.3"};
}

namespace {

std::shared_ptr<void> open_library(const std::vector<std::string>& candidates, bool explicit_path, std::string& path) {
  std::string tried;
  for (const std::string& c : candidates) {
    dlerror();
    if (void* h = dlopen(c.c_str(), RTLD_NOW | RTLD_LOCAL)) {
      path = c;
      return std::shared_ptr<void>(h, [](void*) {});
    }
    const char* err = dlerror();
    tried += "\n  " + c + ": " + (err ? err : "cannot be opened");
  }
  if (explicit_path)
    throw DeviceError("OpenHaptics' HD library could not be opened:" + tried +
                      "\nCheck the path in KIJI_HD_LIBRARY (or the Device settings), or unset it to search the "
                      "system's library path.");
  throw DeviceError("OpenHaptics' HD library was not found:" + tried +
                    "\nInstall the OpenHaptics runtime and your device's driver (Geomagic/3D Systems Touch or "
                    "Phantom), or set KIJI_HD_LIBRARY to the path of libHD.so.");
}

template <typename Fn>
void resolve(void* handle, const char* symbol, Fn& fn, const std::string& path) {
  dlerror();
  void* p = dlsym(handle, symbol);
  if (!p) {
    throw DeviceError("'" + path + "' is not an OpenHaptics HD library of version 3: it has no " + symbol +
                      ". Point KIJI_HD_LIBRARY at libHD.so from the OpenHaptics runtime.");
  }
  fn = reinterpret_cast<Fn>(p);
}

}  // namespace

std::string PhantomDevice::describe(unsigned code) const {
  const char* text = hd_ && hd_->fn.hdGetErrorString ? hd_->fn.hdGetErrorString(code) : nullptr;
  return std::string(error_name(code)) + " (" + hex(code) + ")" + (text && *text ? std::string(": ") + text : "");
}

PhantomDevice::PhantomDevice(const PhantomOptions& options) : options_(options) {
  mapping_ = std::make_shared<const WorkspaceMapping>();
  const auto candidates = library_candidates(options.library);
  const bool explicit_path = !options.library.empty() || (std::getenv("KIJI_HD_LIBRARY") && *std::getenv("KIJI_HD_LIBRARY"));
  std::string path;
  std::shared_ptr<void> handle = open_library(candidates, explicit_path, path);
  auto lib = std::make_shared<Library>();
  lib->path = path;
  hd::Functions& f = lib->fn;
  void* h = handle.get();
  resolve(h, "hdInitDevice", f.hdInitDevice, path);
  resolve(h, "hdDisableDevice", f.hdDisableDevice, path);
  resolve(h, "hdGetCurrentDevice", f.hdGetCurrentDevice, path);
  resolve(h, "hdMakeCurrentDevice", f.hdMakeCurrentDevice, path);
  resolve(h, "hdBeginFrame", f.hdBeginFrame, path);
  resolve(h, "hdEndFrame", f.hdEndFrame, path);
  resolve(h, "hdGetError", f.hdGetError, path);
  resolve(h, "hdGetErrorString", f.hdGetErrorString, path);
  resolve(h, "hdEnable", f.hdEnable, path);
  resolve(h, "hdDisable", f.hdDisable, path);
  resolve(h, "hdGetIntegerv", f.hdGetIntegerv, path);
  resolve(h, "hdGetDoublev", f.hdGetDoublev, path);
  resolve(h, "hdGetString", f.hdGetString, path);
  resolve(h, "hdSetDoublev", f.hdSetDoublev, path);
  resolve(h, "hdCheckCalibration", f.hdCheckCalibration, path);
  resolve(h, "hdStartScheduler", f.hdStartScheduler, path);
  resolve(h, "hdStopScheduler", f.hdStopScheduler, path);
  resolve(h, "hdScheduleAsynchronous", f.hdScheduleAsynchronous, path);
  resolve(h, "hdScheduleSynchronous", f.hdScheduleSynchronous, path);
  resolve(h, "hdUnschedule", f.hdUnschedule, path);
  hd_ = std::move(lib);

  // Errors left on the stack by another user of the library would be read as ours.
  for (int i = 0; i < 64 && f.hdGetError().errorCode != hd::kSuccess; ++i) {
  }
  const char* config = options.device_name.empty() ? nullptr : options.device_name.c_str();
  const hd::HHD device = f.hdInitDevice(config);
  const hd::HDErrorInfo init = f.hdGetError();
  const std::string shown = options.device_name.empty() ? "HD_DEFAULT_DEVICE" : "\"" + options.device_name + "\"";
  if (init.errorCode != hd::kSuccess || device == hd::kInvalidHandle) {
    const unsigned code = init.errorCode != hd::kSuccess ? init.errorCode : hd::kBadHandle;
    throw DeviceError("hdInitDevice(" + shown + ") failed: " + describe(code) + " (internal error " +
                          std::to_string(init.internalErrorCode) +
                          "). Check that the device is plugged in and powered, that its setup tool finds it, and "
                          "try the device name your setup uses (\"Default Device\", \"Default PHANToM\") in the "
                          "Device settings.",
                      code);
  }
  handle_ = device;
  f.hdMakeCurrentDevice(device);
  info_.library = path;
  info_.device_name = options.device_name.empty() ? "HD_DEFAULT_DEVICE" : options.device_name;
  if (const char* s = f.hdGetString(hd::kDeviceModelType)) info_.model = s;
  if (const char* s = f.hdGetString(hd::kDeviceVendor)) info_.vendor = s;
  double v = 0;
  f.hdGetDoublev(hd::kNominalMaxForce, &v);
  info_.max_force = v;
  v = 0;
  f.hdGetDoublev(hd::kNominalMaxContinuousForce, &v);
  info_.max_continuous_force = v;
  v = 0;
  f.hdGetDoublev(hd::kNominalMaxStiffness, &v);
  info_.max_stiffness = 1000.0 * v;  // N/mm
  double dims[6] = {0, 0, 0, 0, 0, 0};
  f.hdGetDoublev(hd::kUsableWorkspaceDimensions, dims);
  info_.workspace = Box3(Vec3(dims[0], dims[1], dims[2]) / 1000.0, Vec3(dims[3], dims[4], dims[5]) / 1000.0);
  const hd::HDenum calibration = f.hdCheckCalibration();
  info_.calibration = calibration == hd::kCalibrationOk                ? "ok"
                      : calibration == hd::kCalibrationNeedsUpdate     ? "needs update"
                      : calibration == hd::kCalibrationNeedsManualInput ? "needs manual input"
                                                                        : "unknown";
  // A parameter a model does not have is an error on the stack, not a reason to refuse the device.
  for (int i = 0; i < 64 && f.hdGetError().errorCode != hd::kSuccess; ++i) {
  }
  // A device that reports no continuous maximum gets the smallest of the Phantom family's (the
  // Omni's 0.88 N), and no peak the Omni's and Touch's 3.3 N.
  if (!(info_.max_continuous_force > 0) || !std::isfinite(info_.max_continuous_force)) info_.max_continuous_force = 0.88;
  if (!(info_.max_force > 0) || !std::isfinite(info_.max_force)) info_.max_force = 3.3;
  if (info_.workspace.isEmpty() || info_.workspace.sizes().minCoeff() <= 0)
    info_.workspace = Box3(Vec3(-0.08, -0.06, -0.035), Vec3(0.08, 0.06, 0.035));  // an Omni's usable box
}

PhantomDevice::~PhantomDevice() {
  stop_servo_loop();
  if (hd_) hd_->fn.hdDisableDevice(handle_);
}

std::string PhantomDevice::name() const {
  std::string n = info_.model.empty() ? "Phantom" : info_.model;
  return n + " (" + info_.device_name + ")";
}

unsigned PhantomDevice::servo_callback(void* self) {
  // Nothing may unwind into the vendor's C library.
  try {
    return static_cast<PhantomDevice*>(self)->servo_frame();
  } catch (...) {
    return hd::kCallbackContinue;
  }
}

unsigned PhantomDevice::servo_frame() {
  const hd::Functions& f = hd_->fn;
  const hd::HHD device = f.hdGetCurrentDevice();
  f.hdBeginFrame(device);
  f.hdGetDoublev(hd::kCurrentTransform, transform_);
  f.hdGetIntegerv(hd::kCurrentButtons, &buttons_);
  force_[0] = force_[1] = force_[2] = 0;
  const bool stopping = stopping_.load(std::memory_order_acquire);
  if (!stopping && tick_) tick_();  // the haptic loop: sample(), the tool's force, set_force()
  if (stopping) force_[0] = force_[1] = force_[2] = 0;
  f.hdSetDoublev(hd::kCurrentForce, force_);
  f.hdEndFrame(device);
  if (stopping) zero_frames_.fetch_add(1, std::memory_order_release);
  bool fatal = false;
  for (int i = 0; i < 8; ++i) {
    const hd::HDErrorInfo e = f.hdGetError();
    if (e.errorCode == hd::kSuccess) break;
    servo_errors_.fetch_add(1, std::memory_order_relaxed);
    last_error_.store(e.errorCode, std::memory_order_relaxed);
    fatal = fatal || hd::is_scheduler_error(e.errorCode);
  }
  if (fatal) {
    stopped_by_error_ = true;
    return hd::kCallbackDone;
  }
  return hd::kCallbackContinue;
}

ToolEvent PhantomDevice::sample() {
  const std::shared_ptr<const WorkspaceMapping> m = std::atomic_load(&mapping_);
  const double* t = transform_;
  Eigen::Matrix3d r;
  r << t[0], t[4], t[8], t[1], t[5], t[9], t[2], t[6], t[10];  // column-major
  const Vec3 position_mm(t[12], t[13], t[14]);
  ToolEvent e;
  e.phase = Phase::Move;
  e.time = seconds_now() - clock_start_;
  e.position = m->to_world(position_mm / 1000.0);
  Eigen::Quaterniond q(r);
  e.orientation = (m->rotation * q.normalized()).normalized();
  const bool b1 = buttons_ & hd::kDeviceButton1, b2 = buttons_ & hd::kDeviceButton2;
  const bool primary = options_.swap_buttons ? b2 : b1, secondary = options_.swap_buttons ? b1 : b2;
  e.buttons = (primary ? kButtonPrimary : 0u) | (secondary ? kButtonSecondary : 0u);
  e.pressure = 1.0;
  return e;
}

void PhantomDevice::set_force(const Vec3& force) {
  if (!servo_running_.load(std::memory_order_relaxed)) return;  // outside the servo loop: nothing to write
  const std::shared_ptr<const WorkspaceMapping> m = std::atomic_load(&mapping_);
  const Vec3 d = m->force_to_device(force);
  force_[0] = d.x();
  force_[1] = d.y();
  force_[2] = d.z();
}

void PhantomDevice::start_servo_loop(std::function<void()> tick) {
  if (servo_running_.load()) return;
  const hd::Functions& f = hd_->fn;
  tick_ = std::move(tick);
  stopping_ = false;
  stopped_by_error_ = false;
  zero_frames_ = 0;
  clock_start_ = seconds_now();
  for (int i = 0; i < 64 && f.hdGetError().errorCode != hd::kSuccess; ++i) {
  }
  f.hdMakeCurrentDevice(handle_);
  // The vendor's order: schedule the servo callback, enable force output, start the scheduler.
  servo_running_ = true;
  scheduled_ = f.hdScheduleAsynchronous(&PhantomDevice::servo_callback, this, hd::kMaxSchedulerPriority);
  hd::HDErrorInfo e = f.hdGetError();
  if (e.errorCode == hd::kSuccess) {
    scheduled_valid_ = true;
    f.hdEnable(hd::kForceOutput);
    f.hdStartScheduler();
    e = f.hdGetError();
  }
  if (e.errorCode != hd::kSuccess) {
    if (scheduled_valid_) {
      f.hdStopScheduler();
      f.hdUnschedule(scheduled_);
      scheduled_valid_ = false;
    }
    servo_running_ = false;
    tick_ = nullptr;
    for (int i = 0; i < 64 && f.hdGetError().errorCode != hd::kSuccess; ++i) {
    }
    throw DeviceError("the HD scheduler failed to start: " + describe(e.errorCode) + " (internal error " +
                          std::to_string(e.internalErrorCode) +
                          "). Another program may hold the device, or the servo thread could not get its "
                          "priority; close other haptic programs and try again.",
                      e.errorCode);
  }
}

void PhantomDevice::stop_servo_loop() {
  if (!servo_running_.load()) return;
  const hd::Functions& f = hd_->fn;
  // Zero force first, for a few frames the device has surely rendered; a scheduler that stopped on
  // an error runs no frame, and the wait ends at its limit.
  stopping_.store(true, std::memory_order_release);
  const auto limit = std::chrono::steady_clock::now() + std::chrono::milliseconds(100);
  while (zero_frames_.load(std::memory_order_acquire) < 3 && !stopped_by_error_ &&
         std::chrono::steady_clock::now() < limit)
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  // The vendor's order: stop the scheduler, unschedule the callback (the device is disabled last,
  // in the destructor).
  f.hdStopScheduler();
  if (scheduled_valid_) f.hdUnschedule(scheduled_);
  scheduled_valid_ = false;
  for (int i = 0; i < 64 && f.hdGetError().errorCode != hd::kSuccess; ++i) {
  }
  servo_running_ = false;
  tick_ = nullptr;
}

PhantomStatus PhantomDevice::status() const {
  PhantomStatus s;
  s.servo_running = servo_running_.load() && !stopped_by_error_.load();
  s.servo_errors = servo_errors_.load();
  s.last_error = last_error_.load();
  if (s.last_error) s.last_error_text = describe(s.last_error);
  s.servo_stopped_by_error = stopped_by_error_.load();
  return s;
}

void PhantomDevice::set_mapping(const WorkspaceMapping& mapping) {
  mapping.validate();
  std::atomic_store(&mapping_, std::shared_ptr<const WorkspaceMapping>(std::make_shared<WorkspaceMapping>(mapping)));
  mapping_version_.fetch_add(1);
}

WorkspaceMapping PhantomDevice::mapping() const { return *std::atomic_load(&mapping_); }

}  // namespace kiji
