// pinch: the hand takes the cloth. As in the 2006 paper, pressing the button links the pointer to
// the cloth with a spring; moving pulls the cloth and the spring's force is fed back. The paper
// links one vertex; here the hand takes the patch of cloth under a fingertip (every vertex joined
// to the nearest one within grab_radius of where the pen touched), the spring's stiffness shared
// among them, so that a pinch pulls the same cloth whatever the mesh's resolution: on a fine mesh
// one vertex alone would be pulled out of the cloth as a spike. On a coarse mesh (vertices further
// apart than the radius) the patch is the one vertex, as in the paper. A local radius limits the
// simulation to the cloth near the hand; mode 'whole' carries the whole garment with the pointer.
#include <kiji/haptics.h>
#include <kiji/session.h>
#include <kiji/tool.h>

#include <CGAL/boost/graph/iterator.h>

#include <atomic>
#include <memory>
#include <unordered_set>

namespace {

using namespace kiji;

// The cloth in the hand: each vertex keeps its offset from the pointer as the stroke began (the
// cloth is held where it was taken, not snapped to the pen), and pulls with its share k.
struct Grip {
  std::size_t garment = 0;
  std::vector<Vertex> vertices;
  std::vector<Vec3> offsets;  // vertex - pointer, when the stroke began
  double k = 0;               // each vertex's share of the stiffness
};

class PinchTool : public Tool {
 public:
  ToolInfo info() const override {
    return {"pinch", "Pinch",
            "Grabs the cloth under the pointer (the patch within the grab radius) with a spring and pulls it "
            "along; the spring's force is felt. With a local radius only the cloth within it of the pointer "
            "moves. Mode 'whole' moves the whole garment with the pointer.",
            {ParamSpec::choice("mode", "vertex", {"vertex", "whole"}, "Mode",
                               "'vertex' pulls the cloth under the pointer on a spring; 'whole' carries the garment."),
             ParamSpec::real("stiffness", 50.0, 0.01, 1e6, "N/m", "Stiffness",
                             "Stiffness of the spring between the pointer and the grabbed cloth (shared among the "
                             "grabbed vertices)."),
             ParamSpec::real("grab_radius", 0.02, 0.0, 1.0, "m", "Grab radius",
                             "The patch of cloth taken: the vertices joined to the nearest one within this distance "
                             "of where the pointer touched (a fingertip's pad). 0 takes the nearest vertex alone, as "
                             "the paper did; so does a mesh coarser than the radius."),
             ParamSpec::real("local_radius", 0.0, 0.0, 100.0, "m", "Local radius",
                             "Only vertices within this distance of the pointer are simulated while pinching "
                             "(the paper's local region); 0 simulates the whole garment.")}};
  }

  Feedback begin(Session& session, const ParamSet& params, const ToolEvent& event) override {
    whole_ = params.get_string("mode") == "whole";
    local_radius_ = params.get_float("local_radius");
    grip_.reset();
    attachments_.clear();
    last_ = event.position;
    if (!event.hit.hit) return {};
    garment_ = event.hit.garment;
    if (whole_) return {};
    auto grip = take(session.garment(garment_), event, params.get_float("grab_radius"), params.get_float("stiffness"));
    Solver& solver = session.solver(garment_);
    saved_params_ = solver.params();
    if (local_radius_ > 0) {
      SolverParams p = saved_params_;
      p.local_radius = local_radius_;
      p.local_center = event.position;
      solver.set_params(p);
    }
    for (std::size_t i = 0; i < grip->vertices.size(); ++i)
      attachments_.push_back(solver.add_attachment(grip->vertices[i], event.position + grip->offsets[i], grip->k));
    grip_ = std::move(grip);
    std::atomic_store(&haptic_grip_, std::shared_ptr<const Grip>(grip_));
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
    if (!grip_) return {};
    Solver& solver = session.solver(garment_);
    for (std::size_t i = 0; i < attachments_.size(); ++i)
      solver.move_attachment(attachments_[i], event.position + grip_->offsets[i]);
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

  // On the haptic thread: the same spring, to the grabbed cloth as the last step left it (the
  // vertices of the grip that the snapshot holds).
  Feedback haptic_force(const HapticSnapshot& snapshot, const ToolEvent& event) const override {
    Feedback f;
    const std::shared_ptr<const Grip> grip = std::atomic_load(&haptic_grip_);
    if (!grip || snapshot.garment != grip->garment) return f;
    for (std::size_t i = 0; i < grip->vertices.size(); ++i)
      if (const Vec3* x = snapshot.position_of(grip->vertices[i]))
        f.force += grip->k * (*x - grip->offsets[i] - event.position);
    return f;
  }

 private:
  // The patch under the pointer: the nearest vertex, and every vertex reached from it across edges
  // through vertices within `radius` of the touched point (so a fold's other layer, close in space
  // but not joined within the patch, is not taken).
  static std::shared_ptr<Grip> take(const Garment& g, const ToolEvent& event, double radius, double stiffness) {
    auto grip = std::make_shared<Grip>();
    grip->garment = event.hit.garment;
    const Mesh& m = g.mesh();
    const Vec3 centre = event.hit.point;
    std::vector<Vertex> todo{event.hit.nearest};
    std::unordered_set<std::uint32_t> seen{event.hit.nearest.idx()};
    while (!todo.empty()) {
      const Vertex v = todo.back();
      todo.pop_back();
      grip->vertices.push_back(v);
      for (Vertex w : CGAL::vertices_around_target(m.halfedge(v), m))
        if ((g.position(w) - centre).norm() <= radius && seen.insert(w.idx()).second) todo.push_back(w);
    }
    std::sort(grip->vertices.begin(), grip->vertices.end());
    for (Vertex v : grip->vertices) grip->offsets.push_back(g.position(v) - event.position);
    grip->k = stiffness / double(grip->vertices.size());
    return grip;
  }

  // The force on the hand: the springs pull the hand towards the cloth, sum k (x - offset - pointer).
  Feedback feedback(const Session& session, const Vec3& pointer) const {
    Feedback f;
    const Garment& g = session.garment(garment_);
    for (std::size_t i = 0; i < grip_->vertices.size(); ++i)
      if (g.mesh().has_valid_index(grip_->vertices[i]) && !g.mesh().is_removed(grip_->vertices[i]))
        f.force += grip_->k * (g.position(grip_->vertices[i]) - grip_->offsets[i] - pointer);
    return f;
  }

  void release(Session& session) {
    std::atomic_store(&haptic_grip_, std::shared_ptr<const Grip>());
    if (!grip_ || garment_ >= session.garment_count()) {
      grip_.reset();
      attachments_.clear();
      return;
    }
    Solver& solver = session.solver(garment_);
    for (int a : attachments_) solver.remove_attachment(a);
    solver.set_params(saved_params_);
    grip_.reset();
    attachments_.clear();
  }

  bool whole_ = false;
  double local_radius_ = 0;
  std::size_t garment_ = 0;
  std::shared_ptr<const Grip> grip_;
  std::vector<int> attachments_;
  SolverParams saved_params_;
  Vec3 last_ = Vec3::Zero();
  // What the haptic thread reads, swapped whole when a stroke begins and ends.
  std::shared_ptr<const Grip> haptic_grip_;
};

}  // namespace

KIJI_TOOL_PLUGIN(PinchTool)
