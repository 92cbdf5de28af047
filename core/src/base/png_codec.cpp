// PNG in memory, on libpng's simplified API (which reports errors in png_image::message instead of
// longjmp-ing through our frames).
#include "base/png_codec.h"

#include "kiji/error.h"

#include <png.h>

#include <filesystem>
#include <fstream>

namespace kiji {

namespace detail {

bool encode_png(int width, int height, const std::uint8_t* rgba, bool flip_rows,
                std::vector<std::uint8_t>& out, std::string& error) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = PNG_FORMAT_RGBA;
  const png_int_32 stride = (flip_rows ? -1 : 1) * static_cast<png_int_32>(4 * width);
  png_alloc_size_t size = 0;
  if (!png_image_write_get_memory_size(image, size, 0, rgba, stride, nullptr)) {
    error = image.message;
    png_image_free(&image);
    return false;
  }
  out.resize(size);
  if (!png_image_write_to_memory(&image, out.data(), &size, 0, rgba, stride, nullptr)) {
    error = image.message;
    png_image_free(&image);
    return false;
  }
  out.resize(size);
  return true;
}

std::string image_size_problem(std::uint64_t width, std::uint64_t height) {
  if (width == 0 || height == 0)
    return "image size " + std::to_string(width) + "x" + std::to_string(height) + " is empty";
  if (width > kMaxImageSide || height > kMaxImageSide || width * height > kMaxImagePixels)
    return "image size " + std::to_string(width) + "x" + std::to_string(height) + " is larger than Kiji reads (at most " +
           std::to_string(kMaxImageSide) + " pixels a side and " + std::to_string(kMaxImagePixels) +
           " pixels in all, 256 MiB as RGBA)";
  return {};
}

bool decode_png(const std::uint8_t* data, std::size_t size, bool flip_rows, int& width, int& height,
                std::vector<std::uint8_t>& rgba, std::string& error) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!data || size < 8 || png_sig_cmp(data, 0, 8) != 0) {
    error = "not a PNG file (no PNG signature)";
    return false;
  }
  if (!png_image_begin_read_from_memory(&image, data, size)) {
    error = image.message;
    png_image_free(&image);
    return false;
  }
  image.format = PNG_FORMAT_RGBA;
  error = image_size_problem(image.width, image.height);
  // The scanlines take at least one bit a pixel and a filter byte a row, and deflate packs at most
  // 1032 bytes into one: a file too small for the size it declares is corrupt or crafted, and is
  // refused before its pixels are allocated.
  const std::uint64_t least_scanline_bytes = std::uint64_t(image.height) * (1 + (std::uint64_t(image.width) + 7) / 8);
  if (error.empty() && least_scanline_bytes > std::uint64_t(size) * 1032 + 1024)
    error = "the file is " + std::to_string(size) + " bytes but declares a " + std::to_string(image.width) + "x" +
            std::to_string(image.height) + " image, more than a PNG file of its size can hold: it is corrupt";
  if (!error.empty()) {
    png_image_free(&image);
    return false;
  }
  width = static_cast<int>(image.width);
  height = static_cast<int>(image.height);
  rgba.assign(std::size_t(4) * image.width * image.height, 0);
  const png_int_32 stride = (flip_rows ? -1 : 1) * static_cast<png_int_32>(4 * width);
  if (!png_image_finish_read(&image, nullptr, rgba.data(), stride, nullptr)) {
    error = image.message;
    png_image_free(&image);
    rgba.clear();
    return false;
  }
  return true;
}

bool read_file(const std::string& path, std::uint64_t max_bytes, std::vector<std::uint8_t>& out, std::string& error) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    error = fs::exists(path, ec) ? "it is not a regular file" : "the file does not exist";
    return false;
  }
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec || size > max_bytes) {
    error = ec ? "its size cannot be read" : "it is " + std::to_string(size) + " bytes, more than the " +
                                                 std::to_string(max_bytes) + " Kiji reads";
    return false;
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    error = "the file cannot be opened; check its permissions";
    return false;
  }
  out.resize(size);
  in.read(reinterpret_cast<char*>(out.data()), static_cast<std::streamsize>(size));
  if (static_cast<std::uintmax_t>(in.gcount()) != size) {
    error = "the file could not be read to its end";
    return false;
  }
  return true;
}

bool write_file(const std::string& path, const std::vector<std::uint8_t>& data, std::string& error) {
  std::error_code ec;
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec)) {
    error = "it exists and is not a regular file (a folder, a FIFO or a device); give the path of a file";
    return false;
  }
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) {
    error = "the file cannot be created; check that the folder exists and is writable";
    return false;
  }
  out.write(reinterpret_cast<const char*>(data.data()), static_cast<std::streamsize>(data.size()));
  out.close();
  if (!out) error = "writing it failed; check the disk has room";
  return static_cast<bool>(out);
}

}  // namespace detail

}  // namespace kiji
