// "nudge": the cloth vertex under the pointer follows the pointer while the button is held, moved
// by `strength` of the way each event. A tool as small as a tool can be, built outside Kiji's tree.
#include <kiji/session.h>
#include <kiji/tool.h>

namespace {

class Nudge : public kiji::Tool {
 public:
  kiji::ToolInfo info() const override {
    return {"nudge", "Nudge", "The cloth vertex under the pointer follows the pointer.",
            {kiji::ParamSpec::real("strength", 1.0, 0.0, 1.0, "", "Strength",
                                   "How much of the way to the pointer the vertex moves at each event.")}};
  }
  kiji::Feedback begin(kiji::Session& session, const kiji::ParamSet& params, const kiji::ToolEvent& event) override {
    held_ = event.hit.hit;
    garment_ = event.hit.garment;
    vertex_ = event.hit.nearest;
    strength_ = params.get_float("strength");
    return {};
  }
  kiji::Feedback update(kiji::Session& session, const kiji::ToolEvent& event) override {
    if (!held_) return {};
    kiji::Garment& g = session.garment(garment_);
    const kiji::Vec3 p = g.position(vertex_);
    g.set_position(vertex_, p + strength_ * (event.position - p));
    kiji::Feedback f;
    f.force = event.position - g.position(vertex_);
    return f;
  }
  void end(kiji::Session& session, const kiji::ToolEvent& event) override { held_ = false; }
  void cancel(kiji::Session& session) override { held_ = false; }

 private:
  bool held_ = false;
  std::size_t garment_ = 0;
  kiji::Vertex vertex_;
  double strength_ = 1.0;
};

}  // namespace

KIJI_TOOL_PLUGIN(Nudge)
