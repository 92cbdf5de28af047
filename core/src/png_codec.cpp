// PNG in memory and the write_png / read_png of render.h, on libpng's simplified API (which
// reports errors in png_image::message instead of longjmp-ing through our frames).
#include "png_codec.h"

#include "kiji/error.h"
#include "kiji/render.h"

#include <png.h>

#include <filesystem>
#include <fstream>
#include <iterator>

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

bool decode_png(const std::uint8_t* data, std::size_t size, bool flip_rows, int& width, int& height,
                std::vector<std::uint8_t>& rgba, std::string& error) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (size < 8 || png_sig_cmp(data, 0, 8) != 0) {
    error = "not a PNG file (no PNG signature)";
    return false;
  }
  if (!png_image_begin_read_from_memory(&image, data, size)) {
    error = image.message;
    png_image_free(&image);
    return false;
  }
  image.format = PNG_FORMAT_RGBA;
  if (image.width == 0 || image.height == 0 || image.width > 32768 || image.height > 32768) {
    error = "image size " + std::to_string(image.width) + "x" + std::to_string(image.height) +
            " is out of range";
    png_image_free(&image);
    return false;
  }
  width = static_cast<int>(image.width);
  height = static_cast<int>(image.height);
  rgba.assign(PNG_IMAGE_SIZE(image), 0);
  const png_int_32 stride = (flip_rows ? -1 : 1) * static_cast<png_int_32>(4 * width);
  if (!png_image_finish_read(&image, nullptr, rgba.data(), stride, nullptr)) {
    error = image.message;
    png_image_free(&image);
    return false;
  }
  return true;
}

bool read_file(const std::string& path, std::vector<std::uint8_t>& out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  out.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return !in.bad();
}

bool write_file(const std::string& path, const std::vector<std::uint8_t>& data) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) return false;
  out.write(reinterpret_cast<const char*>(data.data()), static_cast<std::streamsize>(data.size()));
  out.close();
  return static_cast<bool>(out);
}

}  // namespace detail

void write_png(const Image& image, const std::string& path) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgba.size() != static_cast<std::size_t>(image.width) * image.height * 4)
    throw InputError("cannot write PNG '" + path + "': the image is " + std::to_string(image.width) + "x" +
                     std::to_string(image.height) + " with " + std::to_string(image.rgba.size()) +
                     " bytes; it needs a positive size and 4 bytes a pixel");
  std::vector<std::uint8_t> bytes;
  std::string error;
  if (!detail::encode_png(image.width, image.height, image.rgba.data(), false, bytes, error))
    throw InputError("cannot write PNG '" + path + "': " + error);
  if (!detail::write_file(path, bytes))
    throw InputError("cannot write PNG '" + path + "': the file cannot be created; check that the folder "
                     "exists and is writable");
}

Image read_png(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError("cannot read PNG '" + path + "': " +
                     (std::filesystem::exists(path, ec) ? "it is not a regular file" : "the file does not exist") +
                     "; check the path");
  std::vector<std::uint8_t> bytes;
  if (!detail::read_file(path, bytes))
    throw InputError("cannot read PNG '" + path + "': the file cannot be opened; check its permissions");
  Image image;
  std::string error;
  if (!detail::decode_png(bytes.data(), bytes.size(), false, image.width, image.height, image.rgba, error))
    throw InputError("cannot read PNG '" + path + "': " + error + "; give a PNG image");
  return image;
}

}  // namespace kiji
