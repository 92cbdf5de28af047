// check_nudge <build folder> <installed plugin folder>: loads the nudge tool from where the build put
// it and, through the default search path, from where it was installed beside an installed Kiji,
// then runs a stroke with it through a Session. Exits non-zero, saying what failed, on any failure.
#include <kiji/pattern.h>
#include <kiji/plugin_loader.h>
#include <kiji/session.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

namespace fs = std::filesystem;

namespace {

int failures = 0;

void check(bool ok, const std::string& what) {
  std::cout << (ok ? "ok:     " : "FAILED: ") << what << "\n";
  if (!ok) ++failures;
}

void print(const std::vector<kiji::PluginReport>& reports) {
  for (const auto& r : reports)
    std::cout << "  " << (r.loaded ? "loaded  " : "refused ") << r.path << (r.loaded ? "" : ": " + r.message) << "\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: check_nudge <build folder> <installed plugin folder>\n";
    return 2;
  }
  const fs::path build = fs::canonical(argv[1]);
  const fs::path installed = fs::canonical(argv[2]);

  // 1. From the author's build folder: kiji_add_tool() put the library and its metadata there.
  check(fs::exists(build / "kiji_nudge.so") && fs::exists(build / "kiji_nudge.json"),
        "kiji_nudge.so and kiji_nudge.json are in the build folder");
  kiji::ToolRegistry from_build;
  auto reports = from_build.load_plugins({build.string()});
  print(reports);
  check(from_build.has("nudge"), "nudge loads from the build folder");

  // 2. Installed: libkiji finds lib/kiji/plugins beside itself, with no KIJI_PLUGIN_PATH.
  const auto path = kiji::ToolRegistry::default_search_path();
  check(std::find(path.begin(), path.end(), installed.string()) != path.end(),
        "the default search path has " + installed.string());
  auto registry = std::make_shared<kiji::ToolRegistry>();
  reports = registry->load_plugins();
  print(reports);
  if (!registry->has("nudge")) {
    check(false, "nudge loads from the default search path");
    return 1;
  }
  check(registry->origin("nudge") == (installed / "kiji_nudge.so").string(), "nudge comes from the installed folder");
  const kiji::ToolInfo info = registry->info("nudge");
  check(info.label == "Nudge" && info.parameters.size() == 1 && info.parameters[0].name == "strength",
        "nudge's info is what it declares");

  // 3. A stroke through a session: the vertex under the pointer follows it.
  kiji::Session session(registry);
  session.set_simulating(false);
  session.add_garment(kiji::make_rectangle(1.0, 1.0, 5, 5));
  const kiji::Vertex v(12);
  const kiji::Vec3 start = session.garment(0).position(v);
  const kiji::Vec3 target = start + kiji::Vec3(0.1, 0.2, 0.3);
  kiji::ToolEvent e;
  e.phase = kiji::Phase::Begin;
  e.position = start;
  kiji::Stroke stroke{e};
  e.phase = kiji::Phase::Move;
  e.position = target;
  e.time = 0.1;
  stroke.push_back(e);
  e.phase = kiji::Phase::End;
  stroke.push_back(e);
  session.run("nudge", session.params_for("nudge"), stroke);
  check((session.garment(0).position(v) - target).norm() < 1e-12, "the grabbed vertex follows the pointer");
  check(session.journal().entries().size() == 2 && session.journal().entries().back().tool == "nudge",
        "the stroke is journaled");
  check(session.undo() && (session.garment(0).position(v) - start).norm() < 1e-12, "undo puts it back");

  std::cout << (failures ? "external tool check FAILED\n" : "external tool check passed\n");
  return failures ? 1 : 0;
}
