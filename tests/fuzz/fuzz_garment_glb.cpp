// Garment import from glTF binary bytes (kiji::import_garment): any bytes give a garment or an InputError.
#include "fuzz_input.h"
#include "kiji/error.h"
#include "kiji/io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const kiji::Garment g = kiji::import_garment(kiji::fuzz::write_input(data, size, ".glb"));
    if (!g.is_valid()) __builtin_trap();  // an imported garment is always a valid mesh
  } catch (const kiji::InputError&) {
  }
  return 0;
}
