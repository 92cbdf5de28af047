#include "kiji/scene_frame.h"

#include "kiji/session.h"

#include <cstring>

namespace kiji {

namespace {

std::shared_ptr<const GarmentTopology> build_topology(const Garment& g) {
  auto t = std::make_shared<GarmentTopology>();
  const Mesh& m = g.mesh();
  t->topology_version = g.topology_version();
  t->vertex_count = m.number_of_vertices();
  t->face_count = m.number_of_faces();
  // Each vertex's corners so far, by uv: most vertices have one, a seam's two or three.
  std::vector<std::vector<std::pair<Vec2, std::uint32_t>>> corners(g.vertex_capacity());
  t->triangles.reserve(3 * m.number_of_faces());
  for (Face f : m.faces()) {
    for (Halfedge h : CGAL::halfedges_around_face(m.halfedge(f), m)) {
      const Vertex v = m.target(h);
      const Vec2 uv = g.uv(h);
      auto& mine = corners[v.idx()];
      std::uint32_t index = 0;
      bool found = false;
      for (const auto& [seen, i] : mine)
        if (seen == uv) {
          index = i;
          found = true;
          break;
        }
      if (!found) {
        index = static_cast<std::uint32_t>(t->mesh_vertex.size());
        t->mesh_vertex.push_back(v.idx());
        t->uv.push_back(static_cast<float>(uv.x()));
        t->uv.push_back(static_cast<float>(uv.y()));
        mine.emplace_back(uv, index);
      }
      t->triangles.push_back(index);
    }
  }
  t->points.reserve(m.number_of_vertices());
  for (Vertex v : m.vertices())
    if (!corners[v.idx()].empty()) t->points.push_back(corners[v.idx()].front().second);
  t->edges.reserve(2 * m.number_of_edges());
  for (Edge e : m.edges()) {
    const auto& a = corners[m.vertex(e, 0).idx()];
    const auto& b = corners[m.vertex(e, 1).idx()];
    if (a.empty() || b.empty()) continue;
    t->edges.push_back(a.front().second);
    t->edges.push_back(b.front().second);
  }
  return t;
}

}  // namespace

Box3 SceneFrame::bounds() const {
  Box3 b;
  for (const GarmentFrame& g : garments) b.extend(g.bounds);
  if (body) b.extend(body->bounds());
  return b;
}

std::shared_ptr<SceneFrame> SceneFrameBuilder::build(const Session& session, bool textures_may_have_changed) {
  auto frame = std::make_shared<SceneFrame>();
  frame->number = ++number_;
  frame->time = session.time();
  frame->stroke_active = session.stroke_active();
  frame->stroke_tool = session.active_tool();
  frame->simulating = session.simulating();
  frame->can_undo = session.journal().can_undo();
  frame->can_redo = session.journal().can_redo();

  const Body* body = session.body();
  if (!body) {
    body_.reset();
  } else if (!body_ || body_->geometry_id() != body->geometry_id()) {
    body_ = std::make_shared<const Body>(*body);
  }
  frame->body = body_;

  garments_.resize(session.garment_count());
  frame->garments.resize(session.garment_count());
  for (std::size_t gi = 0; gi < session.garment_count(); ++gi) {
    const Garment& g = session.garment(gi);
    const Mesh& m = g.mesh();
    Cache& cache = garments_[gi];
    GarmentFrame& out = frame->garments[gi];
    if (!cache.topology || cache.topology->topology_version != g.topology_version()) {
      cache.topology = build_topology(g);
      textures_may_have_changed = true;
    }
    const GarmentTopology& t = *cache.topology;
    out.name = g.name;
    out.tacks.reserve(2 * g.tacks.size());
    for (const auto& [a, b] : g.tacks) out.tacks.insert(out.tacks.end(), {std::uint32_t(a.idx()), std::uint32_t(b.idx())});
    out.topology = cache.topology;
    out.color = g.color;
    frame->vertices += t.vertex_count;
    frame->faces += t.face_count;

    // Vertex normals, area-weighted: the sum of the faces' unnormalised normals.
    std::vector<Vec3> normal(g.vertex_capacity(), Vec3::Zero());
    for (Face f : m.faces()) {
      const Halfedge h0 = m.halfedge(f), h1 = m.next(h0), h2 = m.next(h1);
      const Vertex a = m.target(h0), b = m.target(h1), c = m.target(h2);
      const Vec3 pa = g.position(a);
      const Vec3 n = (g.position(b) - pa).cross(g.position(c) - pa);
      normal[a.idx()] += n;
      normal[b.idx()] += n;
      normal[c.idx()] += n;
    }
    const std::size_t count = t.mesh_vertex.size();
    out.positions.resize(3 * count);
    out.normals.resize(3 * count);
    for (std::size_t i = 0; i < count; ++i) {
      const Vertex v(t.mesh_vertex[i]);
      const Vec3 p = g.position(v);
      out.bounds.extend(p);
      Vec3 n = normal[v.idx()];
      const double len = n.norm();
      n = len > 0 ? Vec3(n / len) : Vec3(0, 0, 1);
      for (int k = 0; k < 3; ++k) {
        out.positions[3 * i + k] = static_cast<float>(p[k]);
        out.normals[3 * i + k] = static_cast<float>(n[k]);
      }
    }

    const Texture& tex = g.texture();
    if (tex.empty()) {
      cache.texture.reset();
    } else if (!cache.texture || (textures_may_have_changed &&
                                  (cache.texture->width != tex.width || cache.texture->height != tex.height ||
                                   std::memcmp(cache.texture->rgba.data(), tex.rgba.data(), tex.rgba.size()) != 0))) {
      cache.texture = std::make_shared<const Texture>(tex);
    }
    out.texture = cache.texture;
  }
  return frame;
}

}  // namespace kiji
