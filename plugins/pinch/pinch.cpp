// pinch: the hand takes the cloth. As in the 2006 paper, pressing the button links the pointer to
// the nearest vertex with a spring; moving pulls the cloth and the spring's force is fed back. A
// local radius limits the simulation to the cloth near the hand; mode 'whole' carries the whole
// garment with the pointer.
#include <kiji/haptics.h>
#include <kiji/session.h>
#include <kiji/tool.h>

#include <atomic>

namespace {

using namespace kiji;

class PinchTool : public Tool {
 public:
  ToolInfo info() const override {
    return {"pinch", "Pinch",
            "Grabs the cloth nearest the pointer with a spring and pulls it along; the spring's force is felt. "
            "With a local radius only the cloth within it of the pointer moves. Mode 'whole' moves the whole "
            "garment with the pointer.",
            {ParamSpec::choice("mode", "vertex", {"vertex", "whole"}, "Mode",
                               "'vertex' pulls the nearest vertex on a spring; 'whole' carries the garment."),
             ParamSpec::real("stiffness", 50.0, 0.01, 1e6, "N/m", "Stiffness",
                             "Stiffness of the spring between the pointer and the grabbed vertex."),
             ParamSpec::real("local_radius", 0.0, 0.0, 100.0, "m", "Local radius",
                             "Only vertices within this distance of the pointer are simulated while pinching "
                             "(the paper's local region); 0 simulates the whole garment.")}};
  }

  Feedback begin(Session& session, const ParamSet& params, const ToolEvent& event) override {
    whole_ = params.get_string("mode") == "whole";
    stiffness_ = params.get_float("stiffness");
    local_radius_ = params.get_float("local_radius");
    grabbed_ = Mesh::null_vertex();
    last_ = event.position;
    if (!event.hit.hit) return {};
    garment_ = event.hit.garment;
    if (whole_) return {};
    grabbed_ = event.hit.nearest;
    Solver& solver = session.solver(garment_);
    saved_params_ = solver.params();
    if (local_radius_ > 0) {
      SolverParams p = saved_params_;
      p.local_radius = local_radius_;
      p.local_center = event.position;
      solver.set_params(p);
    }
    attachment_ = solver.add_attachment(grabbed_, event.position, stiffness_);
    haptic_stiffness_ = stiffness_;
    haptic_garment_ = garment_;
    haptic_vertex_ = grabbed_.idx();
    return feedback(session, event.position);
  }

  Feedback update(Session& session, const ToolEvent& event) override {
    if (whole_) {
      if (session.garment_count() > garment_) {
        Garment& g = session.garment(garment_);
        const Vec3 delta = event.position - last_;
        for (Vertex v : g.mesh().vertices()) g.set_position(v, g.position(v) + delta);
      }
      last_ = event.position;
      return {};
    }
    if (grabbed_ == Mesh::null_vertex()) return {};
    Solver& solver = session.solver(garment_);
    solver.move_attachment(attachment_, event.position);
    if (local_radius_ > 0) {
      SolverParams p = solver.params();
      p.local_center = event.position;
      solver.set_params(p);
    }
    return feedback(session, event.position);
  }

  void end(Session& session, const ToolEvent& event) override {
    if (whole_) update(session, event);  // the release point is where the garment stays
    release(session);
  }
  void cancel(Session& session) override { release(session); }

  // On the haptic thread: the same spring, to the grabbed vertex as the last step left it.
  Feedback haptic_force(const HapticSnapshot& snapshot, const ToolEvent& event) const override {
    Feedback f;
    const std::uint32_t v = haptic_vertex_.load();
    if (v == kNone || snapshot.garment != haptic_garment_.load()) return f;
    if (const Vec3* x = snapshot.position_of(Vertex(v))) f.force = haptic_stiffness_.load() * (*x - event.position);
    return f;
  }

 private:
  // The force on the hand: the spring pulls the hand towards the cloth, k (x - pointer).
  Feedback feedback(const Session& session, const Vec3& pointer) const {
    Feedback f;
    const Garment& g = session.garment(garment_);
    if (g.mesh().is_removed(grabbed_)) return f;
    f.force = stiffness_ * (g.position(grabbed_) - pointer);
    return f;
  }

  void release(Session& session) {
    haptic_vertex_ = kNone;
    if (grabbed_ == Mesh::null_vertex() || garment_ >= session.garment_count()) {
      grabbed_ = Mesh::null_vertex();
      return;
    }
    Solver& solver = session.solver(garment_);
    solver.remove_attachment(attachment_);
    solver.set_params(saved_params_);
    grabbed_ = Mesh::null_vertex();
  }

  bool whole_ = false;
  double stiffness_ = 50, local_radius_ = 0;
  std::size_t garment_ = 0;
  Vertex grabbed_;
  int attachment_ = -1;
  SolverParams saved_params_;
  Vec3 last_ = Vec3::Zero();
  // What the haptic thread reads, written when a stroke begins and ends.
  static constexpr std::uint32_t kNone = 0xffffffffu;
  std::atomic<std::uint32_t> haptic_vertex_{kNone};
  std::atomic<std::size_t> haptic_garment_{0};
  std::atomic<double> haptic_stiffness_{0};
};

}  // namespace

KIJI_TOOL_PLUGIN(PinchTool)
