// cut: the knife. Along a stroke over the cloth, or, as in the 2006 paper, at one picked vertex
// that is split in two with its faces shared between the halves.
#include <kiji/error.h>
#include <kiji/tool.h>
#include <kiji/topology.h>

#include <limits>

namespace {

using namespace kiji;

class CutTool : public Tool {
 public:
  ToolInfo info() const override {
    return {"cut", "Cut",
            "Cuts the cloth along the stroke (mode 'stroke'): every edge under the stroke opens, and a stroke "
            "from border to border separates the cloth into pieces. Mode 'vertex' is the 2006 paper's cut: "
            "the picked vertex splits in two along the direction of the stroke.",
            {ParamSpec::choice("mode", "stroke", {"stroke", "vertex"}, "Mode",
                               "'stroke' cuts along the whole stroke; 'vertex' splits the vertex where the stroke "
                               "begins, towards where it goes.")}};
  }

  Feedback begin(ToolContext& context, const ParamSet& params, const ToolEvent& event) override {
    vertex_mode_ = params.get_string("mode") == "vertex";
    points_.clear();
    started_off_cloth_ = !event.hit.hit;
    first_position_ = event.position;
    record(event);
    return {};
  }

  Feedback update(ToolContext& context, const ToolEvent& event) override {
    record(event);
    return {};
  }

  void end(ToolContext& context, const ToolEvent& event) override {
    record(event);
    if (points_.empty()) return;  // the stroke never touched the cloth
    Garment& g = context.garment(garment_);
    if (vertex_mode_) {
      split_picked(g, event.position - first_position_);
    } else {
      const bool ended_off_cloth = !event.hit.hit;
      cut_stroke(g, ended_off_cloth, event.position);
    }
    points_.clear();
  }

  void cancel(ToolContext&) override { points_.clear(); }

 private:
  void record(const ToolEvent& e) {
    if (!e.hit.hit) return;
    if (points_.empty()) garment_ = e.hit.garment;
    if (e.hit.garment != garment_) return;
    if (points_.empty() || points_.back() != e.hit.nearest) points_.push_back(e.hit.nearest);
  }

  // The border vertex nearest a point.
  static Vertex nearest_border(const Garment& g, const Vec3& p) {
    Vertex best;
    double d = std::numeric_limits<double>::infinity();
    for (Vertex v : g.mesh().vertices())
      if (g.mesh().is_border(v) && (g.position(v) - p).squaredNorm() < d) {
        d = (g.position(v) - p).squaredNorm();
        best = v;
      }
    return best;
  }

  void cut_stroke(Garment& g, bool ended_off_cloth, const Vec3& last_position) {
    std::vector<Vertex> stops = points_;
    // A stroke that starts or ends off the cloth cuts through to the border.
    if (started_off_cloth_) stops.insert(stops.begin(), nearest_border(g, first_position_));
    if (ended_off_cloth) stops.push_back(nearest_border(g, last_position));
    std::vector<Vertex> path;
    for (std::size_t i = 0; i < stops.size(); ++i) {
      if (i == 0) {
        path.push_back(stops[0]);
        continue;
      }
      if (stops[i] == path.back()) continue;
      const auto piece = edge_path(g, path.back(), stops[i]);
      path.insert(path.end(), piece.begin() + 1, piece.end());
    }
    // A stroke that doubles back cuts each vertex once: drop the loop between two visits.
    std::vector<Vertex> simple;
    for (Vertex v : path) {
      auto it = std::find(simple.begin(), simple.end(), v);
      if (it != simple.end()) simple.erase(it + 1, simple.end());
      else simple.push_back(v);
    }
    if (simple.size() >= 2) cut_along(g, simple);
  }

  void split_picked(Garment& g, const Vec3& direction) {
    const Mesh& m = g.mesh();
    const Vertex v = points_.front();
    const Vec3 dir = direction.squaredNorm() > 0 ? Vec3(direction.normalized()) : Vec3::UnitX();
    // The neighbours most along +dir and -dir; a border vertex splits towards the cloth only.
    Vertex ahead, behind;
    double best_ahead = -2, best_behind = -2;
    for (Vertex w : CGAL::vertices_around_target(m.halfedge(v), m)) {
      const bool border_edge = m.is_border(m.edge(CGAL::halfedge(v, w, m).first));
      if (border_edge) continue;
      const Vec3 e = (g.position(w) - g.position(v)).normalized();
      if (e.dot(dir) > best_ahead) best_ahead = e.dot(dir), ahead = w;
      if (-e.dot(dir) > best_behind) best_behind = -e.dot(dir), behind = w;
    }
    if (ahead == Mesh::null_vertex()) return;  // a lone triangle's corner: nothing to split along
    if (m.is_border(v)) split_vertex_between(g, v, ahead, ahead);
    else if (behind != ahead) split_vertex_between(g, v, ahead, behind);
  }

  bool vertex_mode_ = false;
  bool started_off_cloth_ = false;
  Vec3 first_position_ = Vec3::Zero();
  std::size_t garment_ = 0;
  std::vector<Vertex> points_;
};

}  // namespace

KIJI_TOOL_PLUGIN(CutTool)
