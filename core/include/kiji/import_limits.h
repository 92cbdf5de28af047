// How a mesh file is read: assimp runs in a child process, so that a file which crashes it, exhausts
// memory or never ends costs only that process, not the user's session.
#pragma once

#include <cstddef>

namespace kiji {

struct ImportLimits {
  // Memory the reading process may take beyond what this process had when it started it, in MiB.
  // A file that needs more is refused; raise it for a very large scan.
  std::size_t memory_mb = 4096;
  // Wall-clock seconds the reading may take before it is stopped and the file refused.
  double seconds = 120;
  // false: read in this process, without the limits (for a debugger, or a fuzzer that needs the
  // reader's coverage). A file that crashes assimp then crashes the process.
  bool isolate = true;
};

}  // namespace kiji
