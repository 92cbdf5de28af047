// PNG decoding (kiji::read_png, which garment import's textures share): any bytes give an image of
// the size it says or an InputError.
#include "fuzz_input.h"
#include "kiji/error.h"
#include "kiji/render.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const kiji::Image image = kiji::read_png(kiji::fuzz::write_input(data, size, ".png"));
    if (image.width <= 0 || image.height <= 0 ||
        image.rgba.size() != static_cast<std::size_t>(image.width) * image.height * 4)
      __builtin_trap();
  } catch (const kiji::InputError&) {
  }
  return 0;
}
