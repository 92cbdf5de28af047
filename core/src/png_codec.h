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

// Decodes any PNG into RGBA8; flip_rows puts the file's last row first.
bool decode_png(const std::uint8_t* data, std::size_t size, bool flip_rows, int& width, int& height,
                std::vector<std::uint8_t>& rgba, std::string& error);

// Whole files, read or written in one go.
bool read_file(const std::string& path, std::vector<std::uint8_t>& out);
bool write_file(const std::string& path, const std::vector<std::uint8_t>& data);

}  // namespace kiji::detail
