// The Phantom backend against the stand-in HD library (tests/fixtures/hd_standin), opened through dlopen as
// libHD would be: what the device is told, in what order, and what force it renders.
#include "kiji/pattern.h"
#include "kiji/phantom.h"
#include "kiji/session.h"

#include "fixtures/hd_standin/hd_record.h"
#include "support/wait.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

using namespace kiji;

namespace {

std::shared_ptr<ToolRegistry> plugins() {
  static auto r = [] {
    auto reg = std::make_shared<ToolRegistry>();
    reg->load_plugins({KIJI_PLUGIN_DIR});
    return reg;
  }();
  return r;
}

const std::string kTmp = KIJI_TEST_TMP;

using test::wait_until;

// The stand-in's configuration for one test, undone after it.
class StandIn : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    log_ = kTmp + "/hd_standin_" + name + ".log";
    path_file_ = kTmp + "/hd_standin_" + name + ".path";
    std::remove(log_.c_str());
    setenv("KIJI_HD_STANDIN_LOG", log_.c_str(), 1);
    unsetenv("KIJI_HD_STANDIN_FAIL");
    unsetenv("KIJI_HD_STANDIN_PATH");
    unsetenv("KIJI_HD_LIBRARY");
  }
  void TearDown() override {
    unsetenv("KIJI_HD_STANDIN_LOG");
    unsetenv("KIJI_HD_STANDIN_FAIL");
    unsetenv("KIJI_HD_STANDIN_PATH");
  }
  // The pen's path: lines "t x y z buttons" (s, mm, device frame).
  void play(const std::string& lines) {
    std::ofstream(path_file_) << lines;
    setenv("KIJI_HD_STANDIN_PATH", path_file_.c_str(), 1);
  }
  PhantomOptions options() const {
    PhantomOptions o;
    o.library = KIJI_HD_STANDIN;
    return o;
  }
  std::string log_, path_file_;
};

ToolEvent at(const Vec3& p, Phase phase) {
  ToolEvent e;
  e.phase = phase;
  e.position = p;
  return e;
}

template <typename F>
DeviceError device_error(F&& f) {
  try {
    f();
  } catch (const DeviceError& e) {
    return e;
  }
  ADD_FAILURE() << "expected a DeviceError";
  return DeviceError("none");
}

}  // namespace

TEST_F(StandIn, AMissingLibraryIsAClearErrorNamingWhatWasTried) {
  PhantomOptions o;
  o.library = kTmp + "/no-such-dir/libHD.so";
  const DeviceError e = device_error([&] { PhantomDevice d(o); });
  const std::string m = e.what();
  EXPECT_NE(m.find(o.library), std::string::npos) << m;
  EXPECT_NE(m.find("KIJI_HD_LIBRARY"), std::string::npos) << m;
  // Without a path, the usual names are tried in order (none is on this machine's library path).
  EXPECT_EQ(PhantomDevice::library_candidates(""),
            (std::vector<std::string>{"libHD.so", "libHD.so.3.4", "libHD.so.3.0", "libHD.so.3"}));
  setenv("KIJI_HD_LIBRARY", "/opt/OpenHaptics/lib/libHD.so", 1);
  EXPECT_EQ(PhantomDevice::library_candidates(""), (std::vector<std::string>{"/opt/OpenHaptics/lib/libHD.so"}));
}

TEST_F(StandIn, ALibraryThatIsNotHdIsRefusedByName) {
  PhantomOptions o;
  o.library = "libz.so.1";  // loads, but has no hdInitDevice
  const std::string m = device_error([&] { PhantomDevice d(o); }).what();
  EXPECT_NE(m.find("not an OpenHaptics HD library"), std::string::npos) << m;
  EXPECT_NE(m.find("hdInitDevice"), std::string::npos) << m;
}

TEST_F(StandIn, OpensTheDeviceAndReadsWhatItIs) {
  PhantomDevice d(options());
  const PhantomInfo& i = d.info();
  EXPECT_EQ(i.library, KIJI_HD_STANDIN);
  EXPECT_EQ(i.device_name, "HD_DEFAULT_DEVICE");
  EXPECT_NE(i.model.find("Omni"), std::string::npos) << i.model;
  EXPECT_DOUBLE_EQ(i.max_continuous_force, 0.88);
  EXPECT_DOUBLE_EQ(i.max_force, 3.3);
  EXPECT_DOUBLE_EQ(i.max_stiffness, 700.0) << "0.7 N/mm";
  EXPECT_TRUE(i.workspace.sizes().isApprox(Vec3(0.160, 0.120, 0.070))) << "millimetres became metres";
  EXPECT_EQ(i.calibration, "ok");
  EXPECT_DOUBLE_EQ(d.max_force(), 0.88) << "the loop clamps to the continuous maximum";
}

TEST_F(StandIn, AFailedInitCarriesTheHdCodeAndItsDescription) {
  setenv("KIJI_HD_STANDIN_FAIL", "init", 1);
  const DeviceError e = device_error([&] { PhantomDevice d(options()); });
  EXPECT_EQ(e.code(), 0x0300u);
  const std::string m = e.what();
  EXPECT_NE(m.find("hdInitDevice(HD_DEFAULT_DEVICE)"), std::string::npos) << m;
  EXPECT_NE(m.find("HD_DEVICE_FAULT (0x0300)"), std::string::npos) << m;
  EXPECT_NE(m.find("Device fault"), std::string::npos) << "the library's own description: " << m;
  EXPECT_NE(m.find("internal error 97"), std::string::npos) << m;
}

TEST_F(StandIn, TheDeviceNameIsASetting) {
  PhantomOptions o = options();
  o.device_name = "Default PHANToM";  // not what this set-up calls it
  const DeviceError e = device_error([&] { PhantomDevice d(o); });
  EXPECT_EQ(e.code(), 0x0303u) << e.what();
  EXPECT_NE(std::string(e.what()).find("\"Default PHANToM\""), std::string::npos) << e.what();
  o.device_name = "Default Device";
  PhantomDevice d(o);
  EXPECT_EQ(d.info().device_name, "Default Device");
}

TEST_F(StandIn, AFailedSchedulerIsAnErrorAndLeavesNothingScheduled) {
  setenv("KIJI_HD_STANDIN_FAIL", "scheduler", 1);
  {
    PhantomDevice d(options());
    HapticLoop loop(d);
    const DeviceError e = device_error([&] { loop.start(); });
    EXPECT_EQ(e.code(), 0x0304u);
    EXPECT_NE(std::string(e.what()).find("HD_TIMER_ERROR (0x0304)"), std::string::npos) << e.what();
    EXPECT_FALSE(loop.running());
  }
  const test::HdRecord r = test::read_hd_record(log_);
  EXPECT_EQ(r.calls, (std::vector<std::string>{"hdInitDevice", "hdScheduleAsynchronous", "hdEnable(HD_FORCE_OUTPUT)",
                                                "hdStartScheduler", "hdStopScheduler", "hdUnschedule",
                                                "hdDisableDevice"}));
}

TEST_F(StandIn, APinchFeltThroughTheServoLoopInTheVendorsOrder) {
  // The pen held 50 mm above the device's origin, which the mapping puts at the grabbed vertex.
  play("0 0 50 0 1\n10 0 50 0 1\n");
  auto s = std::make_unique<Session>(plugins());
  s->add_garment(make_rectangle(1.0, 1.0, 21, 21));
  s->set_simulating(false);
  ParamSet p = s->params_for("pinch", {{"stiffness", 10.0}});
  s->apply("pinch", at(Vec3(0.5, 0.5, 0.0), Phase::Begin), &p);
  {
    PhantomDevice device(options());
    WorkspaceMapping m;
    m.offset = Vec3(0.5, 0.5, 0.0);
    m.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX()));  // device +Y is world +Z
    device.set_mapping(m);
    HapticOptions o;
    o.ramp_s = 0.3;
    HapticLoop loop(device, o);
    loop.set_tool(&s->tool("pinch"));
    loop.publish(std::make_shared<HapticSnapshot>(take_snapshot(*s, 0, Vec3(0.5, 0.5, 0.05), 0.1)));
    loop.start();
    EXPECT_TRUE(loop.latest_sample().position.isApprox(Vec3(0.5, 0.5, 0.05), 1e-9))
        << "50 mm up on the device is 0.05 m along world +Z: " << loop.latest_sample().position.transpose();
    EXPECT_EQ(loop.latest_sample().buttons, kButtonPrimary);
    // The spring pulls the hand back down to the cloth: 10 N/m * 0.05 m = 0.5 N along world -Z,
    // which is the device's -Y, once the 0.3 s ramp is over (its ticks counted, however late they came).
    EXPECT_TRUE(wait_until([&] { return loop.latest_force().isApprox(Vec3(0, 0, -0.5), 1e-6); }))
        << loop.latest_force().transpose();
    std::this_thread::sleep_for(std::chrono::milliseconds(200));  // frames held at the spring's force
    s->apply("pinch", at(Vec3(0.5, 0.5, 0.05), Phase::End));
    EXPECT_TRUE(wait_until([&] { return loop.latest_force() == Vec3::Zero(); })) << loop.latest_force().transpose();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));  // frames of zero after the release
    const HapticStats stats = loop.stats();
    loop.stop();
    EXPECT_EQ(stats.tool_errors + stats.device_errors, 0u) << stats.last_error;
    EXPECT_TRUE(device.status().last_error == 0) << device.status().last_error_text;
  }
  const test::HdRecord r = test::read_hd_record(log_);
  EXPECT_EQ(r.calls, (std::vector<std::string>{"hdInitDevice", "hdScheduleAsynchronous", "hdEnable(HD_FORCE_OUTPUT)",
                                                "hdStartScheduler", "hdStopScheduler", "hdUnschedule",
                                                "hdDisableDevice"}));
  bool highest = false;
  for (const std::string& l : r.lines) highest = highest || l.find("priority 65535") != std::string::npos;
  EXPECT_TRUE(highest) << "the servo callback runs at HD_MAX_SCHEDULER_PRIORITY";
  EXPECT_TRUE(r.errors.empty()) << "the device raised HD error 0x" << std::hex << (r.errors.empty() ? 0 : r.errors[0]);
  ASSERT_GT(r.forces.size(), 500u);
  // About 1 kHz: the frames' times span the run.
  const double span = r.forces.back().first - r.forces.front().first;
  EXPECT_GT(r.forces.size() / span, 700.0);
  EXPECT_LT(r.forces.size() / span, 1300.0);
  // Never above the continuous maximum; up from nothing along the ramp; the spring along the
  // device's -Y while held; zero after the release and in the last frames before the scheduler stopped.
  double peak = 0;
  std::size_t held = 0, last_nonzero = 0;
  for (std::size_t i = 0; i < r.forces.size(); ++i) {
    const Vec3& f = r.forces[i].second;
    ASSERT_LE(f.norm(), 0.88 + 1e-9) << "frame " << i;
    // Up the 0.3 s ramp by at most its slope (1.5 * 0.5 N / 0.3 s = 2.5 mN a frame, a late frame a
    // few times that); elsewhere, a change of the tool's force (the release) spreads over the 3 ms
    // filter: at most 28 % of it a frame.
    if (i > 0) {
      const double step = (f - r.forces[i - 1].second).norm();
      ASSERT_LE(step, r.forces[i].first < 0.3 ? 0.02 : 0.3 * 0.5 + 1e-9) << "a jump at frame " << i;
    }
    peak = std::max(peak, f.norm());
    if (f.isApprox(Vec3(0, -0.5, 0), 1e-6)) ++held;
    if (f.norm() > 0) last_nonzero = i;
  }
  EXPECT_LT(r.forces.front().second.norm(), 0.01);
  EXPECT_NEAR(peak, 0.5, 1e-6);
  EXPECT_GT(held, 100u);
  EXPECT_LT(last_nonzero + 50, r.forces.size()) << "zero for the frames after the release";
  EXPECT_EQ(r.forces.back().second, Vec3::Zero());
}

TEST_F(StandIn, ThePensButtonsAndTheirSwap) {
  // Each state held for 0.15 s: more than a loaded machine's stall of the loop.
  play("0 0 0 0 0\n0.15 0 0 0 1\n0.30 0 0 0 2\n0.45 0 0 0 0\n");
  for (bool swap : {false, true}) {
    PhantomOptions o = options();
    o.swap_buttons = swap;
    PhantomDevice device(o);
    HapticLoop loop(device);
    loop.start();
    std::this_thread::sleep_for(std::chrono::milliseconds(650));
    loop.stop();
    const std::vector<ToolEvent> changes = loop.take_button_changes();
    ASSERT_EQ(changes.size(), 3u);
    EXPECT_EQ(changes[0].buttons, swap ? kButtonSecondary : kButtonPrimary);
    EXPECT_EQ(changes[1].buttons, swap ? kButtonPrimary : kButtonSecondary);
    EXPECT_EQ(changes[2].buttons, 0u);
  }
}

TEST_F(StandIn, ALostConnectionStopsTheServoLoopAndSaysSo) {
  setenv("KIJI_HD_STANDIN_FAIL", "comm:100", 1);
  PhantomDevice device(options());
  HapticLoop loop(device);
  loop.start();
  EXPECT_TRUE(wait_until([&] { return device.status().servo_stopped_by_error; }));
  const PhantomStatus st = device.status();
  EXPECT_TRUE(st.servo_stopped_by_error);
  EXPECT_FALSE(st.servo_running);
  EXPECT_EQ(st.last_error, 0x0302u);
  EXPECT_NE(st.last_error_text.find("HD_COMM_ERROR (0x0302): Communication error"), std::string::npos)
      << st.last_error_text;
  loop.stop();  // and shuts down as usual
}

TEST_F(StandIn, TheLibraryIsFoundOnTheLoadersPathByItsUsualName) {
  // As a user with OpenHaptics installed has it: no setting, libHD.so on the library path. This
  // process's loader path was fixed at start, so ask a child process with the stand-in's folder on it.
  const std::string dir = KIJI_HD_STANDIN_DIR;
  const std::string cmd = "LD_LIBRARY_PATH=" + dir + " " + std::string(KIJI_HD_PROBE) + " > " + kTmp + "/hd_probe.out 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << std::ifstream(kTmp + "/hd_probe.out").rdbuf();
  std::stringstream out;
  out << std::ifstream(kTmp + "/hd_probe.out").rdbuf();
  EXPECT_NE(out.str().find("libHD.so"), std::string::npos) << out.str();
}
