// Body import (kiji::Body::load) from the bytes of any format a user may give: the first byte picks
// the file's extension, which picks assimp's importer; any bytes give a body or an InputError.
#include "fuzz_input.h"
#include "kiji/body.h"
#include "kiji/error.h"

#include <cmath>
#include <iterator>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const char* const extensions[] = {".obj", ".glb", ".dae", ".stl", ".ply", ".fbx", ".off", ".gltf"};
  if (size < 1) return 0;
  const char* extension = extensions[data[0] % std::size(extensions)];
  // In this process, so that the fuzzer sees the reader's coverage and its crashes.
  kiji::BodyImportOptions options;
  options.limits.isolate = false;
  try {
    const kiji::Body b = kiji::Body::load(kiji::fuzz::write_input(data + 1, size - 1, extension), options);
    // A body is in metres, finite, and made of triangles of its own vertices.
    for (const kiji::Vec3& p : b.vertices())
      if (!p.allFinite()) __builtin_trap();
    for (const auto& t : b.triangles())
      for (int k : t)
        if (k < 0 || static_cast<std::size_t>(k) >= b.vertices().size()) __builtin_trap();
  } catch (const kiji::InputError&) {
  }
  return 0;
}
