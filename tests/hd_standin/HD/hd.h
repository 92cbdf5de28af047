/* The HD API of OpenHaptics 3.x as the stand-in library implements it: the types, values and
   functions of the vendor's hdDefines.h, hdDevice.h and hdScheduler.h that a servo loop uses,
   written from the vendor's published headers. */
#ifndef KIJI_HD_STANDIN_HD_H
#define KIJI_HD_STANDIN_HD_H

#include <limits.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef unsigned int HDuint;
typedef unsigned char HDboolean;
typedef unsigned long HDulong;
typedef unsigned short HDushort;
typedef int HDint;
typedef float HDfloat;
typedef double HDdouble;
typedef long HDlong;
typedef char HDchar;
typedef unsigned int HDerror;
typedef unsigned int HDenum;
typedef const char* HDstring;
typedef unsigned int HHD;

typedef struct {
  HDerror errorCode;
  int internalErrorCode;
  HHD hHD;
} HDErrorInfo;

#define HD_TRUE 1
#define HD_FALSE 0

#define HD_SUCCESS 0x0000
#define HD_INVALID_ENUM 0x0100
#define HD_INVALID_VALUE 0x0101
#define HD_INVALID_OPERATION 0x0102
#define HD_INVALID_INPUT_TYPE 0x0103
#define HD_BAD_HANDLE 0x0104
#define HD_WARM_MOTORS 0x0200
#define HD_EXCEEDED_MAX_FORCE 0x0201
#define HD_EXCEEDED_MAX_FORCE_IMPULSE 0x0202
#define HD_EXCEEDED_MAX_VELOCITY 0x0203
#define HD_FORCE_ERROR 0x0204
#define HD_DEVICE_FAULT 0x0300
#define HD_DEVICE_ALREADY_INITIATED 0x0301
#define HD_COMM_ERROR 0x0302
#define HD_COMM_CONFIG_ERROR 0x0303
#define HD_TIMER_ERROR 0x0304
#define HD_ILLEGAL_BEGIN 0x0400
#define HD_ILLEGAL_END 0x0401
#define HD_FRAME_ERROR 0x0402
#define HD_INVALID_PRIORITY 0x0500
#define HD_SCHEDULER_FULL 0x0501
#define HD_INVALID_LICENSE 0x0600

#define HD_CURRENT_BUTTONS 0x2000
#define HD_CURRENT_SAFETY_SWITCH 0x2001
#define HD_CURRENT_INKWELL_SWITCH 0x2002
#define HD_CURRENT_POSITION 0x2050
#define HD_CURRENT_VELOCITY 0x2051
#define HD_CURRENT_TRANSFORM 0x2052
#define HD_CURRENT_ANGULAR_VELOCITY 0x2053
#define HD_CURRENT_GIMBAL_ANGLES 0x2150
#define HD_LAST_BUTTONS 0x2200
#define HD_LAST_POSITION 0x2250
#define HD_DEVICE_MODEL_TYPE 0x2501
#define HD_DEVICE_VENDOR 0x2503
#define HD_MAX_WORKSPACE_DIMENSIONS 0x2550
#define HD_USABLE_WORKSPACE_DIMENSIONS 0x2551
#define HD_TABLETOP_OFFSET 0x2552
#define HD_INPUT_DOF 0x2553
#define HD_OUTPUT_DOF 0x2554
#define HD_UPDATE_RATE 0x2600
#define HD_NOMINAL_MAX_STIFFNESS 0x2602
#define HD_NOMINAL_MAX_FORCE 0x2603
#define HD_NOMINAL_MAX_CONTINUOUS_FORCE 0x2604
#define HD_NOMINAL_MAX_DAMPING 0x2609
#define HD_CURRENT_FORCE 0x2700
#define HD_CURRENT_TORQUE 0x2701

#define HD_FORCE_OUTPUT 0x4000
#define HD_MAX_FORCE_CLAMPING 0x4001
#define HD_FORCE_RAMPING 0x4002
#define HD_SOFTWARE_FORCE_LIMIT 0x4003

#define HD_MAX_SCHEDULER_PRIORITY USHRT_MAX
#define HD_MIN_SCHEDULER_PRIORITY 0
#define HD_DEFAULT_SCHEDULER_PRIORITY ((HD_MAX_SCHEDULER_PRIORITY + HD_MIN_SCHEDULER_PRIORITY) / 2)

#define HD_CALIBRATION_OK 0x5000
#define HD_CALIBRATION_NEEDS_UPDATE 0x5001
#define HD_CALIBRATION_NEEDS_MANUAL_INPUT 0x5002

#define HD_DEVICE_BUTTON_1 (1 << 0)
#define HD_DEVICE_BUTTON_2 (1 << 1)

#define HD_INVALID_HANDLE 0xFFFFFFFF
#define HD_DEFAULT_DEVICE NULL

typedef unsigned int HDCallbackCode;
#define HD_CALLBACK_DONE 0
#define HD_CALLBACK_CONTINUE 1
typedef unsigned long HDSchedulerHandle;
typedef HDCallbackCode (*HDSchedulerCallback)(void* pUserData);
typedef unsigned int HDWaitCode;
#define HD_WAIT_CHECK_STATUS 0
#define HD_WAIT_INFINITE 1

HHD hdInitDevice(HDstring pConfigName);
void hdMakeCurrentDevice(HHD hHD);
void hdDisableDevice(HHD hHD);
HHD hdGetCurrentDevice(void);
void hdBeginFrame(HHD hHD);
void hdEndFrame(HHD hHD);
HDErrorInfo hdGetError(void);
HDstring hdGetErrorString(HDerror errorCode);
void hdEnable(HDenum cap);
void hdDisable(HDenum cap);
HDboolean hdIsEnabled(HDenum cap);
void hdGetBooleanv(HDenum pname, HDboolean* params);
void hdGetIntegerv(HDenum pname, HDint* params);
void hdGetFloatv(HDenum pname, HDfloat* params);
void hdGetDoublev(HDenum pname, HDdouble* params);
void hdGetLongv(HDenum pname, HDlong* params);
HDstring hdGetString(HDenum pname);
void hdSetFloatv(HDenum pname, const HDfloat* params);
void hdSetDoublev(HDenum pname, const HDdouble* params);
HDenum hdCheckCalibration(void);
void hdUpdateCalibration(HDenum style);

void hdStartScheduler(void);
void hdStopScheduler(void);
void hdSetSchedulerRate(HDulong nRate);
void hdScheduleSynchronous(HDSchedulerCallback pCallback, void* pUserData, HDushort nPriority);
HDSchedulerHandle hdScheduleAsynchronous(HDSchedulerCallback pCallback, void* pUserData, HDushort nPriority);
void hdUnschedule(HDSchedulerHandle hHandle);
HDboolean hdWaitForCompletion(HDSchedulerHandle hHandle, HDWaitCode param);
HDdouble hdGetSchedulerTimeStamp(void);

#ifdef __cplusplus
}
#endif

#endif
