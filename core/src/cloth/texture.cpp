#include "kiji/texture.h"

#include "kiji/error.h"

namespace kiji {

Texture Texture::filled(int width, int height, std::uint8_t r, std::uint8_t g, std::uint8_t b,
                        std::uint8_t a) {
  if (width <= 0 || height <= 0 || width > 16384 || height > 16384)
    throw InputError("texture size " + std::to_string(width) + "x" + std::to_string(height) +
                     " is out of range: use 1 to 16384 texels a side");
  Texture t;
  t.width = width;
  t.height = height;
  t.rgba.resize(static_cast<std::size_t>(width) * height * 4);
  for (std::size_t i = 0; i < t.rgba.size(); i += 4) {
    t.rgba[i] = r;
    t.rgba[i + 1] = g;
    t.rgba[i + 2] = b;
    t.rgba[i + 3] = a;
  }
  return t;
}

}  // namespace kiji
