// Topology edits on a face soup: every edit lowers the garment to a list of faces (with their
// corner uvs and panels) and per-vertex data, changes that list, and builds a new Surface_mesh from
// it. Building the whole mesh again costs O(n) per edit, but each edit is then a few lines of list
// surgery, the result is checked before it replaces anything (so a refused edit leaves the garment
// untouched), and vertex indices stay stable because vertices are added back in index order.
#include "kiji/topology.h"

#include "cloth/garment_soup.h"
#include "kiji/error.h"

#include <CGAL/boost/graph/helpers.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <numeric>
#include <optional>
#include <queue>
#include <set>
#include <sstream>
#include <unordered_map>

namespace kiji {

namespace {

namespace PMP = CGAL::Polygon_mesh_processing;

using detail::Soup;
using detail::Index;
using detail::VertexData;
using detail::EdgeData;
using detail::edge_key;
using detail::to_soup;
using detail::commit;
using detail::split_fans;
using detail::check_manifold;

void require_vertex(const Garment& g, Vertex v, const char* role) {
  if (v == Mesh::null_vertex() || v.idx() >= g.vertex_capacity() || g.mesh().is_removed(v))
    throw InputError(std::string(role) + " vertex " + std::to_string(v.idx()) +
                     " is not a vertex of garment '" + g.name + "'");
}

// Faces of the piece containing face `seed` (by shared edges).
std::vector<char> piece_of(const Soup& s, Index seed) {
  std::unordered_map<std::uint64_t, std::vector<Index>> by_edge;
  for (Index f = 0; f < s.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) by_edge[edge_key(s.faces[f][k], s.faces[f][(k + 1) % 3])].push_back(f);
  std::vector<char> seen(s.faces.size(), 0);
  std::vector<Index> stack{seed};
  seen[seed] = 1;
  while (!stack.empty()) {
    const Index f = stack.back();
    stack.pop_back();
    for (int k = 0; k < 3; ++k)
      for (Index n : by_edge[edge_key(s.faces[f][k], s.faces[f][(k + 1) % 3])])
        if (!seen[n]) {
          seen[n] = 1;
          stack.push_back(n);
        }
  }
  return seen;
}

// Reverses the winding of every face of the piece containing face `seed`.
void flip_piece(Soup& s, Index seed) {
  const std::vector<char> in_piece = piece_of(s, seed);
  for (Index f = 0; f < s.faces.size(); ++f)
    if (in_piece[f]) {
      std::swap(s.faces[f][1], s.faces[f][2]);
      std::swap(s.uvs[f][1], s.uvs[f][2]);
    }
}

// Replaces vertex `gone` by `keep` in every face (dropping faces that then repeat a vertex) and in
// the edge data, where two coinciding edges average their rest lengths.
void substitute(Soup& s, Index keep, Index gone) {
  std::vector<char> drop(s.faces.size(), 0);
  bool any = false;
  for (std::size_t f = 0; f < s.faces.size(); ++f) {
    bool has_keep = false, has_gone = false;
    for (Index v : s.faces[f]) {
      has_keep |= v == keep;
      has_gone |= v == gone;
    }
    if (has_keep && has_gone) {
      drop[f] = 1;
      any = true;
    } else if (has_gone) {
      for (Index& v : s.faces[f])
        if (v == gone) v = keep;
    }
  }
  if (any) s.erase_faces(drop);
  std::vector<std::pair<std::uint64_t, EdgeData>> moved;
  for (auto it = s.edges.begin(); it != s.edges.end();) {
    const Index a = Index(it->first >> 32), b = Index(it->first & 0xffffffffu);
    if (a == gone || b == gone) {
      const Index other = a == gone ? b : a;
      if (other != keep) moved.emplace_back(edge_key(keep, other), it->second);
      it = s.edges.erase(it);
    } else {
      ++it;
    }
  }
  for (const auto& [key, data] : moved) {
    auto [it, fresh] = s.edges.emplace(key, data);
    if (!fresh) {
      it->second.rest = 0.5 * (it->second.rest + data.rest);
      it->second.threshold = 0.5 * (it->second.threshold + data.threshold);
    }
  }
  for (auto& [a, b] : s.tacks) {
    if (a == gone) a = keep;
    if (b == gone) b = keep;
  }
  VertexData& k = s.vertices[keep];
  const VertexData& g = s.vertices[gone];
  k.position = 0.5 * (k.position + g.position);
  k.velocity = 0.5 * (k.velocity + g.velocity);
  if (g.inverse_mass == 0.0) k.inverse_mass = 0.0;  // a pin on either side holds the seam
  s.vertices[gone].alive = false;
}

// Is the directed edge a -> b the side of a face (as opposed to b -> a)?
int face_with_directed_edge(const Soup& s, Index a, Index b) {
  for (Index f = 0; f < s.faces.size(); ++f)
    for (int k = 0; k < 3; ++k)
      if (s.faces[f][k] == a && s.faces[f][(k + 1) % 3] == b) return int(f);
  return -1;
}

Halfedge border_halfedge_between(const Mesh& m, Vertex a, Vertex b) {
  auto [h, found] = CGAL::halfedge(a, b, m);
  if (!found) return Mesh::null_halfedge();
  if (m.is_border(h)) return h;
  if (m.is_border(m.opposite(h))) return m.opposite(h);
  return Mesh::null_halfedge();
}

}  // namespace

Vertex split_vertex(Garment& g, Vertex v, const std::vector<Face>& moved) {
  require_vertex(g, v, "split");
  const Mesh& m = g.mesh();
  if (moved.empty()) throw InputError("split_vertex: no faces were given to move to the new vertex");
  std::set<Face> incident;
  for (Face f : CGAL::faces_around_target(m.halfedge(v), m))
    if (f != Mesh::null_face()) incident.insert(f);
  std::set<Index> moved_ids;
  for (Face f : moved) {
    if (!incident.count(f))
      throw InputError("split_vertex: face " + std::to_string(f.idx()) + " is not incident to vertex " +
                       std::to_string(v.idx()));
    moved_ids.insert(f.idx());
  }
  if (moved_ids.size() == incident.size())
    throw InputError("split_vertex: every face of vertex " + std::to_string(v.idx()) +
                     " would move, which splits nothing: keep at least one face on it");

  // Map the moved mesh faces to soup faces: to_soup walks faces in index order.
  Soup s = to_soup(g);
  std::vector<Index> soup_of_face(m.number_of_faces() + m.number_of_removed_faces(), Index(-1));
  {
    Index i = 0;
    for (Face f : m.faces()) soup_of_face[f.idx()] = i++;
  }
  const Index nv = s.add_vertex(s.vertices[v.idx()]);
  for (Index f : moved_ids)
    for (Index& c : s.faces[soup_of_face[f]])
      if (c == v.idx()) c = nv;
  for (Index f : moved_ids)
    for (Index w : s.faces[soup_of_face[f]]) {
      if (w == nv) continue;
      auto it = s.edges.find(edge_key(v.idx(), w));
      if (it != s.edges.end()) s.edges.emplace(edge_key(nv, w), it->second);
    }
  split_fans(s);
  commit(g, s, "split_vertex");
  return Vertex(nv);
}

Vertex split_vertex_between(Garment& g, Vertex v, Vertex a, Vertex b) {
  require_vertex(g, v, "split");
  require_vertex(g, a, "first edge's");
  require_vertex(g, b, "second edge's");
  const Mesh& m = g.mesh();
  auto [ha, found_a] = CGAL::halfedge(v, a, m);
  auto [hb, found_b] = CGAL::halfedge(v, b, m);
  if (!found_a || !found_b)
    throw InputError("split_vertex_between: (" + std::to_string(v.idx()) + ", " + std::to_string(a.idx()) +
                     ") and (" + std::to_string(v.idx()) + ", " + std::to_string(b.idx()) +
                     ") must both be edges of the garment");
  if (a == b && !m.is_border(v))
    throw InputError("split_vertex_between: an interior vertex is split along two different edges");
  // Walk counter-clockwise around v from (v, a): the face left of v -> a, then the next edge out.
  std::vector<Face> faces;
  Halfedge h = ha;
  for (std::size_t guard = 0; guard <= m.degree(v); ++guard) {
    const Face f = m.face(h);
    if (f == Mesh::null_face()) {
      if (a == b) break;
      throw InputError("split_vertex_between: the border was reached before edge (" + std::to_string(v.idx()) +
                       ", " + std::to_string(b.idx()) + ")");
    }
    faces.push_back(f);
    h = m.opposite(m.prev(h));
    if (m.target(h) == b && a != b) break;
  }
  return split_vertex(g, v, faces);
}

namespace {

Index path_source(const std::vector<std::pair<Vertex, std::set<Face>>>& moves, std::size_t k) {
  return moves[k].first.idx();
}

// Faces met turning counter-clockwise (or clockwise) around v, from edge (v, from) until edge
// (v, stop) or the border.
std::vector<Face> sweep(const Mesh& m, Vertex v, Vertex from, Vertex stop, bool clockwise) {
  std::vector<Face> faces;
  auto [h, found] = CGAL::halfedge(v, from, m);
  if (!found) return faces;
  for (std::size_t guard = 0; guard <= m.degree(v) + 1; ++guard) {
    const Face f = clockwise ? m.face(m.opposite(h)) : m.face(h);
    if (f == Mesh::null_face()) break;
    faces.push_back(f);
    h = clockwise ? m.next(m.opposite(h)) : m.opposite(m.prev(h));
    if (m.target(h) == stop || m.target(h) == from) break;
  }
  return faces;
}

}  // namespace

std::vector<Vertex> cut_along(Garment& g, const std::vector<Vertex>& path) {
  const Mesh& m = g.mesh();
  if (path.size() < 2) throw InputError("cut_along: a cut needs a path of at least 2 vertices");
  std::set<Vertex> seen;
  for (std::size_t i = 0; i < path.size(); ++i) {
    require_vertex(g, path[i], "cut path");
    if (!seen.insert(path[i]).second)
      throw InputError("cut_along: vertex " + std::to_string(path[i].idx()) + " appears twice in the path");
    if (i + 1 < path.size() && !CGAL::halfedge(path[i], path[i + 1], m).second)
      throw InputError("cut_along: vertices " + std::to_string(path[i].idx()) + " and " +
                       std::to_string(path[i + 1].idx()) + " are not joined by an edge");
  }
  // The faces on the left of the path (walking along it) move to new vertices.
  std::vector<std::pair<Vertex, std::set<Face>>> moves;
  const std::size_t n = path.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Vertex v = path[i];
    std::set<Face> left;
    if (i > 0 && i + 1 < n) {
      for (Face f : sweep(m, v, path[i + 1], path[i - 1], false)) left.insert(f);
      for (Face f : sweep(m, v, path[i - 1], path[i + 1], true)) left.insert(f);
    } else if (m.is_border(v)) {
      const bool start = i == 0;
      for (Face f : sweep(m, v, start ? path[1] : path[n - 2], Mesh::null_vertex(), !start)) left.insert(f);
    }
    std::size_t degree_faces = 0;
    for (Face f : CGAL::faces_around_target(m.halfedge(v), m)) degree_faces += f != Mesh::null_face();
    if (!left.empty() && left.size() < degree_faces) moves.emplace_back(v, std::move(left));
  }
  if (moves.empty()) return {};

  Soup s = to_soup(g);
  std::vector<Index> soup_of_face(m.number_of_faces() + m.number_of_removed_faces(), Index(-1));
  {
    Index i = 0;
    for (Face f : m.faces()) soup_of_face[f.idx()] = i++;
  }
  std::vector<Vertex> created;
  const std::size_t first_new = s.vertices.size();
  for (const auto& [v, faces] : moves) {
    const Index nv = s.add_vertex(s.vertices[v.idx()]);
    created.push_back(Vertex(nv));
    for (Face f : faces)
      for (Index& c : s.faces[soup_of_face[f.idx()]])
        if (c == v.idx()) c = nv;
  }
  // Edge data for the edges the new vertices now have, from the edges they came from.
  for (const auto& f : s.faces)
    for (int k = 0; k < 3; ++k) {
      const Index a = f[k], b = f[(k + 1) % 3];
      if (s.edges.count(edge_key(a, b))) continue;
      auto original = [&](Index x) { return x >= first_new ? path_source(moves, x - first_new) : x; };
      auto it = s.edges.find(edge_key(original(a), original(b)));
      if (it != s.edges.end()) s.edges.emplace(edge_key(a, b), it->second);
    }
  split_fans(s);
  commit(g, s, "cut_along");
  return created;
}

std::vector<Vertex> edge_path(const Garment& g, Vertex from, Vertex to) {
  require_vertex(g, from, "path start");
  require_vertex(g, to, "path end");
  const Mesh& m = g.mesh();
  const std::size_t n = g.vertex_capacity();
  std::vector<double> dist(n, std::numeric_limits<double>::infinity());
  std::vector<Vertex> parent(n, Mesh::null_vertex());
  using Item = std::pair<double, Index>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
  dist[from.idx()] = 0;
  queue.emplace(0.0, from.idx());
  while (!queue.empty()) {
    const auto [d, u] = queue.top();
    queue.pop();
    if (d > dist[u]) continue;
    if (u == to.idx()) break;
    for (Halfedge h : CGAL::halfedges_around_source(Vertex(u), m)) {
      const Vertex w = m.target(h);
      const double nd = d + (g.position(w) - g.position(Vertex(u))).norm();
      if (nd < dist[w.idx()]) {
        dist[w.idx()] = nd;
        parent[w.idx()] = Vertex(u);
        queue.emplace(nd, w.idx());
      }
    }
  }
  if (!std::isfinite(dist[to.idx()]))
    throw InputError("edge_path: vertices " + std::to_string(from.idx()) + " and " + std::to_string(to.idx()) +
                     " are on different pieces of cloth");
  std::vector<Vertex> path{to};
  while (path.back() != from) path.push_back(parent[path.back().idx()]);
  std::reverse(path.begin(), path.end());
  return path;
}

void remove_edges(Garment& g, const std::vector<Edge>& edges) {
  const Mesh& m = g.mesh();
  std::set<Index> faces;
  for (Edge e : edges) {
    if (e.idx() >= m.number_of_edges() + m.number_of_removed_edges() || m.is_removed(e))
      throw InputError("remove_edge: edge " + std::to_string(e.idx()) + " is not an edge of garment '" +
                       g.name + "'");
    for (Halfedge h : {m.halfedge(e), m.opposite(m.halfedge(e))})
      if (!m.is_border(h)) faces.insert(m.face(h).idx());
  }
  if (edges.empty()) return;
  Soup s = to_soup(g);
  std::vector<char> drop(s.faces.size(), 0);
  Index i = 0;
  for (Face f : m.faces()) {
    if (faces.count(f.idx())) drop[i] = 1;
    ++i;
  }
  s.erase_faces(drop);
  split_fans(s);
  commit(g, s, "remove_edge");
}

void remove_edge(Garment& g, Edge e) { remove_edges(g, {e}); }

Vertex merge_vertices(Garment& g, Vertex keep, Vertex gone) {
  require_vertex(g, keep, "kept");
  require_vertex(g, gone, "merged");
  if (keep == gone) throw InputError("merge_vertices: a vertex cannot be merged with itself");
  const std::string what = "merging vertex " + std::to_string(gone.idx()) + " into " + std::to_string(keep.idx());
  Soup s = to_soup(g);
  const auto inc = s.incidence();
  // Pieces with opposite orientations: flip the piece of `gone` so the seam can close.
  if (!inc[keep.idx()].empty() && !inc[gone.idx()].empty()) {
    const auto piece = piece_of(s, inc[keep.idx()].front());
    if (!piece[inc[gone.idx()].front()]) {
      Soup trial = s;
      substitute(trial, keep.idx(), gone.idx());
      try {
        check_manifold(trial, what);
      } catch (const TopologyError&) {
        flip_piece(s, inc[gone.idx()].front());
      }
    }
  }
  substitute(s, keep.idx(), gone.idx());
  check_manifold(s, what);
  commit(g, s, what);
  return keep;
}

namespace {

// The two sides of a seam as stitch() pairs them, in `s` (g's soup): b's piece turned to face the
// way a's does where they are separate pieces, and (`refine_sides`) each side refined by arc length
// where the other has a vertex, so that a[i] pairs with b[i]; else they are paired as given.
void match_seam(Garment& g, Soup& s, const std::vector<Vertex>& a_in, const std::vector<Vertex>& b_in,
                std::vector<Index>& a, std::vector<Index>& b, bool refine_sides = true) {
  const Mesh& m = g.mesh();
  if (a_in.size() < 2 || b_in.size() < 2)
    throw InputError("stitch: each side of a seam needs at least 2 vertices (one border edge)");
  for (const auto* side : {&a_in, &b_in})
    for (std::size_t i = 0; i < side->size(); ++i) {
      require_vertex(g, (*side)[i], "seam");
      if (i + 1 < side->size() &&
          border_halfedge_between(m, (*side)[i], (*side)[i + 1]) == Mesh::null_halfedge())
        throw InputError("stitch: vertices " + std::to_string((*side)[i].idx()) + " and " +
                         std::to_string((*side)[i + 1].idx()) + " are not joined by a border edge");
    }
  {
    std::set<Vertex> in_a(a_in.begin(), a_in.end());
    for (std::size_t j = 0; j < b_in.size(); ++j)
      if (in_a.count(b_in[j]) && !((j == 0 && b_in[0] == a_in.front()) ||
                                   (j + 1 == b_in.size() && b_in.back() == a_in.back())))
        throw InputError("stitch: the two sides of a seam may share only their matching end points");
  }

  a.resize(a_in.size());
  b.resize(b_in.size());
  for (std::size_t i = 0; i < a.size(); ++i) a[i] = a_in[i].idx();
  for (std::size_t i = 0; i < b.size(); ++i) b[i] = b_in[i].idx();

  // The seam closes when side a's faces run a[i] -> a[i+1] and side b's run b[i+1] -> b[i] (or the
  // reverse). If both run the same way on separate pieces, flip b's piece.
  auto runs_forward = [&](const std::vector<Index>& p) { return face_with_directed_edge(s, p[0], p[1]) >= 0; };
  if (runs_forward(a) == runs_forward(b)) {
    const int fa = face_with_directed_edge(s, a[0], a[1]) >= 0 ? face_with_directed_edge(s, a[0], a[1])
                                                                : face_with_directed_edge(s, a[1], a[0]);
    const int fb = face_with_directed_edge(s, b[0], b[1]) >= 0 ? face_with_directed_edge(s, b[0], b[1])
                                                                : face_with_directed_edge(s, b[1], b[0]);
    if (piece_of(s, Index(fa))[Index(fb)])
      throw TopologyError("stitch: the seam would join a piece to itself with a twist (a Moebius "
                          "strip); reverse one side of the seam");
    flip_piece(s, Index(fb));
  }

  if (!refine_sides) {
    if (a.size() != b.size()) throw TopologyError("stitch: the two sides are not paired vertex for vertex");
    return;
  }
  // Arc-length parameters of each side, then refine both to the union of their parameters.
  auto params_of = [&](const std::vector<Index>& p) {
    std::vector<double> t(p.size(), 0.0);
    for (std::size_t i = 1; i < p.size(); ++i) {
      auto it = s.edges.find(edge_key(p[i - 1], p[i]));
      t[i] = t[i - 1] + it->second.rest;
    }
    for (double& x : t) x /= t.back();
    return t;
  };
  const std::vector<double> ta = params_of(a), tb = params_of(b);
  // Inserts, on the border edge (p[i], p[i+1]) of a side, vertices at the given parameters.
  auto refine = [&](std::vector<Index>& p, const std::vector<double>& tp, const std::vector<double>& other) {
    double min_gap = 1.0;
    for (std::size_t i = 1; i < tp.size(); ++i) min_gap = std::min(min_gap, tp[i] - tp[i - 1]);
    for (std::size_t i = 1; i < other.size(); ++i) min_gap = std::min(min_gap, other[i] - other[i - 1]);
    const double tol = 0.25 * min_gap;
    std::vector<Index> out{p[0]};
    for (std::size_t i = 0; i + 1 < p.size(); ++i) {
      std::vector<double> inserts;
      for (double t : other)
        if (t > tp[i] + tol && t < tp[i + 1] - tol) inserts.push_back(t);
      if (!inserts.empty()) {
        int f = face_with_directed_edge(s, p[i], p[i + 1]);
        const bool forward = f >= 0;
        if (!forward) f = face_with_directed_edge(s, p[i + 1], p[i]);
        // The face (u, w, c) with u -> w along the border edge.
        const auto face = s.faces[f];
        const auto uvf = s.uvs[f];
        int ku = 0;
        const Index u = forward ? p[i] : p[i + 1];
        while (face[ku] != u) ++ku;
        const Index w = face[(ku + 1) % 3], c = face[(ku + 2) % 3];
        const Vec2 uv_u = uvf[ku], uv_w = uvf[(ku + 1) % 3], uv_c = uvf[(ku + 2) % 3];
        // Lay the triangle flat at its rest lengths to give exact rest lengths to new edges.
        const double l_uw = s.edges[edge_key(u, w)].rest, l_uc = s.edges[edge_key(u, c)].rest,
                     l_wc = s.edges[edge_key(w, c)].rest;
        const double cx = (l_uc * l_uc - l_wc * l_wc + l_uw * l_uw) / (2 * l_uw);
        const double cy = std::sqrt(std::max(0.0, l_uc * l_uc - cx * cx));
        const EdgeData base = s.edges[edge_key(u, w)];
        std::vector<double> fr;  // fractions from u to w
        for (double t : inserts) {
          const double along = (t - tp[i]) / (tp[i + 1] - tp[i]);
          fr.push_back(forward ? along : 1.0 - along);
        }
        std::sort(fr.begin(), fr.end());
        std::vector<Index> chain{u};
        std::vector<double> chain_fr{0.0};
        for (double x : fr) {
          VertexData d;
          d.alive = true;
          d.position = (1 - x) * s.vertices[u].position + x * s.vertices[w].position;
          d.velocity = (1 - x) * s.vertices[u].velocity + x * s.vertices[w].velocity;
          d.inverse_mass = 1.0;
          chain.push_back(s.add_vertex(d));
          chain_fr.push_back(x);
        }
        chain.push_back(w);
        chain_fr.push_back(1.0);
        const int panel = s.panels[f];
        std::vector<char> drop(s.faces.size(), 0);
        drop[f] = 1;
        s.erase_faces(drop);
        s.edges.erase(edge_key(u, w));
        for (std::size_t k = 0; k + 1 < chain.size(); ++k) {
          const double x0 = chain_fr[k], x1 = chain_fr[k + 1];
          s.add_face({chain[k], chain[k + 1], c},
                     {Vec2((1 - x0) * uv_u + x0 * uv_w), Vec2((1 - x1) * uv_u + x1 * uv_w), uv_c}, panel);
          s.edges[edge_key(chain[k], chain[k + 1])] = {base.rest * (x1 - x0), base.threshold * (x1 - x0)};
        }
        for (std::size_t k = 1; k + 1 < chain.size(); ++k) {
          const double x = chain_fr[k];
          const double r = std::hypot(cx - x * l_uw, cy);
          s.edges[edge_key(chain[k], c)] = {r, g.material().tear_ratio * r};
        }
        if (forward) {
          for (std::size_t k = 1; k + 1 < chain.size(); ++k) out.push_back(chain[k]);
        } else {
          for (std::size_t k = chain.size() - 2; k >= 1; --k) out.push_back(chain[k]);
        }
      }
      out.push_back(p[i + 1]);
    }
    p = out;
  };
  refine(a, ta, tb);
  refine(b, tb, ta);
  if (a.size() != b.size())
    throw TopologyError("stitch: the two sides could not be matched vertex for vertex");
}

// Sews a seam: the sides matched (match_seam), then b[i] merged into a[i].
void sew_seam(Garment& g, const std::vector<Vertex>& a_in, const std::vector<Vertex>& b_in, bool refine_sides) {
  Soup s = to_soup(g);
  std::vector<Index> a, b;
  match_seam(g, s, a_in, b_in, a, b, refine_sides);
  // Pin state of the new seam vertices is unpinned; merge pairs: b[i] into a[i].
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i] != b[i]) substitute(s, a[i], b[i]);
  check_manifold(s, "stitch");
  commit(g, s, "stitch");
}

}  // namespace

void stitch(Garment& g, const std::vector<Vertex>& a, const std::vector<Vertex>& b) { sew_seam(g, a, b, true); }

std::vector<std::pair<Vertex, Vertex>> tack_seam(Garment& g, const std::vector<Vertex>& a_in,
                                                 const std::vector<Vertex>& b_in) {
  Soup s = to_soup(g);
  std::vector<Index> a, b;
  match_seam(g, s, a_in, b_in, a, b);
  commit(g, s, "tack_seam");
  std::vector<std::pair<Vertex, Vertex>> pairs;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i] != b[i]) pairs.emplace_back(Vertex(a[i]), Vertex(b[i]));
  g.tacks.insert(g.tacks.end(), pairs.begin(), pairs.end());
  return pairs;
}

bool tack_met(const Garment& g, Vertex a, Vertex b, double within) {
  const double gap = (g.position(a) - g.position(b)).norm();
  if (gap <= within) return true;
  if (!(gap <= 2 * within)) return false;
  const Mesh& m = g.mesh();
  Vertex end = Mesh::null_vertex();
  for (Halfedge h : CGAL::halfedges_around_target(m.halfedge(a), m)) {
    const Vertex x = m.source(h);
    if (x == b || !m.is_border(m.edge(h))) continue;
    const auto [k, found] = CGAL::halfedge(b, x, m);
    if (found && m.is_border(m.edge(k))) end = x;
  }
  if (end == Mesh::null_vertex()) return false;
  // The seam's last pair: beyond it, on either border, no vertex is tacked.
  std::set<Vertex> tacked;
  for (const auto& [p, q] : g.tacks)
    if (!((p == a && q == b) || (p == b && q == a))) tacked.insert({p, q});
  for (Vertex v : {a, b})
    for (Halfedge h : CGAL::halfedges_around_target(m.halfedge(v), m)) {
      const Vertex y = m.source(h);
      if (y != end && y != a && y != b && m.is_border(m.edge(h)) && tacked.count(y)) return false;
    }
  return true;
}

std::size_t close_tacks(Garment& g, double within) {
  std::size_t sewn = 0;
  std::set<std::pair<Vertex, Vertex>> refused;
  for (bool again = true; again;) {
    again = false;
    const Mesh& m = g.mesh();
    auto border_neighbours = [&](Vertex p, Vertex q) {
      const auto [h, found] = CGAL::halfedge(p, q, m);
      return found && m.is_border(m.edge(h));
    };
    std::vector<std::pair<Vertex, Vertex>> met;
    for (const auto& t : g.tacks)
      if (!refused.count(t) && tack_met(g, t.first, t.second, within)) met.push_back(t);
    std::vector<char> used(met.size(), 0);
    // A met tack next to `t` along both borders (oriented as t), not yet in a run.
    auto next_of = [&](const std::pair<Vertex, Vertex>& t) -> std::optional<std::pair<Vertex, Vertex>> {
      for (std::size_t j = 0; j < met.size(); ++j) {
        if (used[j]) continue;
        for (int swap = 0; swap < 2; ++swap) {
          const Vertex p = swap ? met[j].second : met[j].first, q = swap ? met[j].first : met[j].second;
          if (border_neighbours(t.first, p) && border_neighbours(t.second, q)) {
            used[j] = 1;
            return std::make_pair(p, q);
          }
        }
      }
      return std::nullopt;
    };
    for (std::size_t i = 0; i < met.size() && !again; ++i) {
      if (used[i]) continue;
      used[i] = 1;
      std::deque<std::pair<Vertex, Vertex>> run{met[i]};
      for (auto n = next_of(run.back()); n; n = next_of(run.back())) run.push_back(*n);
      for (auto n = next_of(run.front()); n; n = next_of(run.front())) run.push_front(*n);
      // A run next to where the seam is already sewn (or began at a shared corner) closes from
      // there: the vertex both its borders lead to is the seam's end, on both sides.
      auto shared_neighbour = [&](const std::pair<Vertex, Vertex>& t, const std::pair<Vertex, Vertex>& inward) {
        for (Halfedge h : CGAL::halfedges_around_target(m.halfedge(t.first), m)) {
          const Vertex x = m.source(h);
          if (x != inward.first && x != inward.second && m.is_border(m.edge(h)) && border_neighbours(t.second, x)) return x;
        }
        return Mesh::null_vertex();
      };
      const auto none = std::make_pair(Mesh::null_vertex(), Mesh::null_vertex());
      if (const Vertex x = shared_neighbour(run.front(), run.size() > 1 ? run[1] : none); x != Mesh::null_vertex())
        run.emplace_front(x, x);
      if (const Vertex x = shared_neighbour(run.back(), run.size() > 1 ? run[run.size() - 2] : none); x != Mesh::null_vertex())
        run.emplace_back(x, x);
      if (run.size() < 2) {
        // A pair alone would pinch the cloth, and waits for a neighbour; unless the two are next to
        // each other on the border (a seam's last pair at a corner): that gap closes.
        const auto [p, q] = run.front();
        if (!border_neighbours(p, q)) continue;
        try {
          merge_vertices(g, p, q);
          ++sewn;
          again = true;
        } catch (const Error&) {
          refused.emplace(p, q);
          refused.emplace(q, p);
        }
        continue;
      }
      std::vector<Vertex> a, b;
      for (const auto& [p, q] : run) a.push_back(p), b.push_back(q);
      try {
        sew_seam(g, a, b, /*refine_sides=*/false);  // paired as tacked
        for (const auto& [p, q] : run) sewn += p != q;
        again = true;  // the mesh changed: look again from the start
      } catch (const Error&) {
        for (const auto& [p, q] : run) {  // they stay tacked, held together by the solver
          refused.emplace(p, q);
          refused.emplace(q, p);
        }
      }
    }
  }
  return sewn;
}

Vertex append_garment(Garment& g, const Garment& other) {
  Soup s = to_soup(g);
  const Soup o = to_soup(other);
  const Index first = static_cast<Index>(s.vertices.size());
  s.vertices.insert(s.vertices.end(), o.vertices.begin(), o.vertices.end());
  for (std::size_t f = 0; f < o.faces.size(); ++f)
    s.add_face({o.faces[f][0] + first, o.faces[f][1] + first, o.faces[f][2] + first}, o.uvs[f], o.panels[f]);
  for (const auto& [key, data] : o.edges)
    s.edges.emplace(edge_key(Index(key >> 32) + first, Index(key & 0xffffffffu) + first), data);
  for (const auto& [a, b] : o.tacks) s.tacks.emplace_back(a + first, b + first);
  // Pinned vertices of `other` stay pinned; its masses follow g's material from here on.
  commit(g, s, "append_garment");
  return Vertex(first);
}

std::vector<std::vector<Vertex>> border_loops(const Garment& g) {
  const Mesh& m = g.mesh();
  std::vector<std::vector<Vertex>> loops;
  std::vector<char> seen(m.number_of_halfedges() + m.number_of_removed_halfedges(), 0);
  for (Halfedge h : m.halfedges()) {
    if (!m.is_border(h) || seen[h.idx()]) continue;
    std::vector<Vertex> loop;
    Halfedge c = h;
    do {
      seen[c.idx()] = 1;
      loop.push_back(m.source(c));
      c = m.next(c);
    } while (c != h && !seen[c.idx()]);
    loops.push_back(std::move(loop));
  }
  return loops;
}

std::vector<Vertex> border_path(const Garment& g, Vertex from, Vertex to) {
  require_vertex(g, from, "path start");
  require_vertex(g, to, "path end");
  const Mesh& m = g.mesh();
  std::vector<Vertex> best;
  for (Halfedge h : CGAL::halfedges_around_source(from, m)) {
    if (!m.is_border(h)) continue;
    // Forward along the loop, and backward; the shorter way wins.
    for (int backward = 0; backward < 2; ++backward) {
      std::vector<Vertex> path{from};
      Halfedge c = backward ? m.prev(h) : h;
      for (std::size_t guard = 0; guard < m.number_of_halfedges(); ++guard) {
        const Vertex next = backward ? m.source(c) : m.target(c);
        path.push_back(next);
        if (next == to) break;
        c = backward ? m.prev(c) : m.next(c);
        if (next == from) break;
      }
      if (path.back() == to && (best.empty() || path.size() < best.size())) best = path;
    }
  }
  if (best.empty() || from == to)
    throw InputError("border_path: vertices " + std::to_string(from.idx()) + " and " + std::to_string(to.idx()) +
                     " are not two vertices of one border loop");
  return best;
}

}  // namespace kiji
