// cut: the knife. Along the line the stroke draws on the cloth (through the triangles it crosses);
// along the mesh edges nearest the stroke (all that earlier builds did, and what their journals
// name); or, as in the 2006 paper, at one picked vertex that is split in two with its faces shared
// between the halves.
#include <kiji/error.h>
#include <kiji/tool.h>
#include <kiji/topology.h>

#include <algorithm>
#include <limits>

namespace {

using namespace kiji;

class CutTool : public Tool {
 public:
  ToolInfo info() const override {
    return {"cut", "Cut",
            "Cuts the cloth along the line the stroke draws (mode 'line'): through the triangles it crosses, "
            "so the opening follows the line; a stroke from border to border separates the cloth into pieces, "
            "and one that comes back to where it began cuts out what it encloses. Mode 'stroke' opens the mesh "
            "edges nearest the stroke. Mode 'vertex' is the 2006 paper's cut: the picked vertex splits in two "
            "along the direction of the stroke.",
            {ParamSpec::choice("mode", "line", {"line", "stroke", "vertex"}, "Mode",
                               "'line' cuts along the drawn line; 'stroke' along the mesh edges nearest it; "
                               "'vertex' splits the vertex where the stroke begins, towards where it goes."),
             ParamSpec::real("close", 0.03, 0.0, 0.5, "m", "Close within",
                             "A line that ends this near where it began is closed, and what it encloses is cut "
                             "out (0: never closed)."),
             ParamSpec::choice("follow", "surface", {"surface", "pattern"}, "Follow",
                               "Mode 'line', between two points of the stroke: 'surface' follows the cloth as it "
                               "lies (the layer the stroke is on, under folds); 'pattern' goes straight in the flat "
                               "pattern between the cloth points the stroke touched, across folds and wrinkles (a "
                               "script's or a pen's cut through points on the cloth; a stroke drawn in a view "
                               "follows what it covers as seen).")}};
  }

  Feedback begin(ToolContext& context, const ParamSet& params, const ToolEvent& event) override {
    const std::string mode = params.get_string("mode");
    mode_ = mode == "vertex" ? Mode::Vertex : mode == "line" ? Mode::Line : Mode::Edges;
    close_ = params.get_float("close");
    follow_pattern_ = params.get_string("follow") == "pattern";
    points_.clear();
    marks_.clear();
    started_off_cloth_ = !event.hit.hit;
    first_position_ = event.position;
    record(context, event);
    return {};
  }

  Feedback update(ToolContext& context, const ToolEvent& event) override {
    record(context, event);
    return {};
  }

  void end(ToolContext& context, const ToolEvent& event) override {
    record(context, event);
    if (points_.empty()) return;  // the stroke never touched the cloth
    Garment& g = context.garment(garment_);
    const bool ended_off_cloth = !event.hit.hit;
    if (mode_ == Mode::Vertex) split_picked(g, event.position - first_position_);
    else if (mode_ == Mode::Line) cut_line_drawn(g, ended_off_cloth, event.position);
    else cut_stroke(g, ended_off_cloth, event.position);
    points_.clear();
    marks_.clear();
  }

  void cancel(ToolContext&) override {
    points_.clear();
    marks_.clear();
  }

 private:
  void record(const ToolContext& context, const ToolEvent& e) {
    if (!e.hit.hit) return;
    if (points_.empty()) {
      garment_ = e.hit.garment;
      topology_at_begin_ = context.garment(garment_).topology_version();
    }
    if (e.hit.garment != garment_) return;
    if (points_.empty() || points_.back() != e.hit.nearest) points_.push_back(e.hit.nearest);
    marks_.push_back({e.hit.face, e.hit.barycentric, e.hit.point, e.ray});
  }

  // Where the line was drawn, on the cloth as it lies now: the cloth may have moved under the
  // stroke, so each point is taken where its face has gone, while no edit has changed the faces.
  std::vector<Vec3> drawn(const Garment& g) const {
    std::vector<Vec3> out;
    const bool same_faces = g.topology_version() == topology_at_begin_;
    for (const Mark& m : marks_) {
      Vec3 p = m.point;
      if (same_faces) {
        p = Vec3::Zero();
        int k = 0;
        for (Vertex v : CGAL::vertices_around_face(g.mesh().halfedge(m.face), g.mesh())) p += m.weights[k++] * g.position(v);
      }
      out.push_back(p);
    }
    return out;
  }

  void cut_line_drawn(Garment& g, bool ended_off_cloth, const Vec3& last_position) {
    KnifeLine line;
    line.start = marks_.front().face;
    line.points = drawn(g);
    if (started_off_cloth_) line.from = first_position_;
    if (ended_off_cloth) line.to = last_position;
    // Drawn in a view (every point with a ray), the line is what the stroke covers as seen.
    if (std::all_of(marks_.begin(), marks_.end(), [](const Mark& m) { return m.ray.squaredNorm() > 0; }))
      for (const Mark& m : marks_) line.sweeps.push_back(m.ray.normalized());
    line.closed = !started_off_cloth_ && !ended_off_cloth && knife_line_closes(line.points, close_);
    // Where each point lies on the cloth, while the faces are those it was drawn on: along the
    // pattern, or for a closed stroke drawn in a view, the cloth it encloses as seen (cut_line). Not
    // the pattern for a stroke in a view: over folds its points hop between layers, and the line
    // between them in the pattern encloses scraps of cloth.
    if ((line.sweeps.empty() ? follow_pattern_ : line.closed) && !started_off_cloth_ && !ended_off_cloth &&
        g.topology_version() == topology_at_begin_) {
      for (const Mark& m : marks_) {
        line.faces.push_back(m.face);
        line.weights.push_back(m.weights);
      }
    }
    // The stroke's return to its start is the closing piece of the line, which the knife draws.
    if (line.closed)
      while (line.points.size() > 3 && (line.points.back() - line.points.front()).norm() <= 0.5 * close_) {
        line.points.pop_back();
        if (!line.sweeps.empty()) line.sweeps.pop_back();
        if (!line.faces.empty()) line.faces.pop_back(), line.weights.pop_back();
      }
    if (line.points.size() < 2 && !line.from && !line.to) return;  // a tap: nothing drawn to cut
    cut_line(g, line);
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

  struct Mark {
    Face face;
    Vec3 weights;
    Vec3 point;
    Vec3 ray;  // the view's ray at the point (zero: a pen's, or a script's, event)
  };
  enum class Mode { Line, Edges, Vertex };
  Mode mode_ = Mode::Line;
  double close_ = 0.03;
  bool follow_pattern_ = false;
  std::uint64_t topology_at_begin_ = 0;
  std::vector<Mark> marks_;  // the line mode's points, as drawn
  bool started_off_cloth_ = false;
  Vec3 first_position_ = Vec3::Zero();
  std::size_t garment_ = 0;
  std::vector<Vertex> points_;
};

}  // namespace

KIJI_TOOL_PLUGIN(CutTool)
