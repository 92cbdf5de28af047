// pinch: the hand takes the cloth. As in the 2006 paper, pressing the button links the pointer to
// the cloth with a spring; moving pulls the cloth and the spring's force is fed back. The paper
// links one vertex; here the hand takes the patch of cloth under a fingertip (every vertex joined
// to the nearest one within grab_radius of where the pen touched), the spring's stiffness shared
// among them, so that a pinch pulls the same cloth whatever the mesh's resolution: on a fine mesh
// one vertex alone would be pulled out of the cloth as a spike. On a coarse mesh (vertices further
// apart than the radius) the patch is the one vertex, as in the paper. A local radius limits the
// simulation to the cloth near the hand; mode 'whole' carries the whole garment with the pointer.
#include <kiji/haptic_force.h>
#include <kiji/tool.h>

#include <CGAL/boost/graph/iterator.h>

#include <algorithm>
#include <atomic>
#include <memory>
#include <unordered_set>

namespace {

using namespace kiji;

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

  Feedback begin(ToolContext& context, const ParamSet& params, const ToolEvent& event) override {
    whole_ = params.get_string("mode") == "whole";
    local_radius_ = params.get_float("local_radius");
    grip_.reset();
    hands_.clear();
    last_ = event.position;
    if (!event.hit.hit) return {};
    garment_ = event.hit.garment;
    if (whole_) return {};
    auto grip = take(context.garment(garment_), event, params.get_float("grab_radius"), params.get_float("stiffness"));
    if (local_radius_ > 0) context.set_local_region(garment_, event.position, local_radius_);
    for (std::size_t i = 0; i < grip->vertices.size(); ++i)
      hands_.push_back(context.attach(garment_, grip->vertices[i], event.position + grip->offsets[i], grip->share()));
    grip_ = std::move(grip);
    std::atomic_store(&haptic_grip_, std::shared_ptr<const HapticSpring>(grip_));
    return feedback(context, event.position);
  }

  Feedback update(ToolContext& context, const ToolEvent& event) override {
    if (whole_) {
      if (context.garment_count() > garment_) {
        Garment& g = context.garment(garment_);
        const Vec3 delta = event.position - last_;
        for (Vertex v : g.mesh().vertices()) g.set_position(v, g.position(v) + delta);
      }
      last_ = event.position;
      return {};
    }
    if (!grip_) return {};
    for (std::size_t i = 0; i < hands_.size(); ++i) context.move(garment_, hands_[i], event.position + grip_->offsets[i]);
    if (local_radius_ > 0) context.set_local_region(garment_, event.position, local_radius_);
    return feedback(context, event.position);
  }

  void end(ToolContext& context, const ToolEvent& event) override {
    if (whole_) update(context, event);  // the release point is where the garment stays
    release(context);
  }
  void cancel(ToolContext& context) override { release(context); }

  // On the haptic thread: the same spring, to the grabbed cloth as the last step left it (the
  // vertices of the grip that the snapshot holds).
  Feedback haptic_force(const HapticSnapshot& snapshot, const ToolEvent& event) const override {
    Feedback f;
    if (const std::shared_ptr<const HapticSpring> grip = std::atomic_load(&haptic_grip_))
      f.force = grip->force(snapshot, event.position);
    return f;
  }

 private:
  // The patch under the pointer: the nearest vertex, and every vertex reached from it across edges
  // through vertices within `radius` of the touched point (so a fold's other layer, close in space
  // but not joined within the patch, is not taken). Each vertex keeps its offset from the pointer
  // as the stroke began (the cloth is held where it was taken, not snapped to the pen).
  static std::shared_ptr<HapticSpring> take(const Garment& g, const ToolEvent& event, double radius, double stiffness) {
    auto grip = std::make_shared<HapticSpring>();
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
    grip->stiffness = stiffness;
    return grip;
  }

  // The force on the hand: the springs pull the hand towards the cloth.
  Feedback feedback(const ToolContext& context, const Vec3& pointer) const {
    Feedback f;
    f.force = grip_->force(context.garment(garment_), pointer);
    return f;
  }

  void release(ToolContext& context) {
    std::atomic_store(&haptic_grip_, std::shared_ptr<const HapticSpring>());
    if (grip_ && garment_ < context.garment_count()) {
      for (int hand : hands_) context.release(garment_, hand);
      if (local_radius_ > 0) context.end_local_region(garment_);
    }
    grip_.reset();
    hands_.clear();
  }

  bool whole_ = false;
  double local_radius_ = 0;
  std::size_t garment_ = 0;
  std::shared_ptr<const HapticSpring> grip_;  // the cloth in the hand: the spring's vertices and offsets
  std::vector<int> hands_;
  Vec3 last_ = Vec3::Zero();
  // What the haptic thread reads, swapped whole when a stroke begins and ends.
  std::shared_ptr<const HapticSpring> haptic_grip_;
};

}  // namespace

KIJI_TOOL_PLUGIN(PinchTool)
