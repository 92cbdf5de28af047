// kiji-studio's command line: the scene to start with, the device, and scripted runs for tests and
// demos (run for a while, write what was asked, exit). Parsed and checked before any window opens,
// with a message that names the option and what it takes.
#pragma once

#include "scene_setup.h"

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace kiji::studio {

class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct StudioOptions {
  std::optional<std::string> body;
  // As `kiji drape` and Python's Body.load read a body: turned to face the camera, a low-poly one
  // rounded (--front, --no-smooth change that), so that a figure drapes alike in each.
  BodyImportOptions body_options = [] {
    BodyImportOptions b;
    b.find_front = true;
    b.smooth = true;
    return b;
  }();
  std::vector<GarmentSpec> garments;
  std::string device = "mouse";  // mouse | phantom | none
  std::string hd_library, hd_device;
  std::optional<std::string> tool;
  std::optional<std::string> edges;  // all | local | none
  bool paused = false;
  double drape_seconds = 0;
  std::optional<std::string> replay, open_session;
  std::optional<std::string> autosave_dir;  // default: the app's data folder
  bool no_autosave = false, recover = false;
  std::vector<std::string> python;  // lines for the console, run in order once the window is up
  std::optional<double> quit_after;
  std::optional<std::string> screenshot, window_screenshot, save_journal, save_session, export_garment;
  // A shared session (as kiji peer's options): host it, or join one.
  bool host = false, join = false;
  std::optional<std::string> url, channel, name, key_file, save_peers;
  double seconds = 0;  // (host) the shared clock stops here; a scripted run ends once all agree there
  int width = 1280, height = 800;
  bool benchmark = false;
  std::vector<int> bench_sizes{529, 5041, 19881};
  std::vector<std::string> bench_tools;  // empty: every tool
  double bench_seconds = 3.0;
  bool help = false, version = false;

  // Throws UsageError for an unknown option, a missing or malformed value, or a value out of range.
  static StudioOptions parse(const std::vector<std::string>& args);
  static std::string usage();
};

}  // namespace kiji::studio
