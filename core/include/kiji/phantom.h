// A SensAble / 3D Systems Phantom (Omni, Touch, Desktop, Premium) through OpenHaptics' HD library,
// opened at run time with dlopen so that Kiji builds and runs without the vendor's SDK and uses a
// Phantom where its driver is installed.
//
// The HD scheduler's servo loop (1 kHz, highest priority) calls the haptic loop's tick between
// reading the device and writing its force, so the force is computed from the sample of the same
// servo frame. Positions come in millimetres in the device's frame (Y up, +Z towards the user) and
// go out in world metres through a WorkspaceMapping; forces go the other way.
#pragma once

#include "kiji/haptics.h"
#include "kiji/workspace_mapping.h"

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace kiji {

struct PhantomOptions {
  // The HD library to open. Empty: $KIJI_HD_LIBRARY if set, else libHD.so, libHD.so.3.4,
  // libHD.so.3.0 and libHD.so.3, in that order, on the dynamic loader's path.
  std::string library;
  // The device configuration to open, as named in the vendor's setup tool ("Default Device",
  // "Default PHANToM"). Empty: HD_DEFAULT_DEVICE. Some set-ups open only by name, others only
  // with the default.
  std::string device_name;
  // The stylus's two buttons swapped: the front (dark grey) one is primary unless this is set.
  bool swap_buttons = false;
};

// What the device says about itself once it is open.
struct PhantomInfo {
  std::string library;             // the file the HD library was opened from
  std::string device_name;         // the configuration opened ("HD_DEFAULT_DEVICE" for the default)
  std::string model;               // HD_DEVICE_MODEL_TYPE
  std::string vendor;              // HD_DEVICE_VENDOR
  double max_force = 0;            // HD_NOMINAL_MAX_FORCE, N (a peak)
  double max_continuous_force = 0;  // HD_NOMINAL_MAX_CONTINUOUS_FORCE, N: what the loop clamps to
  double max_stiffness = 0;        // HD_NOMINAL_MAX_STIFFNESS, N/m
  Box3 workspace;                  // HD_USABLE_WORKSPACE_DIMENSIONS, metres, device axes
  std::string calibration;         // "ok", "needs update" (move the pen through its range, or put it
                                   // in its inkwell) or "needs manual input"
};

// Where the servo loop stands, for the app's status line.
struct PhantomStatus {
  bool servo_running = false;
  std::size_t servo_errors = 0;  // HD errors met in servo frames
  unsigned last_error = 0;       // the latest one's HD error code (0: none)
  std::string last_error_text;   // "HD_COMM_ERROR (0x0302): <the library's description>"
  bool servo_stopped_by_error = false;  // a scheduler error ended the servo loop
};

class PhantomDevice : public InputDevice {
 public:
  // Opens the library and the device and reads its properties; the servo loop starts with the
  // haptic loop. Throws DeviceError (with the HD error code and the library's description, or the
  // loader's message) when the library is missing or not an HD library, or the device fails to
  // initialise; nothing is left open then.
  explicit PhantomDevice(const PhantomOptions& options = {});
  // Stops the servo loop if it runs and disables the device, in the vendor's order, with zero
  // force written last.
  ~PhantomDevice() override;
  PhantomDevice(const PhantomDevice&) = delete;
  PhantomDevice& operator=(const PhantomDevice&) = delete;

  std::string name() const override;
  // Called from the servo loop (the haptic loop's tick): the stylus as the current frame read it.
  ToolEvent sample() override;
  void set_force(const Vec3& force) override;
  double max_force() const override { return info_.max_continuous_force; }
  bool has_servo_loop() const override { return true; }
  // Schedules the servo callback at HD_MAX_SCHEDULER_PRIORITY, enables force output and starts the
  // scheduler. Throws DeviceError if the scheduler fails to start (nothing is left scheduled).
  void start_servo_loop(std::function<void()> tick) override;
  // Writes zero force for a few frames, then stops the scheduler and unschedules the callback.
  void stop_servo_loop() override;
  Box3 workspace() const override { return info_.workspace; }
  std::uint64_t workspace_version() const override { return mapping_version_.load(); }

  const PhantomInfo& info() const { return info_; }
  PhantomStatus status() const;
  // The device's place in the world; safe to call while the servo loop runs (the haptic loop then
  // ramps its forces up again).
  void set_mapping(const WorkspaceMapping& mapping);  // validates
  WorkspaceMapping mapping() const;

  // The library files tried, in order, for an explicit path (or none).
  static std::vector<std::string> library_candidates(const std::string& explicit_path);

 private:
  struct Library;
  static unsigned servo_callback(void* self);
  unsigned servo_frame();
  std::string describe(unsigned code) const;

  PhantomOptions options_;
  std::shared_ptr<Library> hd_;
  unsigned handle_ = 0;  // HHD
  unsigned long scheduled_ = 0;  // HDSchedulerHandle of the servo callback
  bool scheduled_valid_ = false;
  PhantomInfo info_;
  std::function<void()> tick_;
  std::shared_ptr<const WorkspaceMapping> mapping_;  // std::atomic_load/store
  std::atomic<std::uint64_t> mapping_version_{1};

  // Servo-frame state (written and read in the servo loop's thread).
  double transform_[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  int buttons_ = 0;
  double force_[3] = {0, 0, 0};
  double clock_start_ = 0;
  std::atomic<bool> servo_running_{false};
  std::atomic<bool> stopping_{false};
  std::atomic<int> zero_frames_{0};
  std::atomic<std::size_t> servo_errors_{0};
  std::atomic<unsigned> last_error_{0};
  std::atomic<bool> stopped_by_error_{false};
};

}  // namespace kiji
