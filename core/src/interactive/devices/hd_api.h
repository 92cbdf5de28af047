// The part of OpenHaptics' HD API (libHD, version 3.x) that the Phantom backend uses: its types and
// values as the vendor's hdDefines.h, hdDevice.h and hdScheduler.h give them, and the table of its
// functions, resolved from the library at run time so that Kiji builds without the vendor's SDK.
#pragma once

#include <climits>

namespace kiji::hd {

using HHD = unsigned int;
using HDenum = unsigned int;
using HDerror = unsigned int;
using HDboolean = unsigned char;
using HDint = int;
using HDdouble = double;
using HDushort = unsigned short;
using HDstring = const char*;
using HDCallbackCode = unsigned int;
using HDSchedulerHandle = unsigned long;
using HDSchedulerCallback = HDCallbackCode (*)(void* user_data);

// Returned by value from hdGetError().
struct HDErrorInfo {
  HDerror errorCode;
  int internalErrorCode;
  HHD hHD;
};

constexpr HDCallbackCode kCallbackDone = 0;
constexpr HDCallbackCode kCallbackContinue = 1;
constexpr HHD kInvalidHandle = 0xFFFFFFFFu;

// Errors.
constexpr HDerror kSuccess = 0x0000;
constexpr HDerror kInvalidEnum = 0x0100;
constexpr HDerror kInvalidValue = 0x0101;
constexpr HDerror kInvalidOperation = 0x0102;
constexpr HDerror kBadHandle = 0x0104;
constexpr HDerror kWarmMotors = 0x0200;
constexpr HDerror kExceededMaxForce = 0x0201;
constexpr HDerror kExceededMaxVelocity = 0x0203;
constexpr HDerror kForceError = 0x0204;
constexpr HDerror kDeviceFault = 0x0300;
constexpr HDerror kDeviceAlreadyInitiated = 0x0301;
constexpr HDerror kCommError = 0x0302;
constexpr HDerror kCommConfigError = 0x0303;
constexpr HDerror kTimerError = 0x0304;
constexpr HDerror kIllegalBegin = 0x0400;
constexpr HDerror kIllegalEnd = 0x0401;
constexpr HDerror kInvalidPriority = 0x0500;
constexpr HDerror kSchedulerFull = 0x0501;
constexpr HDerror kInvalidLicense = 0x0600;

// Parameters.
constexpr HDenum kCurrentButtons = 0x2000;
constexpr HDenum kCurrentSafetySwitch = 0x2001;
constexpr HDenum kCurrentInkwellSwitch = 0x2002;
constexpr HDenum kCurrentPosition = 0x2050;   // 3 doubles, mm
constexpr HDenum kCurrentVelocity = 0x2051;   // 3 doubles, mm/s
constexpr HDenum kCurrentTransform = 0x2052;  // 16 doubles, column-major, translation in mm
constexpr HDenum kDeviceModelType = 0x2501;
constexpr HDenum kDeviceVendor = 0x2503;
constexpr HDenum kMaxWorkspaceDimensions = 0x2550;     // 6 doubles: min xyz, max xyz, mm
constexpr HDenum kUsableWorkspaceDimensions = 0x2551;  // 6 doubles: min xyz, max xyz, mm
constexpr HDenum kUpdateRate = 0x2600;
constexpr HDenum kNominalMaxStiffness = 0x2602;        // N/mm
constexpr HDenum kNominalMaxForce = 0x2603;            // N
constexpr HDenum kNominalMaxContinuousForce = 0x2604;  // N
constexpr HDenum kCurrentForce = 0x2700;               // 3 doubles, N

// Capabilities.
constexpr HDenum kForceOutput = 0x4000;

// Scheduler priorities (higher runs first).
constexpr HDushort kMaxSchedulerPriority = USHRT_MAX;

// Calibration.
constexpr HDenum kCalibrationOk = 0x5000;
constexpr HDenum kCalibrationNeedsUpdate = 0x5001;
constexpr HDenum kCalibrationNeedsManualInput = 0x5002;

// Stylus buttons in HD_CURRENT_BUTTONS.
constexpr int kDeviceButton1 = 1 << 0;
constexpr int kDeviceButton2 = 1 << 1;

// hduIsSchedulerError (a static helper library in the SDK): errors after which the servo loop
// cannot go on.
inline bool is_scheduler_error(HDerror code) {
  return code == kCommError || code == kCommConfigError || code == kTimerError || code == kInvalidPriority ||
         code == kSchedulerFull;
}

// The functions, resolved by name with dlsym (plain C calling convention on Linux x86-64).
struct Functions {
  HHD (*hdInitDevice)(HDstring config_name);
  void (*hdDisableDevice)(HHD device);
  HHD (*hdGetCurrentDevice)();
  void (*hdMakeCurrentDevice)(HHD device);
  void (*hdBeginFrame)(HHD device);
  void (*hdEndFrame)(HHD device);
  HDErrorInfo (*hdGetError)();
  HDstring (*hdGetErrorString)(HDerror code);
  void (*hdEnable)(HDenum capability);
  void (*hdDisable)(HDenum capability);
  void (*hdGetIntegerv)(HDenum name, HDint* values);
  void (*hdGetDoublev)(HDenum name, HDdouble* values);
  HDstring (*hdGetString)(HDenum name);
  void (*hdSetDoublev)(HDenum name, const HDdouble* values);
  HDenum (*hdCheckCalibration)();
  void (*hdStartScheduler)();
  void (*hdStopScheduler)();
  HDSchedulerHandle (*hdScheduleAsynchronous)(HDSchedulerCallback callback, void* data, HDushort priority);
  void (*hdScheduleSynchronous)(HDSchedulerCallback callback, void* data, HDushort priority);
  void (*hdUnschedule)(HDSchedulerHandle handle);
};

}  // namespace kiji::hd
