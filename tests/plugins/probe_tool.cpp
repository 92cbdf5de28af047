// "probe": a small tool for the loader tests. A stroke lifts the cloth vertex under the pointer by
// `height` (down with direction = "down"); it declares one parameter of every type so the tests can
// compare the generated metadata with the declarations. Compile definitions make the broken twins:
// KIJI_TEST_OTHER_ABI or KIJI_TEST_OTHER_INTERFACE give a binary built for another Kiji (and the
// build with -mavx one whose Eigen members are laid out otherwise).
#include "kiji/error.h"
#include "kiji/session.h"
#include "kiji/tool.h"

#ifdef KIJI_TEST_OTHER_ABI  // as if built with another compiler, CGAL, Eigen and scalar type
#undef KIJI_ABI_TAG
#define KIJI_ABI_TAG "kiji=0.1;compiler=gcc1;stdlib=libstdc++0;cgal=0.0;eigen=0.0.0;scalar=float"
#endif
#ifdef KIJI_TEST_OTHER_INTERFACE  // as if built against a later tool interface
#undef KIJI_TOOL_INTERFACE
#define KIJI_TOOL_INTERFACE "org.kiji.Tool/2"
#endif

// Not exported: the tests check that a plugin's own symbols are hidden.
extern "C" int kiji_probe_hidden_marker() { return 42; }

namespace {

class ProbeTool : public kiji::Tool {
 public:
  kiji::ToolInfo info() const override {
    using kiji::ParamSpec;
    return {"probe",
            "Probe",
            "Lifts the cloth vertex under the pointer; for the plugin loader's tests.",
            {ParamSpec::real("height", 0.05, 0.0, 1.0, "m", "Height", "How far the vertex is lifted."),
             ParamSpec::choice("direction", "up", {"up", "down"}, "Direction", "Which way along +Y."),
             ParamSpec::integer("repeat", 1, 1, 10, "Repeat", "How many times the lift is applied."),
             ParamSpec::boolean("fail", false, "Fail", "Throw from begin(), to test errors across the plugin boundary."),
             ParamSpec::text("note", "", "Note", "Free text, unused."),
             ParamSpec::color("tint", kiji::Vec3(1.0, 0.5, 0.25), "Tint", "A colour, unused.")}};
  }

  kiji::Feedback begin(kiji::Session& session, const kiji::ParamSet& params, const kiji::ToolEvent& event) override {
    if (params.get_bool("fail")) throw kiji::InputError("probe was asked to fail");
    grabbed_ = event.hit.hit;
    garment_ = event.hit.garment;
    vertex_ = event.hit.nearest;
    lift_ = params.get_float("height") * double(params.get_int("repeat")) *
            (params.get_string("direction") == "down" ? -1.0 : 1.0);
    kiji::Feedback f;
    f.force = kiji::Vec3(0, -lift_, 0);
    return f;
  }

  kiji::Feedback update(kiji::Session&, const kiji::ToolEvent&) override { return {}; }

  void end(kiji::Session& session, const kiji::ToolEvent&) override {
    if (!grabbed_) return;
    kiji::Garment& g = session.garment(garment_);
    g.set_position(vertex_, g.position(vertex_) + kiji::Vec3(0, lift_, 0));
    grabbed_ = false;
  }

  void cancel(kiji::Session&) override { grabbed_ = false; }

 private:
  bool grabbed_ = false;
  std::size_t garment_ = 0;
  kiji::Vertex vertex_;
  double lift_ = 0;
};

}  // namespace

KIJI_TOOL_PLUGIN(ProbeTool)
