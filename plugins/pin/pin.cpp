// pin: pins (or unpins) the cloth under a round brush, so that it holds still where it is.
// Written as any plugin author would write a tool: only Kiji's installed headers.
#include <kiji/tool.h>

namespace {

using namespace kiji;

class PinTool : public Tool {
 public:
  ToolInfo info() const override {
    return {"pin", "Pin",
            "Pins the cloth's vertices under the brush so they hold still (mode 'pin'), or frees them "
            "(mode 'unpin').",
            {ParamSpec::choice("mode", "pin", {"pin", "unpin"}, "Mode", "Pin or unpin the vertices under the brush."),
             ParamSpec::real("radius", 0.02, 0.0, 1.0, "m", "Radius",
                             "Vertices within this distance of the brush's point on the cloth are (un)pinned.")}};
  }

  Feedback begin(ToolContext& context, const ParamSet& params, const ToolEvent& event) override {
    pin_ = params.get_string("mode") == "pin";
    radius_ = params.get_float("radius");
    apply(context, event);
    return {};
  }
  Feedback update(ToolContext& context, const ToolEvent& event) override {
    apply(context, event);
    return {};
  }
  void end(ToolContext& context, const ToolEvent& event) override { apply(context, event); }
  void cancel(ToolContext&) override {}

 private:
  void apply(ToolContext& context, const ToolEvent& e) {
    if (!e.hit.hit) return;
    Garment& g = context.garment(e.hit.garment);
    const double r2 = radius_ * radius_;
    bool any = false;
    for (Vertex v : g.mesh().vertices()) {
      if ((g.position(v) - e.hit.point).squaredNorm() > r2) continue;
      g.set_pinned(v, pin_);
      any = true;
    }
    // The brush always takes at least the vertex under it.
    if (!any) g.set_pinned(e.hit.nearest, pin_);
  }

  bool pin_ = true;
  double radius_ = 0.02;
};

}  // namespace

KIJI_TOOL_PLUGIN(PinTool)
