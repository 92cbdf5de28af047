// Garment import from glTF binary bytes (kiji::import_garment): any bytes give a garment or an InputError.
#include "fuzz_input.h"
#include "kiji/error.h"
#include "kiji/io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // In this process, so that the fuzzer sees the reader's coverage and its crashes.
  kiji::ImportLimits in_process;
  in_process.isolate = false;
  try {
    const kiji::Garment g = kiji::import_garment(kiji::fuzz::write_input(data, size, ".glb"), {}, in_process);
    if (!g.is_valid()) __builtin_trap();  // an imported garment is always a valid mesh
  } catch (const kiji::InputError&) {
  }
  return 0;
}
