// kiji bench: runs kiji-bench, the benchmark program built beside this one (bench/), in this
// process's place, so that the user's command line does not link Bullet's soft body.
#include "commands.h"
#include "kiji/error.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

namespace kiji::cli {

int bench_program(const std::vector<std::string>& args) {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) throw Error("cannot find where this program is (/proc/self/exe: " + ec.message() + ")");
  const std::string program = (self.parent_path() / "kiji-bench").string();
  std::vector<char*> argv{const_cast<char*>(program.c_str())};
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  execv(program.c_str(), argv.data());
  const int error = errno;
  if (error == ENOENT)
    throw Error("the benchmark program " + program +
                " is missing: build it with the apps (cmake --build build --target kiji_bench)");
  throw Error("cannot run the benchmark program " + program + ": " + std::strerror(error));
}

}  // namespace kiji::cli
