// Images as PNG files (kiji/render.h): write_png and read_png.
#include "kiji/render.h"

#include "base/png_codec.h"
#include "kiji/error.h"

namespace kiji {

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
  if (!detail::write_file(path, bytes, error)) throw InputError("cannot write PNG '" + path + "': " + error);
}

Image read_png(const std::string& path) {
  std::vector<std::uint8_t> bytes;
  std::string error;
  if (!detail::read_file(path, detail::kMaxPngFileBytes, bytes, error))
    throw InputError("cannot read PNG '" + path + "': " + error + "; check the path");
  Image image;
  if (!detail::decode_png(bytes.data(), bytes.size(), false, image.width, image.height, image.rgba, error))
    throw InputError("cannot read PNG '" + path + "': " + error + "; give a PNG image");
  return image;
}

}  // namespace kiji
