// The garment's per-edge and per-face arrays, and the topology edits of kiji/topology.h, on rows of
// the garment's arrays. On a session's garment each edit is one set_garment operation (a tool
// written in Python edits in place during its stroke, as a C++ tool does).
#include "bindings.h"

#include "kiji/operation.h"
#include "kiji/topology.h"

#include <cmath>

namespace kiji::python {

namespace {

using Ref = GarmentRef;
using RefPtr = std::shared_ptr<GarmentRef>;

std::vector<Edge> edge_list(const Mesh& m) { return {m.edges().begin(), m.edges().end()}; }
std::vector<Face> face_list(const Mesh& m) { return {m.faces().begin(), m.faces().end()}; }

py::array_t<long long> int_vector(py::handle obj, const char* what) {
  py::array a = py::module_::import("numpy").attr("asarray")(obj);
  if (a.dtype().kind() != 'i' && a.dtype().kind() != 'u')
    throw py::type_error(std::string(what) + " must be an int or an array of ints");
  return py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(a);
}

Vertex vertex_at(const VertexRows& rows, long long row, const char* what) {
  if (row < 0 || row >= static_cast<long long>(rows.vertices.size()))
    throw InputError(std::string(what) + ": vertex row " + std::to_string(row) + " does not exist (the garment has " +
                     std::to_string(rows.vertices.size()) + " vertices)");
  return rows.vertices[row];
}

std::vector<Vertex> vertices_at(const Garment& g, py::handle obj, const char* what) {
  const VertexRows rows(g);
  auto a = int_vector(obj, what);
  if (a.ndim() != 1) throw InputError(std::string(what) + " must be a 1-D array of vertex rows");
  std::vector<Vertex> out;
  for (py::ssize_t i = 0; i < a.size(); ++i) out.push_back(vertex_at(rows, a.data()[i], what));
  return out;
}

py::array_t<std::int64_t> rows_of(const Garment& g, const std::vector<Vertex>& vs) {
  const VertexRows rows(g);
  py::array_t<std::int64_t> a(static_cast<py::ssize_t>(vs.size()));
  for (std::size_t i = 0; i < vs.size(); ++i) a.mutable_data()[i] = rows.row[vs[i].idx()];
  return a;
}

// Edges from (K,) rows of garment.edges or (K, 2) pairs of vertex rows.
std::vector<Edge> edges_at(const Garment& g, py::handle obj, const char* what) {
  const Mesh& m = g.mesh();
  auto a = int_vector(obj, what);
  std::vector<Edge> out;
  if (a.ndim() == 1 || a.ndim() == 0) {
    const auto edges = edge_list(m);
    for (py::ssize_t i = 0; i < a.size(); ++i) {
      const long long e = a.data()[i];
      if (e < 0 || e >= static_cast<long long>(edges.size()))
        throw InputError(std::string(what) + ": edge row " + std::to_string(e) + " does not exist (the garment has " +
                         std::to_string(edges.size()) + " edges)");
      out.push_back(edges[e]);
    }
    return out;
  }
  if (a.ndim() != 2 || a.shape(1) != 2)
    throw InputError(std::string(what) + " must be edge rows (K,) or pairs of vertex rows (K, 2)");
  const VertexRows rows(g);
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    const Vertex u = vertex_at(rows, a.at(i, 0), what), v = vertex_at(rows, a.at(i, 1), what);
    const Halfedge h = m.halfedge(u, v);
    if (h == Mesh::null_halfedge())
      throw InputError(std::string(what) + ": vertices " + std::to_string(a.at(i, 0)) + " and " +
                       std::to_string(a.at(i, 1)) + " are not joined by an edge");
    out.push_back(m.edge(h));
  }
  return out;
}

py::array_t<double> per_edge(const Garment& g, const std::function<double(Edge)>& f) {
  const auto edges = edge_list(g.mesh());
  py::array_t<double> a(static_cast<py::ssize_t>(edges.size()));
  for (std::size_t i = 0; i < edges.size(); ++i) a.mutable_data()[i] = f(edges[i]);
  return a;
}

void set_per_edge(Ref& r, py::handle value, const char* what, void (Garment::*set)(Edge, double)) {
  r.edit([&](Garment& g) {
    const auto edges = edge_list(g.mesh());
    auto a = real_array(value, what, static_cast<long>(edges.size()), 0);
    for (std::size_t i = 0; i < edges.size(); ++i)
      if (!(a.data()[i] > 0))
        throw InputError(std::string(what) + "[" + std::to_string(i) + "] is " + std::to_string(a.data()[i]) +
                         ": every value must be a positive length in metres");
    for (std::size_t i = 0; i < edges.size(); ++i) (g.*set)(edges[i], a.data()[i]);
  });
}

RefPtr check(const RefPtr& g) {
  if (!g) throw py::type_error("expected a kiji.Garment");
  return g;
}

}  // namespace

void bind_topology(py::module_& m) {
  auto c = py::reinterpret_borrow<py::class_<Ref, std::shared_ptr<Ref>>>(m.attr("Garment"));
  c.def_property_readonly("edges", [](const Ref& r) {
    auto lock = r.guard();
    const Garment& g = r.get();
    const Mesh& mm = g.mesh();
    const VertexRows rows(g);
    const auto edges = edge_list(mm);
    py::array_t<std::int64_t> a({static_cast<py::ssize_t>(edges.size()), py::ssize_t(2)});
    for (std::size_t i = 0; i < edges.size(); ++i) {
      const Halfedge h = mm.halfedge(edges[i]);
      a.mutable_at(i, 0) = rows.row[mm.source(h).idx()];
      a.mutable_at(i, 1) = rows.row[mm.target(h).idx()];
    }
    return a;
  }, "(E, 2) int64: the two vertex rows of each edge. The per-edge arrays (rest_lengths, tear_thresholds,\n"
     "edge_lengths, strains) follow this order, which a topology edit changes.");
  c.def_property(
      "rest_lengths", [](const Ref& r) {
        auto lock = r.guard();
        const Garment& g = r.get();
        return per_edge(g, [&](Edge e) { return g.rest_length(e); });
      },
      [](Ref& r, py::handle v) { set_per_edge(r, v, "rest_lengths", &Garment::set_rest_length); },
      "(E,) float64: each edge's rest length, metres (l_ij of the paper's eq. 3). Assign positive lengths.");
  c.def_property(
      "tear_thresholds", [](const Ref& r) {
        auto lock = r.guard();
        const Garment& g = r.get();
        return per_edge(g, [&](Edge e) { return g.tear_threshold(e); });
      },
      [](Ref& r, py::handle v) { set_per_edge(r, v, "tear_thresholds", &Garment::set_tear_threshold); },
      "(E,) float64: the length above which each edge tears, metres (the material's tear_ratio times the\n"
      "rest length unless set).");
  c.def_property_readonly("edge_lengths", [](const Ref& r) {
    auto lock = r.guard();
    const Garment& g = r.get();
    return per_edge(g, [&](Edge e) { return g.length(e); });
  }, "(E,) float64: each edge's current length, metres (l'_ij of the paper's eq. 3).");
  c.def_property_readonly("strains", [](const Ref& r) {
    auto lock = r.guard();
    const Garment& g = r.get();
    return per_edge(g, [&](Edge e) { return g.strain(e); });
  }, "(E,) float64: length / rest length - 1 of each edge.");
  c.def_property_readonly("inverse_masses", [](const Ref& r) {
    auto lock = r.guard();
    const Garment& g = r.get();
    const VertexRows rows(g);
    py::array_t<double> a(static_cast<py::ssize_t>(rows.vertices.size()));
    for (std::size_t i = 0; i < rows.vertices.size(); ++i) a.mutable_data()[i] = g.inverse_mass(rows.vertices[i]);
    return a;
  }, "(V,) float64: 1 / mass of each vertex, kg^-1 (0 = pinned).");
  c.def_property_readonly("masses", [](const Ref& r) {
    auto lock = r.guard();
    const Garment& g = r.get();
    const VertexRows rows(g);
    py::array_t<double> a(static_cast<py::ssize_t>(rows.vertices.size()));
    for (std::size_t i = 0; i < rows.vertices.size(); ++i) a.mutable_data()[i] = g.mass(rows.vertices[i]);
    return a;
  }, "(V,) float64: lumped mass of each vertex, kg (a third of each incident face's rest area times the\n"
     "density; the mass-spring model uses unit masses instead, as the paper does).");
  c.def("recompute_masses", [](Ref& r) { r.edit([](Garment& g) { g.recompute_masses(); }); },
        "Recomputes every unpinned vertex's mass from the rest areas and the material's density.");
  c.def_property(
      "panels",
      [](const Ref& r) {
        auto lock = r.guard();
        const Garment& g = r.get();
        const auto faces = face_list(g.mesh());
        py::array_t<std::int64_t> a(static_cast<py::ssize_t>(faces.size()));
        for (std::size_t i = 0; i < faces.size(); ++i) a.mutable_data()[i] = g.panel(faces[i]);
        return a;
      },
      [](Ref& r, py::handle value) {
        r.edit([&](Garment& g) {
          const auto faces = face_list(g.mesh());
          auto a = int_vector(value, "panels");
          if (a.ndim() != 1 || a.shape(0) != static_cast<py::ssize_t>(faces.size()))
            throw InputError("panels must have shape (" + std::to_string(faces.size()) + ",)");
          for (std::size_t i = 0; i < faces.size(); ++i) {
            const long long p = a.data()[i];
            if (p < 0 || p > 1'000'000) throw InputError("panels: a panel id must be 0 to 1000000");
            g.set_panel(faces[i], static_cast<int>(p));
          }
        });
      },
      "(F,) int64: the pattern panel each face was cut from.");
  c.def_property_readonly("rest_areas", [](const Ref& r) {
    auto lock = r.guard();
    const Garment& g = r.get();
    const auto faces = face_list(g.mesh());
    py::array_t<double> a(static_cast<py::ssize_t>(faces.size()));
    for (std::size_t i = 0; i < faces.size(); ++i) a.mutable_data()[i] = g.rest_area(faces[i]);
    return a;
  }, "(F,) float64: each face's rest area from its rest edge lengths, m^2.");
  c.def_property_readonly("vertex_capacity", [](const Ref& r) {
    auto lock = r.guard();
    return r.get().vertex_capacity();
  }, "One past the largest vertex id in use (removed vertices included).");
  c.def("compact", [](Ref& r) { r.edit([](Garment& g) { g.compact(); }); },
        "Removes the holes removed vertices left, so that vertex ids equal rows again (ids change).");
  c.def("to_bytes", [](const Ref& r) {
    auto lock = r.guard();
    return py::bytes(encode_garment(r.get()));
  }, "The garment's whole state in Kiji's binary form (what operations and session files carry).");
  c.def_static("from_bytes", [](const py::bytes& b) {
    const std::string bytes = b;
    return std::make_shared<Ref>(decode_garment(bytes));
  }, py::arg("data"), "A garment from its binary form (Garment.to_bytes); InputError for malformed bytes.");
  c.def("rows", [](const Ref& r, py::handle ids) {
    auto lock = r.guard();
    const VertexRows rows(r.get());
    auto a = int_vector(ids, "ids");
    py::array_t<std::int64_t> out(a.size());
    for (py::ssize_t i = 0; i < a.size(); ++i) {
      const long long id = a.data()[i];
      if (id < 0 || id >= static_cast<long long>(rows.row.size()) || rows.row[id] < 0)
        throw InputError("rows: vertex id " + std::to_string(id) + " is not a vertex of this garment");
      out.mutable_data()[i] = rows.row[id];
    }
    return out;
  }, py::arg("ids"), "The rows of vertex ids (SurfaceHit.vertex_id, vertex_ids): ids stay across edits, rows\n"
     "are the positions in the arrays.");

  // --- the edits ---
  m.def("non_manifold_vertices", [](const RefPtr& g) {
    auto lock = check(g)->guard();
    return rows_of(g->get(), non_manifold_vertices(g->get().mesh()));
  }, py::arg("garment"), "Rows of the vertices whose faces do not form one fan (none in a valid garment).");
  m.def("split_vertex", [](const RefPtr& g, long long vertex, py::handle faces) {
    py::array_t<std::int64_t> out;
    check(g)->edit([&](Garment& gm) {
      const Vertex v = vertex_at(VertexRows(gm), vertex, "split_vertex");
      const auto all = face_list(gm.mesh());
      auto f = int_vector(faces, "faces");
      std::vector<Face> moved;
      for (py::ssize_t i = 0; i < f.size(); ++i) {
        const long long x = f.data()[i];
        if (x < 0 || x >= static_cast<long long>(all.size()))
          throw InputError("split_vertex: face row " + std::to_string(x) + " does not exist");
        moved.push_back(all[x]);
      }
      const Vertex nv = split_vertex(gm, v, moved);
      out = rows_of(gm, {nv});
    });
    return out.at(0);
  }, py::arg("garment"), py::arg("vertex"), py::arg("faces"),
     "Splits a vertex in two: the faces given (rows of garment.faces, each around the vertex) go to a new\n"
     "vertex at the same place; the cloth opens between moved and kept faces. Returns the new vertex's row.");
  m.def("split_vertex_between", [](const RefPtr& g, long long vertex, long long a, long long b) {
    py::array_t<std::int64_t> out;
    check(g)->edit([&](Garment& gm) {
      const VertexRows rows(gm);
      const Vertex nv = split_vertex_between(gm, vertex_at(rows, vertex, "split_vertex_between"),
                                             vertex_at(rows, a, "split_vertex_between"),
                                             vertex_at(rows, b, "split_vertex_between"));
      out = rows_of(gm, {nv});
    });
    return out.at(0);
  }, py::arg("garment"), py::arg("vertex"), py::arg("a"), py::arg("b"),
     "Splits a vertex along its edges to a and b: the faces met turning counter-clockwise from (vertex, a)\n"
     "to (vertex, b) go to the new vertex (on a border vertex a may equal b). Returns its row.");
  m.def("cut_along", [](const RefPtr& g, py::handle path) {
    py::array_t<std::int64_t> out;
    check(g)->edit([&](Garment& gm) { out = rows_of(gm, cut_along(gm, vertices_at(gm, path, "cut_along"))); });
    return out;
  }, py::arg("garment"), py::arg("path"),
     "Cuts the cloth along a path of vertex rows joined by edges (a knife stroke; see edge_path): no face is\n"
     "lost, a path from border to border separates the pieces. Returns the rows of the vertices made.");
  m.def("edge_path", [](const RefPtr& g, long long from, long long to) {
    auto lock = check(g)->guard();
    const Garment& gm = g->get();
    const VertexRows rows(gm);
    return rows_of(gm, edge_path(gm, vertex_at(rows, from, "edge_path"), vertex_at(rows, to, "edge_path")));
  }, py::arg("garment"), py::arg("start"), py::arg("end"),
     "The shortest path of edges between two vertex rows, as rows; InputError if they are not connected.");
  m.def("remove_edge", [](const RefPtr& g, py::handle edge) {
    check(g)->edit([&](Garment& gm) {
      const auto es = edges_at(gm, edge, "remove_edge");
      if (es.size() != 1) throw InputError("remove_edge: give one edge (a row, or a pair of vertex rows)");
      remove_edge(gm, es[0]);
    });
  }, py::arg("garment"), py::arg("edge"),
     "Removes an edge (a row of garment.edges, or a pair of vertex rows) with its faces: the paper's tear.");
  m.def("remove_edges", [](const RefPtr& g, py::handle edges) {
    check(g)->edit([&](Garment& gm) { remove_edges(gm, edges_at(gm, edges, "remove_edges")); });
  }, py::arg("garment"), py::arg("edges"),
     "Removes edges ((K,) rows of garment.edges, or (K, 2) pairs of vertex rows) and their faces at once.");
  m.def("merge_vertices", [](const RefPtr& g, long long keep, long long gone) {
    py::array_t<std::int64_t> out;
    check(g)->edit([&](Garment& gm) {
      const VertexRows rows(gm);
      const Vertex v = merge_vertices(gm, vertex_at(rows, keep, "merge_vertices"), vertex_at(rows, gone, "merge_vertices"));
      out = rows_of(gm, {v});
    });
    return out.at(0);
  }, py::arg("garment"), py::arg("keep"), py::arg("gone"),
     "Merges vertex `gone` into `keep` (the paper's sew), which moves to the midpoint; returns its row\n"
     "afterwards. TopologyError when the result would not be manifold.");
  m.def("stitch", [](const RefPtr& g, py::handle a, py::handle b) {
    check(g)->edit([&](Garment& gm) { stitch(gm, vertices_at(gm, a, "stitch"), vertices_at(gm, b, "stitch")); });
  }, py::arg("garment"), py::arg("a"), py::arg("b"),
     "Sews two border polylines (vertex rows) into a seam, a[0] to b[0] ... last to last; no border is\n"
     "left along it.");
  m.def("tack_seam", [](const RefPtr& g, py::handle a, py::handle b) {
    py::array_t<std::int64_t> out;
    check(g)->edit([&](Garment& gm) {
      const auto pairs = tack_seam(gm, vertices_at(gm, a, "tack_seam"), vertices_at(gm, b, "tack_seam"));
      const VertexRows rows(gm);
      out = py::array_t<std::int64_t>({static_cast<py::ssize_t>(pairs.size()), py::ssize_t(2)});
      for (std::size_t i = 0; i < pairs.size(); ++i) {
        out.mutable_data()[2 * i] = rows.row[pairs[i].first.idx()];
        out.mutable_data()[2 * i + 1] = rows.row[pairs[i].second.idx()];
      }
    });
    return out;
  }, py::arg("garment"), py::arg("a"), py::arg("b"),
     "A seam sewn as it closes: the two border polylines (vertex rows) paired as stitch pairs them, and\n"
     "each pair tacked (garment.tacks): a session's simulation draws them together and sews the pairs\n"
     "as they meet. Returns the (N, 2) rows tacked.");
  m.def("close_tacks", [](const RefPtr& g, double within) {
    std::size_t sewn = 0;
    check(g)->edit([&](Garment& gm) { sewn = close_tacks(gm, within); });
    return sewn;
  }, py::arg("garment"), py::arg("within"),
     "Sews every run of two or more tacks whose vertices are within `within` m of each other along both\n"
     "borders (a seam's last pair, next to its sewn end, within twice that; a session does this after\n"
     "each step); returns the number of pairs sewn.");
  m.def("tack_met", [](const RefPtr& g, long long a, long long b, double within) {
    auto lock = check(g)->guard();
    const Garment& gm = g->get();
    const VertexRows rows(gm);
    return tack_met(gm, vertex_at(rows, a, "tack_met"), vertex_at(rows, b, "tack_met"), within);
  }, py::arg("garment"), py::arg("a"), py::arg("b"), py::arg("within"),
     "Whether the tacked pair of vertex rows (a, b) counts as met for close_tacks: within `within` m, or\n"
     "within twice that for a seam's last pair, next to its sewn end.");
  m.def("append_garment", [](const RefPtr& g, const RefPtr& other) {
    check(other);
    Garment copy;
    {
      auto lock = other->guard();
      copy = other->get();
    }
    py::array_t<std::int64_t> out;
    check(g)->edit([&](Garment& gm) { out = rows_of(gm, {append_garment(gm, copy)}); });
    return out.at(0);
  }, py::arg("garment"), py::arg("other"),
     "Adds every vertex and face of `other` to the garment as separate pieces (the panels of one garment);\n"
     "returns the row its vertex 0 now has.");
  m.def("border_loops", [](const RefPtr& g) {
    auto lock = check(g)->guard();
    py::list out;
    for (const auto& loop : border_loops(g->get())) out.append(rows_of(g->get(), loop));
    return out;
  }, py::arg("garment"), "The border loops, each an array of vertex rows in order.");
  m.def("border_path", [](const RefPtr& g, long long from, long long to) {
    auto lock = check(g)->guard();
    const Garment& gm = g->get();
    const VertexRows rows(gm);
    return rows_of(gm, border_path(gm, vertex_at(rows, from, "border_path"), vertex_at(rows, to, "border_path")));
  }, py::arg("garment"), py::arg("start"), py::arg("end"),
     "The border vertices (rows) from start to end, walking forward along the border.");
}

}  // namespace kiji::python
