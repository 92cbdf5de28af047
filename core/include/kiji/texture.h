// The RGBA canvas a garment carries in uv space: paint writes it, export carries it.
#pragma once

#include <cstdint>
#include <vector>

namespace kiji {

struct Texture {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba;  // row 0 is v = 0; 4 bytes a texel

  bool empty() const { return width == 0 || height == 0; }
  // A canvas of the given size filled with one colour.
  static Texture filled(int width, int height, std::uint8_t r, std::uint8_t g, std::uint8_t b,
                        std::uint8_t a = 255);
  std::uint8_t* texel(int x, int y) { return rgba.data() + 4 * (static_cast<std::size_t>(y) * width + x); }
  const std::uint8_t* texel(int x, int y) const {
    return rgba.data() + 4 * (static_cast<std::size_t>(y) * width + x);
  }
};

}  // namespace kiji
