// paint: the pen as a brush. Colours the garment's texture at the pointer's place on the cloth
// and pushes back along the cloth's normal while the pen touches it, as in the 2006 paper.
#include <kiji/haptic_force.h>
#include <kiji/tool.h>

#include <algorithm>
#include <atomic>
#include <cmath>

namespace {

using namespace kiji;

class PaintTool : public Tool {
 public:
  ToolInfo info() const override {
    return {"paint", "Paint",
            "Paints the garment's texture where the pen touches the cloth, with a round brush; the texture "
            "travels with the cloth and is exported with the garment. Touching the cloth pushes back along its "
            "normal.",
            {ParamSpec::color("color", Vec3(0.1, 0.2, 0.8), "Colour", "Brush colour, linear RGB in [0, 1]."),
             ParamSpec::real("radius", 0.01, 0.0005, 0.5, "m", "Radius", "Brush radius on the cloth."),
             ParamSpec::real("hardness", 0.8, 0.0, 1.0, "", "Hardness",
                             "Fraction of the radius painted at full strength; beyond it the paint fades out."),
             ParamSpec::real("opacity", 1.0, 0.0, 1.0, "", "Opacity", "Strength of the paint, times the pen's pressure."),
             ParamSpec::integer("resolution", 1024, 16, 8192, "Texture size",
                                "Texels a side of the texture made for a garment that has none."),
             ParamSpec::real("touch_distance", 0.005, 0.0, 0.1, "m", "Touch distance",
                             "The pen paints and feels the cloth when it is this close to it."),
             ParamSpec::real("stiffness", 300.0, 0.0, 1e5, "N/m", "Stiffness",
                             "How hard the cloth pushes back on the pen, per metre the pen goes past the touch distance.")}};
  }

  Feedback begin(ToolContext& context, const ParamSet& params, const ToolEvent& event) override {
    color_ = params.get_color("color");
    radius_ = params.get_float("radius");
    hardness_ = params.get_float("hardness");
    opacity_ = params.get_float("opacity");
    resolution_ = static_cast<int>(params.get_int("resolution"));
    push_.touch = params.get_float("touch_distance");
    push_.stiffness = params.get_float("stiffness");
    haptic_touch_ = push_.touch;
    haptic_stiffness_ = push_.stiffness;
    has_last_ = false;
    return paint(context, event);
  }

  Feedback update(ToolContext& context, const ToolEvent& event) override { return paint(context, event); }

  void end(ToolContext& context, const ToolEvent& event) override { paint(context, event); }

  void cancel(ToolContext&) override { has_last_ = false; }

  // On the haptic thread: the same push, from the cloth's surface near the pen in the last step's
  // snapshot.
  Feedback haptic_force(const HapticSnapshot& snapshot, const ToolEvent& event) const override {
    const HapticPush push{haptic_touch_.load(), haptic_stiffness_.load()};
    Feedback f;
    f.force = push.force(snapshot.nearest(event.position), event.position);
    return f;
  }

 private:
  Feedback paint(ToolContext& context, const ToolEvent& e) {
    if (!e.hit.hit || e.hit.distance > push_.touch) {
      has_last_ = false;
      return {};
    }
    Garment& g = context.garment(e.hit.garment);
    Texture& t = g.texture();
    if (t.empty()) {
      const auto to8 = [](double x) { return static_cast<std::uint8_t>(std::lround(255 * std::clamp(x, 0.0, 1.0))); };
      t = Texture::filled(resolution_, resolution_, to8(g.color.x()), to8(g.color.y()), to8(g.color.z()));
    }
    const double r_uv = radius_ / g.pattern_scale();
    // Stamps a quarter radius apart from the last point, so a fast stroke leaves no gaps.
    const Vec2 to = e.hit.uv;
    const bool join = has_last_ && last_garment_ == e.hit.garment && (to - last_uv_).norm() < 8 * r_uv;
    const Vec2 from = join ? last_uv_ : to;
    const int stamps = std::max(1, static_cast<int>(std::ceil((to - from).norm() / (0.25 * r_uv))));
    for (int i = join ? 1 : 0; i <= stamps; ++i) stamp(t, from + (to - from) * (double(i) / stamps), r_uv, e.pressure);
    has_last_ = true;
    last_uv_ = to;
    last_garment_ = e.hit.garment;
    // The touch pushes the pen back out of the cloth, on whichever side it is, along the normal.
    Feedback f;
    f.force = push_.force(e.hit, e.position);
    return f;
  }

  void stamp(Texture& t, const Vec2& uv, double r_uv, double pressure) {
    const double cx = uv.x() * t.width - 0.5, cy = uv.y() * t.height - 0.5;
    const double rx = r_uv * t.width, ry = r_uv * t.height;
    const int x0 = std::max(0, int(std::floor(cx - rx))), x1 = std::min(t.width - 1, int(std::ceil(cx + rx)));
    const int y0 = std::max(0, int(std::floor(cy - ry))), y1 = std::min(t.height - 1, int(std::ceil(cy + ry)));
    const double strength = opacity_ * std::clamp(pressure, 0.0, 1.0);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const double d = std::hypot((x - cx) / rx, (y - cy) / ry);  // 1 at the brush's edge
        if (d > 1) continue;
        double a = strength;
        if (d > hardness_) a *= 1.0 - (d - hardness_) / std::max(1e-9, 1.0 - hardness_);
        std::uint8_t* px = t.texel(x, y);
        for (int c = 0; c < 3; ++c) {
          const double painted = 255.0 * color_[c];
          px[c] = static_cast<std::uint8_t>(std::lround(px[c] + a * (painted - px[c])));
        }
        px[3] = 255;
      }
  }

  Vec3 color_ = Vec3::Zero();
  double radius_ = 0.01, hardness_ = 0.8, opacity_ = 1;
  HapticPush push_;  // touch_distance and stiffness
  int resolution_ = 1024;
  bool has_last_ = false;
  Vec2 last_uv_ = Vec2::Zero();
  std::size_t last_garment_ = 0;
  std::atomic<double> haptic_touch_{0.005}, haptic_stiffness_{300};
};

}  // namespace

KIJI_TOOL_PLUGIN(PaintTool)
