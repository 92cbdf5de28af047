// Helpers for tests of PNG input: a PNG's header rewritten to declare another image size, as a
// corrupt or crafted file would.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace kiji::test {

inline std::uint32_t crc32(const unsigned char* data, std::size_t n) {
  std::uint32_t c = 0xffffffffu;
  for (std::size_t i = 0; i < n; ++i) {
    c ^= data[i];
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return c ^ 0xffffffffu;
}

inline void put_be32(std::string& s, std::size_t at, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) s[at + k] = static_cast<char>((v >> (24 - 8 * k)) & 0xff);
}

// Rewrites the IHDR of the PNG starting at `png` within `bytes` to declare width x height, with a
// correct checksum, so that only the size is wrong. Returns false if no PNG header is there.
inline bool declare_png_size(std::string& bytes, std::size_t png, std::uint32_t width, std::uint32_t height) {
  if (bytes.compare(png, 8, "\x89PNG\r\n\x1a\n") != 0 || bytes.compare(png + 12, 4, "IHDR") != 0) return false;
  put_be32(bytes, png + 16, width);
  put_be32(bytes, png + 20, height);
  const auto* chunk = reinterpret_cast<const unsigned char*>(bytes.data() + png + 12);
  put_be32(bytes, png + 29, crc32(chunk, 17));  // over the type and the 13 bytes of data
  return true;
}

}  // namespace kiji::test
