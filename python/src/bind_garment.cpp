// Garments as NumPy arrays, the pattern makers, file I/O and pictures.
#include "bindings.h"

#include "kiji/drape.h"
#include "kiji/io.h"
#include "kiji/pattern.h"
#include "kiji/render.h"
#include "kiji/topology.h"

#include <algorithm>
#include <numeric>

namespace kiji::python {

namespace {

using Ref = GarmentRef;

py::array_t<double> per_vertex(const Garment& g, const std::function<Vec3(Vertex)>& f) {
  const VertexRows rows(g);
  py::array_t<double> a({static_cast<py::ssize_t>(rows.vertices.size()), py::ssize_t(3)});
  auto r = a.mutable_unchecked<2>();
  for (std::size_t i = 0; i < rows.vertices.size(); ++i) {
    const Vec3 v = f(rows.vertices[i]);
    for (int k = 0; k < 3; ++k) r(i, k) = v[k];
  }
  return a;
}

std::array<Halfedge, 3> corners(const Mesh& m, Face f) {
  const Halfedge h0 = m.halfedge(f), h1 = m.next(h0), h2 = m.next(h1);
  return {h0, h1, h2};
}

py::array_t<std::int64_t> faces_array(const Garment& g) {
  const VertexRows rows(g);
  const Mesh& m = g.mesh();
  py::array_t<std::int64_t> a({static_cast<py::ssize_t>(m.number_of_faces()), py::ssize_t(3)});
  auto r = a.mutable_unchecked<2>();
  std::size_t i = 0;
  for (Face f : m.faces()) {
    const auto c = corners(m, f);
    for (int k = 0; k < 3; ++k) r(i, k) = rows.row[m.target(c[k]).idx()];
    ++i;
  }
  return a;
}

// Piece label of every face (connected through shared edges), 0..pieces-1 in face order.
std::vector<int> face_pieces(const Garment& g) {
  const Mesh& m = g.mesh();
  std::vector<int> label(m.number_of_faces() + m.number_of_removed_faces(), -1);
  int next = 0;
  for (Face f : m.faces()) {
    if (label[f.idx()] >= 0) continue;
    std::vector<Face> stack{f};
    label[f.idx()] = next;
    while (!stack.empty()) {
      Face c = stack.back();
      stack.pop_back();
      for (Halfedge h : CGAL::halfedges_around_face(m.halfedge(c), m)) {
        const Face o = m.face(m.opposite(h));
        if (o != Mesh::null_face() && label[o.idx()] < 0) label[o.idx()] = next, stack.push_back(o);
      }
    }
    ++next;
  }
  return label;
}

Garment garment_from_arrays(py::handle positions, py::handle faces, const Material& material,
                            const std::string& name) {
  auto p = real_array(positions, "positions", -1, 3);
  py::array fa = py::module_::import("numpy").attr("asarray")(faces);
  if (fa.dtype().kind() != 'i' && fa.dtype().kind() != 'u')
    throw py::type_error("faces must be an integer array of shape (F, 3)");
  if (fa.ndim() != 2 || fa.shape(1) != 3) throw InputError("faces must have shape (F, 3)");
  auto f = py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(fa);
  if (f.shape(0) == 0) throw InputError("a garment needs at least one face");
  Mesh mesh;
  std::vector<Vertex> vs;
  for (py::ssize_t i = 0; i < p.shape(0); ++i) vs.push_back(mesh.add_vertex(Point3(p.at(i, 0), p.at(i, 1), p.at(i, 2))));
  for (py::ssize_t i = 0; i < f.shape(0); ++i) {
    std::array<Vertex, 3> c;
    for (int k = 0; k < 3; ++k) {
      const long long x = f.at(i, k);
      if (x < 0 || x >= p.shape(0))
        throw InputError("face " + std::to_string(i) + " names vertex " + std::to_string(x) + ", which does not exist");
      c[k] = vs[x];
    }
    if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2])
      throw TopologyError("face " + std::to_string(i) + " repeats a vertex");
    if (mesh.add_face(c[0], c[1], c[2]) == Mesh::null_face())
      throw TopologyError("face " + std::to_string(i) +
                          " would make the mesh non-manifold (an edge shared by more than two faces, or faces "
                          "of opposite orientation across an edge)");
  }
  for (Vertex v : vs)
    if (mesh.is_isolated(v)) throw TopologyError("vertex " + std::to_string(v.idx()) + " is used by no face");
  Garment g(std::move(mesh), material);
  g.name = name;
  g.validate();
  return g;
}

void set_uvs(Garment& g, py::handle obj) {
  py::array a = py::module_::import("numpy").attr("asarray")(obj);
  const Mesh& m = g.mesh();
  const auto nf = static_cast<py::ssize_t>(m.number_of_faces());
  if (a.dtype().kind() != 'f' && a.dtype().kind() != 'i' && a.dtype().kind() != 'u')
    throw py::type_error("uvs must be an array of real numbers");
  if (a.ndim() != 3 || a.shape(0) != nf || a.shape(1) != 3 || a.shape(2) != 2)
    throw InputError("uvs must have shape (faces, 3, 2) = (" + std::to_string(nf) + ", 3, 2)");
  auto u = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  for (py::ssize_t i = 0; i < u.size(); ++i)
    if (!std::isfinite(u.data()[i])) throw InputError("uvs has a value that is not a finite number");
  std::size_t i = 0;
  for (Face f : m.faces()) {
    const auto c = corners(m, f);
    for (int k = 0; k < 3; ++k) g.set_uv(c[k], Vec2(u.at(i, k, 0), u.at(i, k, 1)));
    ++i;
  }
}

Material material_or_default(const std::optional<Material>& m) { return m ? *m : Material{}; }

}  // namespace

void bind_garment(py::module_& m) {
  py::class_<Ref, std::shared_ptr<Ref>> c(m, "Garment",
      "A garment: a triangle mesh with cloth properties. Per-vertex arrays have one row per live vertex,\n"
      "in vertex-index order (vertex_ids gives each row's index, stable across tool edits). Getters\n"
      "return copies; assign to a property to change the garment (checked: shape, dtype, NaN).");
  c.def(py::init([](py::handle positions, py::handle faces, std::optional<Material> material, const std::string& name,
                    py::handle uvs) {
          Garment g = garment_from_arrays(positions, faces, material_or_default(material), name);
          if (!uvs.is_none()) set_uvs(g, uvs);
          return std::make_shared<Ref>(std::move(g));
        }),
        py::arg("positions"), py::arg("faces"), py::kw_only(), py::arg("material") = py::none(),
        py::arg("name") = "garment", py::arg("uvs") = py::none(),
        "A garment from an (N, 3) float array of positions and an (F, 3) int array of triangles.\n"
        "Rest lengths are the current edge lengths. Raises TopologyError for a non-manifold mesh.");
  c.def_property("name", [](const Ref& r) {
    auto lock = r.guard();
    return r.get().name; }, [](Ref& r, const std::string& n) { r.edit([&](Garment& g) { g.name = n; }); });
  c.def_property_readonly("in_session", &Ref::in_session, "Whether this is a view of a session's garment.");
  c.def_property_readonly("vertex_count", [](const Ref& r) {
    auto lock = r.guard();
    return r.get().mesh().number_of_vertices(); });
  c.def_property_readonly("face_count", [](const Ref& r) {
    auto lock = r.guard();
    return r.get().mesh().number_of_faces(); });
  c.def_property_readonly("piece_count", [](const Ref& r) {
    auto lock = r.guard();
    return r.get().count_pieces(); },
                          "Number of connected pieces of cloth.");
  c.def_property_readonly("topology_version", [](const Ref& r) {
    auto lock = r.guard();
    return r.get().topology_version(); });
  c.def_property_readonly("vertex_ids", [](const Ref& r) {
    auto lock = r.guard();
   
    const VertexRows rows(r.get());
    py::array_t<std::int64_t> a(static_cast<py::ssize_t>(rows.vertices.size()));
    for (std::size_t i = 0; i < rows.vertices.size(); ++i) a.mutable_data()[i] = rows.vertices[i].idx();
    return a;
  }, "(V,) int64: the vertex index of each row (stable across tool edits).");
  c.def_property(
      "positions", [](const Ref& r) {
    auto lock = r.guard();
    const Garment& g = r.get(); return per_vertex(g, [&](Vertex v) { return g.position(v); }); },
      [](Ref& r, py::handle value) {
        r.edit([&](Garment& g) {
          const VertexRows rows(g);
          auto a = real_array(value, "positions", static_cast<long>(rows.vertices.size()), 3);
          for (std::size_t i = 0; i < rows.vertices.size(); ++i)
            g.set_position(rows.vertices[i], Vec3(a.at(i, 0), a.at(i, 1), a.at(i, 2)));
        });
      },
      "(V, 3) float64, metres.");
  c.def_property(
      "velocities", [](const Ref& r) {
    auto lock = r.guard();
    const Garment& g = r.get(); return per_vertex(g, [&](Vertex v) { return g.velocity(v); }); },
      [](Ref& r, py::handle value) {
        r.edit([&](Garment& g) {
          const VertexRows rows(g);
          auto a = real_array(value, "velocities", static_cast<long>(rows.vertices.size()), 3);
          for (std::size_t i = 0; i < rows.vertices.size(); ++i)
            g.velocity(rows.vertices[i]) = Vec3(a.at(i, 0), a.at(i, 1), a.at(i, 2));
        });
      },
      "(V, 3) float64, m/s.");
  c.def_property(
      "pins",
      [](const Ref& r) {
    auto lock = r.guard();
   
        const Garment& g = r.get();
        const VertexRows rows(g);
        py::array_t<bool> a(static_cast<py::ssize_t>(rows.vertices.size()));
        for (std::size_t i = 0; i < rows.vertices.size(); ++i) a.mutable_data()[i] = g.pinned(rows.vertices[i]);
        return a;
      },
      [](Ref& r, py::handle value) {
        r.edit([&](Garment& g) {
          const VertexRows rows(g);
          py::array a = py::module_::import("numpy").attr("asarray")(value);
          if (a.dtype().kind() != 'b') throw py::type_error("pins must be a bool array of shape (V,)");
          if (a.ndim() != 1 || a.shape(0) != static_cast<py::ssize_t>(rows.vertices.size()))
            throw InputError("pins must have shape (" + std::to_string(rows.vertices.size()) + ",)");
          auto b = py::array_t<bool, py::array::c_style | py::array::forcecast>::ensure(a);
          for (std::size_t i = 0; i < rows.vertices.size(); ++i) g.set_pinned(rows.vertices[i], b.data()[i]);
        });
      },
      "(V,) bool: pinned vertices do not move.");
  c.def_property_readonly("faces", [](const Ref& r) {
    auto lock = r.guard();
    return faces_array(r.get()); },
                          "(F, 3) int64: rows of the per-vertex arrays, counter-clockwise.");
  c.def_property(
      "uvs",
      [](const Ref& r) {
    auto lock = r.guard();
   
        const Garment& g = r.get();
        const Mesh& mm = g.mesh();
        py::array_t<double> a({static_cast<py::ssize_t>(mm.number_of_faces()), py::ssize_t(3), py::ssize_t(2)});
        auto w = a.mutable_unchecked<3>();
        std::size_t i = 0;
        for (Face f : mm.faces()) {
          const auto cs = corners(mm, f);
          for (int k = 0; k < 3; ++k) w(i, k, 0) = g.uv(cs[k]).x(), w(i, k, 1) = g.uv(cs[k]).y();
          ++i;
        }
        return a;
      },
      [](Ref& r, py::handle v) { r.edit([&](Garment& g) { set_uvs(g, v); }); },
      "(F, 3, 2) float64: texture coordinates of each face corner (in the order of faces).");
  c.def_property(
      "texture",
      [](const Ref& r) -> py::object {
        const Texture& t = r.get().texture();
        if (t.empty()) return py::none();
        py::array_t<std::uint8_t> a({t.height, t.width, 4});
        std::copy(t.rgba.begin(), t.rgba.end(), a.mutable_data());
        return std::move(a);
      },
      [](Ref& r, py::handle value) {
        Texture t;
        if (!value.is_none()) {
          py::array a = py::module_::import("numpy").attr("asarray")(value);
          if (a.dtype().kind() != 'u' || a.dtype().itemsize() != 1)
            throw py::type_error("a texture must be a uint8 array of shape (height, width, 4)");
          if (a.ndim() != 3 || a.shape(2) != 4 || a.shape(0) < 1 || a.shape(1) < 1)
            throw InputError("a texture must have shape (height, width, 4)");
          auto b = py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>::ensure(a);
          t.height = static_cast<int>(b.shape(0));
          t.width = static_cast<int>(b.shape(1));
          t.rgba.assign(b.data(), b.data() + b.size());
        }
        r.edit([&](Garment& g) { g.texture() = std::move(t); });
      },
      "(H, W, 4) uint8 RGBA in uv space (row 0 is v = 0), or None when nothing was painted.");
  c.def_property(
      "color", [](const Ref& r) {
    auto lock = r.guard();
    return vec3_array(r.get().color); },
      [](Ref& r, py::handle v) {
        const Vec3 col = to_vec3(v, "color");
        if ((col.array() < 0).any() || (col.array() > 1).any()) throw InputError("color components must be in [0, 1]");
        r.edit([&](Garment& g) { g.color = col; });
      },
      "Base colour, linear RGB in [0, 1].");
  c.def_property(
      "material", [](const Ref& r) {
    auto lock = r.guard();
    return r.get().material(); },
      [](Ref& r, const Material& mat) { r.edit([&](Garment& g) { g.set_material(mat); }); }, "The fabric (a copy; assign to change it).");
  c.def_property("pattern_scale", [](const Ref& r) {
    auto lock = r.guard();
    return r.get().pattern_scale(); },
                 [](Ref& r, double s) {
                   if (!std::isfinite(s) || s <= 0) throw InputError("pattern_scale must be a positive number");
                   r.edit([&](Garment& g) { g.set_pattern_scale(s); });
                 },
                 "Metres of flat pattern per unit of uv.");
  c.def_property_readonly("tacks", [](const Ref& r) {
    auto lock = r.guard();
   
    const Garment& g = r.get();
    const VertexRows rows(g);
    py::array_t<std::int64_t> a({static_cast<py::ssize_t>(g.tacks.size()), py::ssize_t(2)});
    for (std::size_t i = 0; i < g.tacks.size(); ++i) {
      a.mutable_at(i, 0) = rows.row[g.tacks[i].first.idx()];
      a.mutable_at(i, 1) = rows.row[g.tacks[i].second.idx()];
    }
    return a;
  }, "(T, 2) rows of vertices held together until sewn.");
  c.def_property_readonly("bounds", [](const Ref& r) {
    auto lock = r.guard();
   
    const Box3 b = r.get().bounds();
    py::array_t<double> a({2, 3});
    for (int i = 0; i < 3; ++i) a.mutable_at(0, i) = b.min()[i], a.mutable_at(1, i) = b.max()[i];
    return a;
  }, "[[min xyz], [max xyz]]");
  c.def_property_readonly("kinetic_energy", [](const Ref& r) {
    auto lock = r.guard();
    return r.get().kinetic_energy(); });
  c.def("is_valid", [](const Ref& r) {
    auto lock = r.guard();
    return r.get().is_valid(); }, "A valid manifold triangle mesh with finite values?");
  c.def("validate", [](const Ref& r) {
    auto lock = r.guard();
    r.get().validate(); }, "Raises TopologyError or InputError saying what is wrong.");
  c.def("pieces", [](const Ref& r) {
    auto lock = r.guard();
   
    const Garment& g = r.get();
    const auto label = face_pieces(g);
    py::array_t<std::int64_t> a(static_cast<py::ssize_t>(g.mesh().number_of_faces()));
    std::size_t i = 0;
    for (Face f : g.mesh().faces()) a.mutable_data()[i++] = label[f.idx()];
    return a;
  }, "(F,) int64: the piece each face belongs to (0 .. piece_count - 1).");
  c.def("border_loops", [](const Ref& r) {
    auto lock = r.guard();
   
    const Garment& g = r.get();
    const VertexRows rows(g);
    py::list out;
    for (const auto& loop : border_loops(g)) {
      py::array_t<std::int64_t> a(static_cast<py::ssize_t>(loop.size()));
      for (std::size_t i = 0; i < loop.size(); ++i) a.mutable_data()[i] = rows.row[loop[i].idx()];
      out.append(a);
    }
    return out;
  }, "The border loops, each an array of vertex rows in order.");
  c.def("remove_piece", [](Ref& r, long face) {
    r.edit([&](Garment& g) {
    const Mesh& mm = g.mesh();
    if (face < 0 || face >= static_cast<long>(mm.number_of_faces()))
      throw InputError("remove_piece: face " + std::to_string(face) + " does not exist");
    const auto label = face_pieces(g);
    std::vector<Face> fs(mm.faces().begin(), mm.faces().end());
    const int piece = label[fs[face].idx()];
    if (g.count_pieces() < 2) throw InputError("remove_piece: the garment is one piece; removing it would leave nothing");
    std::vector<Edge> edges;
    for (Edge e : mm.edges()) {
      const Halfedge h = mm.halfedge(e);
      const Face a = mm.face(h), b = mm.face(mm.opposite(h));
      if ((a != Mesh::null_face() && label[a.idx()] == piece) || (b != Mesh::null_face() && label[b.idx()] == piece))
        edges.push_back(e);
    }
    remove_edges(g, edges);
    });
  }, py::arg("face"),
     "Removes the piece of cloth that face (a row of faces) belongs to: what a cut left unneeded.\n"
     "In a session it is an operation of the journal (undo, replay and peers see it).");
  c.def("transform", [](Ref& r, py::handle matrix) {
    auto a = real_array(matrix, "transform", 4, 4);
    Eigen::Matrix4d t;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) t(i, j) = a.at(i, j);
    r.edit([&](Garment& g) { g.transform(Eigen::Affine3d(t)); });
  }, py::arg("matrix"), "Moves every vertex by a 4 x 4 affine matrix (the rest shape is unchanged).");
  c.def("translate", [](Ref& r, py::handle offset) {
    const Vec3 d = to_vec3(offset, "offset");
    r.edit([&](Garment& g) { g.transform(Eigen::Affine3d(Eigen::Translation3d(d))); });
  }, py::arg("offset"), "Moves every vertex by an offset (3,), metres (the rest shape is unchanged).");
  c.def("copy", [](const Ref& r) {
    auto lock = r.guard();
    return std::make_shared<Ref>(r.get()); }, "A separate copy, in no session.");
  c.def("export", [](const Ref& r, const std::string& path) {
    const Garment& g = r.get();
    py::gil_scoped_release nogil;
    export_garment(g, path);
  }, py::arg("path"), "Writes a .glb (with uv and texture) or .obj (+ .mtl + .png).");
  c.def("__repr__", [](const Ref& r) {
    auto lock = r.guard();
   
    const Garment& g = r.get();
    return "<kiji.Garment '" + g.name + "', " + std::to_string(g.mesh().number_of_vertices()) + " vertices, " +
           std::to_string(g.mesh().number_of_faces()) + " faces, " + std::to_string(g.count_pieces()) + " piece(s)" +
           (r.in_session() ? ", in a session" : "") + ">";
  });

  // --- pattern makers and files ---
  m.def("rectangle",
        [](double width, double height, std::optional<int> nx, std::optional<int> ny, std::optional<double> spacing,
           std::optional<Material> material, const std::string& name) {
          Garment g;
          if (spacing) {
            if (nx || ny) throw py::type_error("rectangle(): give either nx and ny or spacing, not both");
            g = make_rectangle_spaced(width, height, *spacing, material_or_default(material));
          } else {
            if (!nx || !ny) throw py::type_error("rectangle(): give nx and ny (vertices a side) or spacing (metres)");
            g = make_rectangle(width, height, *nx, *ny, material_or_default(material));
          }
          g.name = name;
          return std::make_shared<Ref>(std::move(g));
        },
        py::arg("width"), py::arg("height"), py::kw_only(), py::arg("nx") = py::none(), py::arg("ny") = py::none(),
        py::arg("spacing") = py::none(), py::arg("material") = py::none(), py::arg("name") = "rectangle",
        "A flat width x height (metres) rectangle in the z = 0 plane, with nx x ny vertices or vertices\n"
        "about `spacing` metres apart; uv = the pattern coordinates scaled to [0, 1].");
  m.def("panel",
        [](py::handle outline, double edge_length, std::optional<Material> material, int panel_id, const std::string& name) {
          auto a = real_array(outline, "outline", -1, 2);
          std::vector<Vec2> pts;
          for (py::ssize_t i = 0; i < a.shape(0); ++i) pts.emplace_back(a.at(i, 0), a.at(i, 1));
          Garment g = make_panel(pts, edge_length, material_or_default(material), panel_id);
          g.name = name;
          return std::make_shared<Ref>(std::move(g));
        },
        py::arg("outline"), py::arg("edge_length"), py::kw_only(), py::arg("material") = py::none(),
        py::arg("panel_id") = 0, py::arg("name") = "panel",
        "A pattern piece: a simple polygon outline ((N, 2) metres, not closed by a repeated point)\n"
        "triangulated inside with edges of about edge_length metres.");
  m.def("place_over_body", [](Ref& r, const Body& body, double clearance) { r.edit([&](Garment& g) { place_over_body(g, body, clearance); }); },
        py::arg("garment"), py::arg("body"), py::arg("clearance") = 0.02,
        "Lays a flat pattern horizontally over the body (x along the shoulders, y front to back),\n"
        "clearance metres above the highest point under it.");
  m.def("load_garment",
        [](const std::string& path, std::optional<Material> material, std::size_t memory_limit_mb, double timeout) {
          ImportLimits limits;
          limits.memory_mb = memory_limit_mb;
          limits.seconds = timeout;
          Garment g;
          {
            py::gil_scoped_release nogil;
            g = import_garment(path, material_or_default(material), limits);
          }
          return std::make_shared<Ref>(std::move(g));
        },
        py::arg("path"), py::arg("material") = py::none(), py::kw_only(),
        py::arg("memory_limit_mb") = ImportLimits{}.memory_mb, py::arg("timeout") = ImportLimits{}.seconds,
        "Reads a garment from .glb, .gltf or .obj. assimp reads it in a child process: a file that crashes\n"
        "it, or needs more than memory_limit_mb MiB or timeout seconds, raises ValueError and leaves this\n"
        "process as it was.");
  m.def("export_garment", [](const Ref& r, const std::string& path) { export_garment(r.get(), path); },
        py::arg("garment"), py::arg("path"), "Writes a .glb (with uv and texture) or .obj (+ .mtl + .png).");
  // The garments to draw and the box a default camera frames (the body and the garments).
  auto scene_of = [](const std::vector<std::shared_ptr<Ref>>& garments, const Body* body, const char* what) {
    std::pair<std::vector<const Garment*>, Box3> scene;
    if (body) scene.second.extend(body->bounds());
    for (const auto& r : garments) {
      if (!r) throw py::type_error(std::string(what) + ": garments must be kiji.Garment objects");
      scene.first.push_back(&r->get());
      scene.second.extend(r->get().bounds());
    }
    if (scene.second.isEmpty()) scene.second = Box3(Vec3(-1, 0, -1), Vec3(1, 2, 1));
    return scene;
  };
  m.def("render",
        [scene_of](const std::vector<std::shared_ptr<Ref>>& garments, const Body* body, std::optional<Camera> camera,
                   int width, int height) {
          if (width < 1 || height < 1 || width > 16384 || height > 16384)
            throw InputError("render: width and height must be 1 to 16384 pixels");
          const auto [gs, frame] = scene_of(garments, body, "render");
          const Camera cam = camera ? *camera : Camera::framing(frame);
          Image image;
          {
            py::gil_scoped_release nogil;
            image = render(gs, body, cam, width, height);
          }
          py::array_t<std::uint8_t> a({image.height, image.width, 4});
          std::copy(image.rgba.begin(), image.rgba.end(), a.mutable_data());
          return a;
        },
        py::arg("garments"), py::arg("body") = nullptr, py::kw_only(), py::arg("camera") = py::none(),
        py::arg("width") = 1024, py::arg("height") = 768,
        "A picture of garments (and a body) without a window: an (H, W, 4) uint8 array. The default\n"
        "camera frames everything from the front.");
  m.def("visible_points",
        [scene_of](py::handle points, const std::vector<std::shared_ptr<Ref>>& garments, const Body* body,
                   std::optional<Camera> camera, int width, int height, double tolerance) {
          const auto p = real_array(points, "points", -1, 3);
          std::vector<Vec3> ps(p.shape(0));
          for (std::size_t i = 0; i < ps.size(); ++i) ps[i] = Vec3(p.at(i, 0), p.at(i, 1), p.at(i, 2));
          const auto [gs, frame] = scene_of(garments, body, "visible_points");
          const Camera cam = camera ? *camera : Camera::framing(frame);
          std::vector<bool> seen;
          {
            py::gil_scoped_release nogil;
            seen = visible_points(gs, body, cam, width, height, ps, tolerance);
          }
          py::array_t<bool> a(static_cast<py::ssize_t>(seen.size()));
          for (std::size_t i = 0; i < seen.size(); ++i) a.mutable_at(i) = seen[i];
          return a;
        },
        py::arg("points"), py::arg("garments"), py::arg("body") = nullptr, py::kw_only(),
        py::arg("camera") = py::none(), py::arg("width") = 1024, py::arg("height") = 768,
        py::arg("tolerance") = 0.005,
        "(N,) bool: which of the (N, 3) points the picture render() would draw shows, each not hidden\n"
        "behind the body or cloth by more than `tolerance` metres along its ray.");
}

}  // namespace kiji::python
