// The software renderer and PNG files: what is drawn where, depth, textures, and PNG errors.
#include "kiji/error.h"
#include "kiji/pattern.h"
#include "kiji/render.h"
#include "support/test_errors.h"
#include "support/test_png.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

using namespace kiji;

namespace {

std::string tmp_path(const std::string& name) {
  std::filesystem::create_directories(KIJI_TEST_TMP);
  return std::string(KIJI_TEST_TMP) + "/" + name;
}

struct Rgb {
  int r, g, b;
};
Rgb pixel(const Image& img, int x, int y) {
  const std::uint8_t* p = &img.rgba[4 * (static_cast<std::size_t>(y) * img.width + x)];
  return {p[0], p[1], p[2]};
}

int srgb(double linear) {
  const double c = linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1 / 2.4) - 0.055;
  return static_cast<int>(std::lround(255 * c));
}

bool near(const Rgb& a, const Rgb& b, int tol) {
  return std::abs(a.r - b.r) <= tol && std::abs(a.g - b.g) <= tol && std::abs(a.b - b.b) <= tol;
}

// The background is light and neutral.
bool is_background(const Rgb& c) {
  return c.r > 180 && std::abs(c.r - c.g) <= 6 && std::abs(c.r - c.b) <= 6;
}

// A 1 x 1 m square of cloth centred on the origin in the plane z = z0, facing +Z.
Garment square(double z0, Vec3 color) {
  Garment g = make_rectangle(1.0, 1.0, 11, 11);
  g.transform(Eigen::Affine3d(Eigen::Translation3d(-0.5, -0.5, z0)));
  g.color = color;
  return g;
}

// A box body from triangles: [-w, w] x [-w, w] x [z0 - 0.1, z0 + 0.1], outward-facing.
Body box_body(double w, double z0) {
  std::vector<Vec3> v;
  for (int i = 0; i < 8; ++i)
    v.emplace_back(i & 1 ? w : -w, i & 2 ? w : -w, z0 + (i & 4 ? 0.1 : -0.1));
  std::vector<std::array<int, 3>> t = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                                       {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return Body::from_triangles(v, t, "box");
}

Camera front_camera() {
  Camera c;
  c.eye = Vec3(0, 0, 3);
  c.target = Vec3(0, 0, 0);
  c.up = Vec3(0, 1, 0);
  c.fov_degrees = 35;
  return c;
}

// At 200 x 200 with the camera 3 m away, the 1 m square spans about 106 pixels around the centre.
constexpr int kSize = 200;

}  // namespace

TEST(Render, GarmentCoversItsRegionInItsColour) {
  const Garment g = square(0.0, Vec3(0.8, 0.1, 0.1));
  const Image img = render({&g}, nullptr, front_camera(), kSize, kSize);
  ASSERT_EQ(img.width, kSize);
  ASSERT_EQ(img.height, kSize);
  ASSERT_EQ(img.rgba.size(), 4u * kSize * kSize);
  const Rgb expected{srgb(0.8), srgb(0.1), srgb(0.1)};  // facing the light: its colour, unshaded
  int inside = 0, outside = 0;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const int dx = std::abs(x - kSize / 2), dy = std::abs(y - kSize / 2);
      const Rgb c = pixel(img, x, y);
      if (dx < 45 && dy < 45) {
        EXPECT_TRUE(near(c, expected, 6)) << x << "," << y << ": " << c.r << " " << c.g << " " << c.b;
        ++inside;
      } else if (dx > 60 || dy > 60) {
        EXPECT_TRUE(is_background(c)) << x << "," << y << ": " << c.r << " " << c.g << " " << c.b;
        ++outside;
      }
      EXPECT_EQ(img.rgba[4 * (static_cast<std::size_t>(y) * kSize + x) + 3], 255);
    }
  EXPECT_GT(inside, 7000);
  EXPECT_GT(outside, 20000);
  // The square's edge lands where the perspective projection puts it: 0.5 m at 3 m, fov 35.
  const double edge = kSize / 2 + 0.5 / 3.0 * (kSize / 2) / std::tan(17.5 * M_PI / 180);
  EXPECT_FALSE(is_background(pixel(img, static_cast<int>(edge) - 2, kSize / 2)));
  EXPECT_TRUE(is_background(pixel(img, static_cast<int>(edge) + 2, kSize / 2)));
}

TEST(Render, BackgroundIsALightGradient) {
  const Image img = render({}, nullptr, front_camera(), 64, 48);
  const Rgb top = pixel(img, 10, 0), bottom = pixel(img, 10, 47);
  EXPECT_TRUE(is_background(top));
  EXPECT_TRUE(is_background(bottom));
  EXPECT_GT(top.r, bottom.r) << "lighter at the top";
}

TEST(Render, BothSidesOfClothAreLit) {
  const Garment g = square(0.0, Vec3(0.1, 0.2, 0.8));
  Camera behind = front_camera();
  behind.eye = Vec3(0, 0, -3);
  const Image img = render({&g}, nullptr, behind, kSize, kSize);
  EXPECT_TRUE(near(pixel(img, kSize / 2, kSize / 2), Rgb{srgb(0.1), srgb(0.2), srgb(0.8)}, 6));
}

TEST(Render, OblongCameraLightsLessThanHeadOn) {
  // Lambert: seen at a grazing angle the lit colour is darker, but not below the ambient term.
  const Garment g = square(0.0, Vec3(0.8, 0.8, 0.8));
  Camera side = front_camera();
  side.eye = Vec3(2.6, 0, 1.5);  // 60 degrees off the normal
  const Image img = render({&g}, nullptr, side, kSize, kSize);
  const Rgb c = pixel(img, kSize / 2, kSize / 2);
  EXPECT_LT(c.r, srgb(0.8) - 20);
  EXPECT_GT(c.r, srgb(0.8 * 0.25));
}

TEST(Render, BodyInFrontHidesTheGarment) {
  const Garment g = square(0.0, Vec3(0.8, 0.1, 0.1));
  const Body b = box_body(0.2, 1.0);  // between the camera and the cloth
  const Image img = render({&g}, &b, front_camera(), kSize, kSize);
  const Rgb centre = pixel(img, kSize / 2, kSize / 2);
  EXPECT_TRUE(std::abs(centre.r - centre.g) <= 2 && std::abs(centre.g - centre.b) <= 2)
      << "the body is grey: " << centre.r << " " << centre.g << " " << centre.b;
  EXPECT_FALSE(is_background(centre));
  // Beside the body the cloth still shows.
  EXPECT_TRUE(near(pixel(img, kSize / 2 + 45, kSize / 2), Rgb{srgb(0.8), srgb(0.1), srgb(0.1)}, 10));
}

TEST(Render, GarmentInFrontHidesTheBody) {
  const Garment g = square(1.0, Vec3(0.8, 0.1, 0.1));
  const Body b = box_body(0.2, 0.0);  // behind the cloth, drawn first or not
  const Image img = render({&g}, &b, front_camera(), kSize, kSize);
  EXPECT_TRUE(near(pixel(img, kSize / 2, kSize / 2), Rgb{srgb(0.8), srgb(0.1), srgb(0.1)}, 6));
}

// A session's frames reuse what the body drew in the last one while the body, camera and size stay
// the same: a frame drawn so is the frame drawn afresh, and a different body, a copy of the body,
// a moved camera or another size each get their own picture.
TEST(Render, RepeatedFramesMatchFreshOnesAndFollowTheBodyAndCamera) {
  const Garment g = square(0.3, Vec3(0.8, 0.1, 0.1));
  const Body near_box = box_body(0.7, 0.0), far_box = box_body(0.7, -1.0);
  Camera side = front_camera();
  side.eye = Vec3(2.0, 0.5, 2.5);
  auto same = [](const Image& a, const Image& b) { return a.width == b.width && a.rgba == b.rgba; };

  const Image first = render({&g}, &near_box, front_camera(), kSize, kSize);
  const Image again = render({&g}, &near_box, front_camera(), kSize, kSize);
  EXPECT_TRUE(same(first, again));
  const Body copy = near_box;
  EXPECT_TRUE(same(first, render({&g}, &copy, front_camera(), kSize, kSize)));
  // Beside the cloth, the near box shows (grey), not the background.
  EXPECT_FALSE(is_background(pixel(first, kSize / 2 + 65, kSize / 2)));

  // Another body after the first, with the same camera: its own picture, as drawn after anything else.
  const Image far_after_near = render({&g}, &far_box, front_camera(), kSize, kSize);
  render({&g}, &near_box, side, kSize, kSize);
  const Image far_after_side = render({&g}, &far_box, front_camera(), kSize, kSize);
  EXPECT_TRUE(same(far_after_near, far_after_side));
  EXPECT_FALSE(same(first, far_after_near));
  // A box 1 m further away is smaller on the screen: that pixel is background now.
  EXPECT_TRUE(is_background(pixel(far_after_near, kSize / 2 + 65, kSize / 2)));

  // The camera moved, and the size changed: each drawn as if first.
  const Image from_side = render({&g}, &near_box, side, kSize, kSize);
  EXPECT_FALSE(same(first, from_side));
  render({&g}, &far_box, front_camera(), kSize, kSize);
  EXPECT_TRUE(same(from_side, render({&g}, &near_box, side, kSize, kSize)));
  const Image small = render({&g}, &near_box, front_camera(), kSize / 2, kSize / 2);
  render({&g}, nullptr, front_camera(), kSize / 2, kSize / 2);
  EXPECT_TRUE(same(small, render({&g}, &near_box, front_camera(), kSize / 2, kSize / 2)));
  EXPECT_EQ(small.width, kSize / 2);
}

TEST(Render, NearerGarmentWinsWhateverTheOrder) {
  const Garment red = square(0.0, Vec3(0.8, 0.1, 0.1));
  const Garment blue = square(0.5, Vec3(0.1, 0.1, 0.8));
  const Rgb b{srgb(0.1), srgb(0.1), srgb(0.8)};
  EXPECT_TRUE(near(pixel(render({&red, &blue}, nullptr, front_camera(), kSize, kSize), 100, 100), b, 6));
  EXPECT_TRUE(near(pixel(render({&blue, &red}, nullptr, front_camera(), kSize, kSize), 100, 100), b, 6));
}

TEST(Render, TextureIsSampledByUv) {
  // 2 x 2 texels: v = 0 row red | blue, v = 1 row green | white. The square's uv is its pattern
  // coordinates, so the bottom left of the cloth (on screen) is red and the top right is white.
  Garment g = square(0.0, Vec3(0.5, 0.5, 0.5));
  g.texture() = Texture::filled(2, 2, 0, 0, 0);
  const std::uint8_t colours[4][3] = {{255, 0, 0}, {0, 0, 255}, {0, 255, 0}, {255, 255, 255}};
  for (int i = 0; i < 4; ++i) std::copy_n(colours[i], 3, g.texture().texel(i % 2, i / 2));
  const Image img = render({&g}, nullptr, front_camera(), kSize, kSize);
  const int c = kSize / 2, q = 35;
  EXPECT_TRUE(near(pixel(img, c - q, c + q), Rgb{255, 0, 0}, 8)) << "bottom left";
  EXPECT_TRUE(near(pixel(img, c + q, c + q), Rgb{0, 0, 255}, 8)) << "bottom right";
  EXPECT_TRUE(near(pixel(img, c - q, c - q), Rgb{0, 255, 0}, 8)) << "top left";
  EXPECT_TRUE(near(pixel(img, c + q, c - q), Rgb{255, 255, 255}, 8)) << "top right";
}

TEST(Render, NearPlaneClipsInsteadOfSmearing) {
  // A floor running from in front of the camera to far behind it: only the part ahead is drawn,
  // in the lower half of the image; the upper half stays background.
  Garment g = make_rectangle(4.0, 20.0, 5, 21);
  g.transform(Eigen::Affine3d(Eigen::Translation3d(-2, -1, -10) * Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX())));
  const Image img = render({&g}, nullptr, front_camera(), kSize, kSize);
  for (int y = 0; y < kSize / 2 - 2; ++y) EXPECT_TRUE(is_background(pixel(img, kSize / 2, y))) << y;
  EXPECT_FALSE(is_background(pixel(img, kSize / 2, kSize - 5)));
}

TEST(Render, FramingShowsTheWholeBody) {
  const Body body = Body::load(Body::default_path());
  const Camera cam = Camera::framing(body.bounds());
  EXPECT_GT(cam.eye.z(), body.bounds().max().z()) << "in front (+Z) of the body";
  const int w = 320, h = 240;
  const Image img = render({}, &body, cam, w, h);
  int top = h, bottom = -1;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (!is_background(pixel(img, x, y))) {
        top = std::min(top, y);
        bottom = std::max(bottom, y);
        EXPECT_TRUE(x > 0 && x < w - 1 && y > 0 && y < h - 1) << "body cut off at " << x << "," << y;
      }
  EXPECT_GT(bottom - top, h / 2) << "the body fills a good part of the frame";
}

TEST(Render, BodyAndDenseClothAt1024x768) {
  // The sizes the design asks for: about 30k body and 50k cloth triangles. Prints the time (a
  // figure to read, not a pass/fail threshold) and checks both are drawn.
  const Body body = Body::load(Body::default_path());
  Garment cloth = make_rectangle(0.8, 0.6, 159, 159);  // 2 * 158^2 = 49,928 triangles
  cloth.transform(Eigen::Affine3d(Eigen::Translation3d(-0.4, 0.8, 0.25)));
  cloth.color = Vec3(0.1, 0.3, 0.8);
  const Camera cam = Camera::framing(body.bounds());
  const auto t0 = std::chrono::steady_clock::now();
  const Image img = render({&cloth}, &body, cam, 1024, 768);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::cout << "render: " << body.triangles().size() << " body + " << cloth.mesh().number_of_faces()
            << " cloth triangles at 1024x768 in " << ms << " ms\n";
  write_png(img, tmp_path("body_and_cloth.png"));
  int blue = 0, grey = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const Rgb c = pixel(img, x, y);
      if (c.b > c.r + 40) ++blue;
      else if (!is_background(c) && std::abs(c.r - c.b) <= 2) ++grey;
    }
  EXPECT_GT(blue, 10000);
  EXPECT_GT(grey, 10000);
}

// What a picture shows: a point on the cloth facing the camera is seen; behind a body or another
// cloth, outside the picture, or behind the camera it is not.
TEST(Render, VisiblePointsAreThoseThePictureShows) {
  const Garment back = square(0.0, Vec3(0.8, 0.1, 0.1));
  const Body box = box_body(0.2, 0.5);  // in front of the cloth's middle, x and y within 0.2
  const std::vector<Vec3> points = {
      Vec3(0.4, 0.4, 0.0),     // on the cloth, beside the box: seen
      Vec3(0.0, 0.0, 0.0),     // on the cloth, behind the box: hidden
      Vec3(0.0, 0.0, 0.6),     // on the box's front face: seen
      Vec3(0.4, 0.4, -0.02),   // 2 cm behind the cloth: hidden by it
      Vec3(0.4, 0.4, 0.002),   // 2 mm in front of the cloth (a brush on its surface): seen
      Vec3(3.0, 0.0, 0.0),     // outside the picture
      Vec3(0.0, 0.0, 4.0)};    // behind the camera
  const auto seen = visible_points({&back}, &box, front_camera(), kSize, kSize, points);
  ASSERT_EQ(seen.size(), points.size());
  EXPECT_EQ(seen, (std::vector<bool>{true, false, true, false, true, false, false}));
  // Without the body, the cloth's middle shows; a looser tolerance lets the point behind it through.
  EXPECT_TRUE(visible_points({&back}, nullptr, front_camera(), kSize, kSize, {Vec3(0, 0, 0)})[0]);
  EXPECT_TRUE(visible_points({&back}, nullptr, front_camera(), kSize, kSize, {points[3]}, 0.05)[0]);
  EXPECT_THROW(visible_points({&back}, nullptr, front_camera(), kSize, kSize, points, -1.0), InputError);
}

TEST(RenderErrors, BadSizeAndCamera) {
  EXPECT_THROW(render({}, nullptr, front_camera(), 0, 10), InputError);
  EXPECT_THROW(render({}, nullptr, front_camera(), 10, -1), InputError);
  Camera same = front_camera();
  same.eye = same.target;
  EXPECT_THROW(render({}, nullptr, same, 10, 10), InputError);
  Camera wide = front_camera();
  wide.fov_degrees = 0;
  EXPECT_THROW(render({}, nullptr, wide, 10, 10), InputError);
  Camera nan_cam = front_camera();
  nan_cam.eye.x() = std::nan("");
  EXPECT_THROW(render({}, nullptr, nan_cam, 10, 10), InputError);
  EXPECT_THROW(render({nullptr}, nullptr, front_camera(), 10, 10), InputError);
}

TEST(Png, WriteReadRoundTripIsExact) {
  Image img;
  img.width = 37;
  img.height = 23;
  img.rgba.resize(4 * 37 * 23);
  std::mt19937 rng(7);
  for (auto& b : img.rgba) b = static_cast<std::uint8_t>(rng());
  const std::string path = tmp_path("noise.png");
  write_png(img, path);
  const Image back = read_png(path);
  EXPECT_EQ(back.width, img.width);
  EXPECT_EQ(back.height, img.height);
  EXPECT_EQ(back.rgba, img.rgba);
}

TEST(Png, RenderedImageRoundTrips) {
  const Garment g = square(0.0, Vec3(0.8, 0.1, 0.1));
  const Image img = render({&g}, nullptr, front_camera(), 64, 48);
  write_png(img, tmp_path("square.png"));
  EXPECT_EQ(read_png(tmp_path("square.png")).rgba, img.rgba);
}

TEST(PngErrors, NotAPng) {
  const std::string path = tmp_path("not_a_png.png");
  std::ofstream(path) << "v 0 0 0\nv 1 0 0\n";
  try {
    read_png(path);
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(msg.find("not a PNG"), std::string::npos) << msg;
  }
  EXPECT_THROW(read_png(std::string(KIJI_TEST_MODELS) + "/OBJ/box.obj"), InputError);
}

TEST(PngErrors, TruncatedPng) {
  Image img;
  img.width = img.height = 16;
  img.rgba.assign(16 * 16 * 4, 200);
  write_png(img, tmp_path("whole.png"));
  std::ifstream in(tmp_path("whole.png"), std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(tmp_path("truncated.png"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  EXPECT_THROW(read_png(tmp_path("truncated.png")), InputError);
}

namespace {
// The largest resident size of this process so far, in bytes.
std::size_t peak_resident_bytes() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<std::size_t>(u.ru_maxrss) * 1024;
}
}  // namespace

TEST(PngErrors, AHugeDeclaredSizeIsRefusedBeforeItsPixelsAreAllocated) {
  // A 16 x 16 PNG whose header is rewritten to declare other sizes: a few hundred bytes that would
  // otherwise ask for up to 4 GiB.
  Image img;
  img.width = img.height = 16;
  img.rgba.assign(16 * 16 * 4, 90);
  write_png(img, tmp_path("small.png"));
  std::ifstream in(tmp_path("small.png"), std::ios::binary);
  const std::string original((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t peak_before = peak_resident_bytes();
  struct Case {
    std::uint32_t width, height;
    std::string expect;
  };
  const Case cases[] = {
      {32767, 32767, "image size 32767x32767 is larger than Kiji reads (at most 16384 pixels a side and "
                     "67108864 pixels in all, 256 MiB as RGBA)"},
      {16384, 16384, "image size 16384x16384 is larger than Kiji reads"},
      {1, 100000, "image size 1x100000 is larger than Kiji reads"},
      {8192, 8192, "declares a 8192x8192 image, more than a PNG file of its size can hold"},
  };
  for (const Case& c : cases) {
    std::string bytes = original;
    ASSERT_TRUE(test::declare_png_size(bytes, 0, c.width, c.height));
    const std::string path = tmp_path("declares_" + std::to_string(c.width) + "x" + std::to_string(c.height) + ".png");
    std::ofstream(path, std::ios::binary) << bytes;
    const std::string msg = test::input_error([&] { read_png(path); });
    EXPECT_NE(msg.find(c.expect), std::string::npos) << msg;
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
  }
  EXPECT_LT(peak_resident_bytes(), peak_before + (64u << 20)) << "nothing near the declared sizes was allocated";
  // The same file with its own size still reads.
  EXPECT_EQ(read_png(tmp_path("small.png")).rgba, img.rgba);
}

TEST(PngErrors, AFileThatIsNotARegularFileIsRefusedWithoutBlocking) {
  const std::string fifo = tmp_path("fifo.png");
  std::filesystem::remove(fifo);
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_NE(test::input_error([&] { read_png(fifo); }).find("it is not a regular file"), std::string::npos);
  Image img;
  img.width = img.height = 2;
  img.rgba.assign(16, 0);
  EXPECT_NE(test::input_error([&] { write_png(img, fifo); }).find("it exists and is not a regular file"),
            std::string::npos);
  std::filesystem::remove(fifo);
}

TEST(PngErrors, MissingFileAndUnwritablePath) {
  EXPECT_THROW(read_png("/nonexistent/picture.png"), InputError);
  EXPECT_THROW(read_png(KIJI_TEST_TMP), InputError);
  Image img;
  img.width = img.height = 2;
  img.rgba.assign(16, 0);
  EXPECT_THROW(write_png(img, "/nonexistent/picture.png"), InputError);
  Image bad = img;
  bad.rgba.resize(5);
  EXPECT_THROW(write_png(bad, tmp_path("bad.png")), InputError);
}
