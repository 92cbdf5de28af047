#include "cloth/garment_soup.h"

#include "kiji/error.h"

#include <CGAL/boost/graph/helpers.h>

#include <numeric>

namespace kiji::detail {

Soup to_soup(const Garment& g) {
  const Mesh& m = g.mesh();
  Soup s;
  s.vertices.resize(g.vertex_capacity());
  for (Vertex v : m.vertices()) {
    VertexData& d = s.vertices[v.idx()];
    d.position = g.position(v);
    d.velocity = g.velocity(v);
    d.inverse_mass = g.inverse_mass(v);
    d.alive = true;
  }
  s.faces.reserve(m.number_of_faces());
  s.uvs.reserve(m.number_of_faces());
  s.panels.reserve(m.number_of_faces());
  for (Face f : m.faces()) {
    std::array<Index, 3> corners{};
    std::array<Vec2, 3> uv;
    int k = 0;
    for (Halfedge h : CGAL::halfedges_around_face(m.halfedge(f), m)) {
      if (k < 3) {
        corners[k] = m.target(h).idx();
        uv[k] = g.uv(h);
      }
      ++k;
    }
    if (k != 3) throw TopologyError("garment '" + g.name + "' has a face that is not a triangle");
    s.add_face(corners, uv, g.panel(f));
  }
  for (const auto& [a, b] : g.tacks) s.tacks.emplace_back(a.idx(), b.idx());
  s.edges.reserve(m.number_of_edges());
  for (Edge e : m.edges()) {
    const Halfedge h = m.halfedge(e);
    s.edges[edge_key(m.source(h).idx(), m.target(h).idx())] = {g.rest_length(e), g.tear_threshold(e)};
  }
  return s;
}

// Splits every vertex whose faces fall into separate fans (wedges that share no edge at that
// vertex) into one vertex a fan. Returns the number of vertices added.
std::size_t split_fans(Soup& s) {
  const auto inc = s.incidence();
  std::size_t added = 0;
  const std::size_t n = s.vertices.size();
  for (Index v = 0; v < n; ++v) {
    const auto& fs = inc[v];
    if (fs.size() < 2) continue;
    // Union faces of the fan that share an edge (v, w).
    std::vector<std::size_t> parent(fs.size());
    std::iota(parent.begin(), parent.end(), 0);
    auto find = [&](std::size_t i) {
      while (parent[i] != i) i = parent[i] = parent[parent[i]];
      return i;
    };
    std::unordered_map<Index, std::size_t> first_with;
    for (std::size_t i = 0; i < fs.size(); ++i)
      for (Index w : s.faces[fs[i]]) {
        if (w == v) continue;
        auto [it, fresh] = first_with.emplace(w, i);
        if (!fresh) parent[find(i)] = find(it->second);
      }
    std::unordered_map<std::size_t, Index> vertex_of_root;
    for (std::size_t i = 0; i < fs.size(); ++i) {
      const std::size_t r = find(i);
      auto it = vertex_of_root.find(r);
      Index target;
      if (it == vertex_of_root.end()) {
        target = vertex_of_root.empty() ? v : s.add_vertex(s.vertices[v]);
        if (target != v) ++added;
        vertex_of_root.emplace(r, target);
      } else {
        target = it->second;
      }
      if (target == v) continue;
      for (Index& c : s.faces[fs[i]])
        if (c == v) c = target;
    }
    // Edge data for the new copies of (v, w).
    for (const auto& [root, nv] : vertex_of_root) {
      if (nv == v) continue;
      for (std::size_t i = 0; i < fs.size(); ++i) {
        if (find(i) != root) continue;
        for (Index w : s.faces[fs[i]]) {
          if (w == nv) continue;
          auto it = s.edges.find(edge_key(v, w));
          if (it != s.edges.end()) s.edges.emplace(edge_key(nv, w), it->second);
        }
      }
    }
  }
  return added;
}

// Throws TopologyError if an edge is used by more than two faces or by two faces in the same
// direction, or if a vertex has more than one fan.
void check_manifold(const Soup& s, const std::string& what) {
  std::unordered_map<std::uint64_t, int> directed;
  for (const auto& f : s.faces) {
    if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2])
      throw TopologyError(what + ": a face would lose an edge (degenerate triangle)");
    for (int k = 0; k < 3; ++k) {
      const std::uint64_t d = (std::uint64_t(f[k]) << 32) | f[(k + 1) % 3];
      if (++directed[d] > 1)
        throw TopologyError(what + ": two faces would share an edge with opposite orientations, or "
                                   "more than two faces would meet at an edge");
    }
  }
  Soup copy = s;
  if (split_fans(copy) > 0)
    throw TopologyError(what + ": the cloth would meet itself at a single vertex (non-manifold); "
                               "join a neighbouring pair as well, or sew along a seam");
}

// Builds the mesh from the soup and swaps it into the garment; the garment is untouched on error.
void commit(Garment& g, const Soup& s, const std::string& what) {
  Mesh m;
  const std::size_t n = s.vertices.size();
  m.reserve(n, s.edges.size() + s.faces.size(), s.faces.size());
  for (std::size_t i = 0; i < n; ++i) m.add_vertex(to_point(s.vertices[i].position));
  auto rest = m.add_property_map<Edge, double>("e:rest_length", 0.0).first;
  auto threshold = m.add_property_map<Edge, double>("e:tear_threshold", 0.0).first;
  auto uv = m.add_property_map<Halfedge, Vec2>("h:uv", Vec2::Zero()).first;
  auto velocity = m.add_property_map<Vertex, Vec3>("v:velocity", Vec3::Zero()).first;
  auto inverse_mass = m.add_property_map<Vertex, double>("v:inverse_mass", 1.0).first;
  auto panel = m.add_property_map<Face, int>("f:panel", 0).first;

  for (std::size_t fi = 0; fi < s.faces.size(); ++fi) {
    const auto& f = s.faces[fi];
    const Face face = m.add_face(Vertex(f[0]), Vertex(f[1]), Vertex(f[2]));
    if (face == Mesh::null_face())
      throw TopologyError(what + ": the result would not be a manifold mesh");
    panel[face] = s.panels[fi];
    for (Halfedge h : CGAL::halfedges_around_face(m.halfedge(face), m)) {
      const Index t = m.target(h).idx();
      for (int k = 0; k < 3; ++k)
        if (f[k] == t) uv[h] = s.uvs[fi][k];
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    const Vertex v(static_cast<Index>(i));
    if (!s.vertices[i].alive || m.is_isolated(v)) {
      m.remove_vertex(v);
      continue;
    }
    velocity[v] = s.vertices[i].velocity;
    inverse_mass[v] = s.vertices[i].inverse_mass;
  }
  const std::vector<Vertex> bad = non_manifold_vertices(m);
  if (!bad.empty())
    throw TopologyError(what + ": vertex " + std::to_string(bad.front().idx()) + " would be non-manifold");
  const double ratio = g.material().tear_ratio;
  for (Edge e : m.edges()) {
    const Halfedge h = m.halfedge(e);
    auto it = s.edges.find(edge_key(m.source(h).idx(), m.target(h).idx()));
    if (it != s.edges.end()) {
      rest[e] = it->second.rest;
      threshold[e] = it->second.threshold;
    } else {
      rest[e] = std::sqrt(CGAL::squared_distance(m.point(m.source(h)), m.point(m.target(h))));
      threshold[e] = ratio * rest[e];
    }
  }
  if (!CGAL::is_valid_polygon_mesh(m)) throw TopologyError(what + ": the result would not be a valid mesh");
  std::vector<std::pair<Vertex, Vertex>> tacks;
  for (const auto& [a, b] : s.tacks)
    if (a != b && a < n && b < n && !m.is_removed(Vertex(a)) && !m.is_removed(Vertex(b)))
      tacks.emplace_back(Vertex(a), Vertex(b));
  g.replace_mesh(std::move(m));
  g.tacks = std::move(tacks);
  g.recompute_masses();
}

}  // namespace kiji::detail
