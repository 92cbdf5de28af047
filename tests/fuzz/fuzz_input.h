// What every fuzz target shares: the fuzzer's bytes put in a file (Kiji's parsers of outside bytes
// read files, and are fuzzed through the same entry points users call), and the rule that an
// InputError is the right answer to bad bytes while anything else escaping is a finding.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace kiji::fuzz {

// A file holding the bytes, named with the extension given, in a folder of this process's own
// (in memory where the system has one), rewritten for every input.
inline std::string write_input(const std::uint8_t* data, std::size_t size, const std::string& extension) {
  namespace fs = std::filesystem;
  // Removed at a normal exit; scripts/fuzz.sh removes those of runs that ended on a finding.
  struct Folder {
    fs::path path;
    Folder() {
      std::error_code ec;
      const fs::path base = fs::is_directory("/dev/shm", ec) ? fs::path("/dev/shm") : fs::temp_directory_path();
      path = base / ("kiji-fuzz-" + std::to_string(getpid()));
      fs::create_directories(path);
    }
    ~Folder() {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  };
  static const Folder dir;
  const fs::path path = dir.path / ("input" + extension);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path.string();
}

}  // namespace kiji::fuzz
