// A picture of the scene without a window: a small software rasteriser, for reports and tests.
#pragma once

#include "kiji/body.h"
#include "kiji/garment.h"

#include <cstdint>
#include <string>
#include <vector>

namespace kiji {

struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba;  // row 0 at the top
};

struct Camera {
  Vec3 eye{0.0, 1.2, 3.0};
  Vec3 target{0.0, 1.0, 0.0};
  Vec3 up{0.0, 1.0, 0.0};
  double fov_degrees = 35.0;
  // A camera in front of (+Z) the box, framing all of it.
  static Camera framing(const Box3& box);
};

// Draws the body (grey) and the garments (their texture, or their colour), lit from the camera.
Image render(const std::vector<const Garment*>& garments, const Body* body, const Camera& camera,
             int width, int height);

// Which of `points` a picture from `camera` shows: each is inside the picture, in front of the
// camera, and no drawn surface lies more than `tolerance` metres nearer the camera along its pixel's
// ray. A point on a surface the picture shows counts as seen; one behind a fold or the body does not.
std::vector<bool> visible_points(const std::vector<const Garment*>& garments, const Body* body, const Camera& camera,
                                 int width, int height, const std::vector<Vec3>& points, double tolerance = 0.005);

// PNG files (libpng). write_png throws InputError if the file cannot be written; read_png if it
// cannot be read or is not a PNG.
void write_png(const Image& image, const std::string& path);
Image read_png(const std::string& path);

}  // namespace kiji
