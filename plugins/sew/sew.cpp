// sew: joins cloth. As in the 2006 paper, a vertex dragged within a distance of another is merged
// with it, and edges that then coincide become one (mode 'pinch'); or a whole seam at once: the
// stroke traces one border with the primary button and the other with the secondary (mode 'seam'),
// joined at once or tacked and sewn as the simulation draws them together (join 'closing').
#include <kiji/error.h>
#include <kiji/tool.h>
#include <kiji/topology.h>

#include <limits>

namespace {

using namespace kiji;

class SewTool : public Tool {
 public:
  ToolInfo info() const override {
    return {"sew", "Sew",
            "Mode 'pinch' (the 2006 paper): drag a border vertex to another; within the sewing distance they "
            "become one, and edges that then coincide become one. Two separate pieces are first tacked "
            "together, and close into a seam when the neighbouring pair is sewn. Mode 'seam': trace one border "
            "with the primary button and the other with the secondary; the two are sewn along their length.",
            {ParamSpec::choice("mode", "pinch", {"pinch", "seam"}, "Mode",
                               "'pinch' sews vertex to vertex as you drag; 'seam' sews two traced borders."),
             ParamSpec::real("distance", 0.01, 0.0, 0.5, "m", "Sewing distance",
                             "A dragged vertex this close to another border vertex is sewn to it."),
             ParamSpec::choice("join", "at once", {"at once", "closing"}, "Join",
                               "Mode 'seam': 'at once' joins the two borders where they are; 'closing' tacks each "
                               "pair and the simulation draws the borders together, sewing them as they meet "
                               "(while it is paused they stay tacked).")}};
  }

  Feedback begin(ToolContext& context, const ParamSet& params, const ToolEvent& event) override {
    seam_mode_ = params.get_string("mode") == "seam";
    closing_ = params.get_string("join") == "closing";
    distance_ = params.get_float("distance");
    side_a_.clear();
    side_b_.clear();
    grabbed_ = Mesh::null_vertex();
    if (seam_mode_) {
      trace(context, event);
      return {};
    }
    if (!event.hit.hit) return {};
    garment_ = event.hit.garment;
    Garment& g = context.garment(garment_);
    grabbed_ = nearest_border(g, event.hit.point, 3 * std::max(distance_, 0.01), Mesh::null_vertex());
    if (grabbed_ == Mesh::null_vertex()) grabbed_ = event.hit.nearest;
    was_pinned_ = g.pinned(grabbed_);
    offset_ = g.position(grabbed_) - event.position;
    g.set_pinned(grabbed_, true);  // held by the hand while dragged
    return {};
  }

  Feedback update(ToolContext& context, const ToolEvent& event) override {
    if (seam_mode_) trace(context, event);
    else drag(context, event);
    return {};
  }

  void end(ToolContext& context, const ToolEvent& event) override {
    if (seam_mode_) {
      trace(context, event);
      sew_seam(context);
    } else {
      drag(context, event);
      release(context);
    }
  }

  void cancel(ToolContext&) override {
    grabbed_ = Mesh::null_vertex();
    side_a_.clear();
    side_b_.clear();
  }

 private:
  static bool border_neighbours(const Garment& g, Vertex a, Vertex b) {
    auto [h, found] = CGAL::halfedge(a, b, g.mesh());
    return found && g.mesh().is_border(g.mesh().edge(h));
  }

  static Vertex nearest_border(const Garment& g, const Vec3& p, double within, Vertex skip) {
    Vertex best = Mesh::null_vertex();
    double d = within * within;
    for (Vertex v : g.mesh().vertices()) {
      if (v == skip || !g.mesh().is_border(v)) continue;
      const double e = (g.position(v) - p).squaredNorm();
      if (e <= d) d = e, best = v;
    }
    return best;
  }

  void release(ToolContext& context) {
    if (grabbed_ == Mesh::null_vertex()) return;
    context.garment(garment_).set_pinned(grabbed_, was_pinned_);
    grabbed_ = Mesh::null_vertex();
  }

  void drag(ToolContext& context, const ToolEvent& e) {
    if (grabbed_ == Mesh::null_vertex()) return;
    Garment& g = context.garment(garment_);
    g.set_position(grabbed_, e.position + offset_);
    g.velocity(grabbed_) = Vec3::Zero();
    // The nearest other border vertex within the sewing distance, not already joined to it.
    Vertex target = Mesh::null_vertex();
    double d = distance_ * distance_;
    for (Vertex v : g.mesh().vertices()) {
      if (v == grabbed_ || !g.mesh().is_border(v) || CGAL::halfedge(v, grabbed_, g.mesh()).second) continue;
      const double e2 = (g.position(v) - g.position(grabbed_)).squaredNorm();
      if (e2 <= d) d = e2, target = v;
    }
    if (target == Mesh::null_vertex()) return;
    const Vertex moving = grabbed_;
    release(context);
    sew_pair(g, target, moving);
  }

  // Merges `moving` into `target`, or tacks them and closes a seam with a neighbouring tack.
  static void sew_pair(Garment& g, Vertex target, Vertex moving) {
    try {
      merge_vertices(g, target, moving);
      return;
    } catch (const TopologyError&) {
    }
    for (std::size_t i = 0; i < g.tacks.size(); ++i) {
      const auto [p, q] = g.tacks[i];
      for (int swap = 0; swap < 2; ++swap) {
        const Vertex a = swap ? q : p, b = swap ? p : q;
        if (border_neighbours(g, a, target) && border_neighbours(g, b, moving)) {
          try {
            stitch(g, {a, target}, {b, moving});
            return;
          } catch (const Error&) {
          }
        }
      }
    }
    g.tacks.emplace_back(target, moving);
    g.velocity(moving) = Vec3::Zero();
  }

  void trace(ToolContext& context, const ToolEvent& e) {
    if (!e.hit.hit) return;
    if (side_a_.empty() && side_b_.empty()) garment_ = e.hit.garment;
    if (e.hit.garment != garment_) return;
    const Garment& g = context.garment(garment_);
    const Vertex v = nearest_border(g, e.hit.point, std::numeric_limits<double>::infinity(), Mesh::null_vertex());
    auto& side = (e.buttons & kButtonSecondary) ? side_b_ : side_a_;
    if (v != Mesh::null_vertex() && (side.empty() || side.back() != v)) side.push_back(v);
  }

  // The traced border vertices joined along the border into one polyline.
  static std::vector<Vertex> along_border(const Garment& g, const std::vector<Vertex>& stops) {
    std::vector<Vertex> path;
    for (Vertex v : stops) {
      if (path.empty()) {
        path.push_back(v);
        continue;
      }
      if (v == path.back()) continue;
      const auto piece = border_path(g, path.back(), v);
      path.insert(path.end(), piece.begin() + 1, piece.end());
    }
    return path;
  }

  void sew_seam(ToolContext& context) {
    if (side_a_.empty() || side_b_.empty())
      throw InputError("sew: a seam needs both borders traced: the first with the primary button, the "
                       "second with the secondary");
    Garment& g = context.garment(garment_);
    const auto a = along_border(g, side_a_), b = along_border(g, side_b_);
    if (closing_)
      tack_seam(g, a, b);
    else
      stitch(g, a, b);
  }

  bool seam_mode_ = false;
  bool closing_ = false;
  double distance_ = 0.01;
  std::size_t garment_ = 0;
  Vertex grabbed_;
  bool was_pinned_ = false;
  Vec3 offset_ = Vec3::Zero();
  std::vector<Vertex> side_a_, side_b_;
};

}  // namespace

KIJI_TOOL_PLUGIN(SewTool)
