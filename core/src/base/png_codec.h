// PNG encoding and decoding in memory (libpng's simplified API), shared by the garment files and
// the renderer. Private to libkiji.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace kiji::detail {

// RGBA8 texels, `height` rows of `width`; flip_rows writes the last row first.
// Returns false and sets `error` when libpng refuses.
bool encode_png(int width, int height, const std::uint8_t* rgba, bool flip_rows,
                std::vector<std::uint8_t>& out, std::string& error);

// The largest image decoded: 16,384 pixels a side and 67,108,864 pixels (256 MiB as RGBA8, an
// 8192 x 8192 texture, the paint tool's largest). A file declares its size in its first bytes, so a
// few bytes could otherwise ask for gigabytes.
constexpr std::uint32_t kMaxImageSide = 16384;
constexpr std::uint64_t kMaxImagePixels = std::uint64_t(8192) * 8192;
// "" when an image of this size may be decoded, else why not (the size and the limit).
std::string image_size_problem(std::uint64_t width, std::uint64_t height);

// Decodes any PNG into RGBA8; flip_rows puts the file's last row first. Refuses, before allocating
// anything for the pixels, an image over the limits above or one larger than a file of `size`
// bytes can hold.
bool decode_png(const std::uint8_t* data, std::size_t size, bool flip_rows, int& width, int& height,
                std::vector<std::uint8_t>& rgba, std::string& error);

// The largest PNG file read: an image at the limits above stored without compression, and more.
constexpr std::uint64_t kMaxPngFileBytes = std::uint64_t(512) << 20;

// Whole files, read or written in one go. read_file reads only a regular file of at most
// `max_bytes` (a FIFO would block, a device never end); otherwise it says why in `error`.
bool read_file(const std::string& path, std::uint64_t max_bytes, std::vector<std::uint8_t>& out, std::string& error);
// write_file writes only a new or a regular file (opening a FIFO to write waits for a reader).
bool write_file(const std::string& path, const std::vector<std::uint8_t>& data, std::string& error);

}  // namespace kiji::detail
