// Compares two pictures with a tolerance per pixel, as renderers differ in their last bits (another
// llvmpipe, another GPU): they match when no more than a given share of the pixels differ by more
// than a given amount in any channel.
//   kiji_compare_png A.png B.png [THRESHOLD=24] [MAX_SHARE=0.005]
#include "kiji/render.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: kiji_compare_png A.png B.png [THRESHOLD] [MAX_SHARE]\n");
    return 2;
  }
  const int threshold = argc > 3 ? std::atoi(argv[3]) : 24;
  const double max_share = argc > 4 ? std::atof(argv[4]) : 0.005;
  try {
    const kiji::Image a = kiji::read_png(argv[1]), b = kiji::read_png(argv[2]);
    if (a.width != b.width || a.height != b.height) {
      std::printf("different sizes: %dx%d and %dx%d\n", a.width, a.height, b.width, b.height);
      return 1;
    }
    std::size_t differing = 0;
    double sum = 0;
    for (std::size_t i = 0; i < a.rgba.size(); i += 4) {
      int worst = 0;
      for (int k = 0; k < 3; ++k) {
        const int d = std::abs(int(a.rgba[i + k]) - int(b.rgba[i + k]));
        worst = std::max(worst, d);
        sum += d;
      }
      differing += worst > threshold;
    }
    const double pixels = double(a.rgba.size() / 4);
    const double share = differing / pixels;
    std::printf("%.4f%% of the pixels differ by more than %d; mean difference %.3f a channel\n", 100 * share, threshold,
                sum / (3 * pixels));
    return share <= max_share ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
}
