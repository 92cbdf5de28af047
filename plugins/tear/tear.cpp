// tear: pull the cloth until it gives. As in the 2006 paper, every edge has a length threshold
// (the fabric's property: high for rubber-like cloth, low for fragile cloth); an edge pulled past
// it breaks. Mode 'remove' removes the edge with its two faces (the paper); mode 'split' opens the
// cloth along the edge instead, so no cloth is lost.
#include <kiji/tool.h>
#include <kiji/topology.h>

#include <set>

namespace {

using namespace kiji;

class TearTool : public Tool {
 public:
  ToolInfo info() const override {
    return {"tear", "Tear",
            "Grabs the cloth nearest the pointer and pulls it; edges stretched past the fabric's tear threshold "
            "break. Mode 'remove' removes a broken edge with its faces (the 2006 paper); mode 'split' opens the "
            "cloth along it and loses nothing.",
            {ParamSpec::choice("mode", "remove", {"remove", "split"}, "Mode",
                               "'remove' drops the broken edge and its two faces; 'split' opens the cloth there."),
             ParamSpec::real("stiffness", 200.0, 0.01, 1e6, "N/m", "Stiffness",
                             "Stiffness of the spring between the pointer and the grabbed vertex.")}};
  }

  Feedback begin(ToolContext& context, const ParamSet& params, const ToolEvent& event) override {
    split_ = params.get_string("mode") == "split";
    stiffness_ = params.get_float("stiffness");
    grabbed_ = Mesh::null_vertex();
    if (!event.hit.hit) return {};
    garment_ = event.hit.garment;
    grabbed_ = event.hit.nearest;
    attachment_ = context.attach(garment_, grabbed_, event.position, stiffness_, /*firm=*/true);
    return feedback(context, event.position);
  }

  Feedback update(ToolContext& context, const ToolEvent& event) override {
    if (grabbed_ == Mesh::null_vertex()) return {};
    tear_overstretched(context.garment(garment_));
    const Garment& g = context.garment(garment_);
    if (g.mesh().is_removed(grabbed_)) {  // the grabbed corner tore off with its faces
      context.release(garment_, attachment_);
      grabbed_ = Mesh::null_vertex();
      return {};
    }
    context.move(garment_, attachment_, event.position);
    return feedback(context, event.position);
  }

  void end(ToolContext& context, const ToolEvent& event) override {
    if (grabbed_ == Mesh::null_vertex()) return;
    tear_overstretched(context.garment(garment_));
    release(context);
  }

  void cancel(ToolContext& context) override { release(context); }

 private:
  Feedback feedback(const ToolContext& context, const Vec3& pointer) const {
    Feedback f;
    const Garment& g = context.garment(garment_);
    if (grabbed_ != Mesh::null_vertex() && !g.mesh().is_removed(grabbed_))
      f.force = stiffness_ * (g.position(grabbed_) - pointer);
    return f;
  }

  void release(ToolContext& context) {
    if (grabbed_ != Mesh::null_vertex() && garment_ < context.garment_count())
      context.release(garment_, attachment_);
    grabbed_ = Mesh::null_vertex();
  }

  void tear_overstretched(Garment& g) {
    const Mesh& m = g.mesh();
    std::vector<Edge> broken;
    for (Edge e : m.edges())
      if (g.length(e) > g.tear_threshold(e)) broken.push_back(e);
    if (broken.empty()) return;
    if (!split_) {
      remove_edges(g, broken);
      return;
    }
    // Split mode: open each broken edge by cutting along it; an edge inside the cloth opens
    // together with the most stretched edge next to it, since one edge alone cannot open.
    std::vector<std::pair<Vertex, Vertex>> ends;
    for (Edge e : broken) ends.emplace_back(m.source(m.halfedge(e)), m.target(m.halfedge(e)));
    for (auto [a, b] : ends) {
      const Mesh& mm = g.mesh();
      if (mm.is_removed(a) || mm.is_removed(b) || !CGAL::halfedge(a, b, mm).second) continue;
      if (mm.is_border(mm.edge(CGAL::halfedge(a, b, mm).first))) continue;  // already open
      std::vector<Vertex> path;
      if (mm.is_border(a)) path = {a, b};
      else if (mm.is_border(b)) path = {b, a};
      else {
        Vertex x = Mesh::null_vertex();
        double worst = -1;
        for (Vertex w : CGAL::vertices_around_target(mm.halfedge(a), mm)) {
          if (w == b) continue;
          const Edge e = mm.edge(CGAL::halfedge(a, w, mm).first);
          const double s = g.length(e) / g.tear_threshold(e);
          if (s > worst) worst = s, x = w;
        }
        if (x == Mesh::null_vertex()) continue;
        path = {x, a, b};
      }
      cut_along(g, path);
    }
  }

  bool split_ = false;
  double stiffness_ = 200;
  std::size_t garment_ = 0;
  Vertex grabbed_;
  int attachment_ = -1;
};

}  // namespace

KIJI_TOOL_PLUGIN(TearTool)
