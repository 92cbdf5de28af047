#include "kiji/pattern.h"

#include "kiji/error.h"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Delaunay_mesh_face_base_2.h>
#include <CGAL/Delaunay_mesh_size_criteria_2.h>
#include <CGAL/Delaunay_mesh_vertex_base_2.h>
#include <CGAL/Delaunay_mesher_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_2.h>

#include <cmath>
#include <map>
#include <sstream>

namespace kiji {

namespace {

void require_length(double value, const char* what) {
  if (std::isfinite(value) && value > 0) return;
  std::ostringstream msg;
  msg << what << " is " << value << ": it must be a positive length in metres";
  throw InputError(msg.str());
}

}  // namespace

Garment make_rectangle(double width, double height, int nx, int ny, const Material& material) {
  require_length(width, "rectangle width");
  require_length(height, "rectangle height");
  if (nx < 2 || ny < 2)
    throw InputError("a rectangle needs at least 2 x 2 vertices, not " + std::to_string(nx) + " x " +
                     std::to_string(ny));
  if (static_cast<long long>(nx) * ny > 20'000'000)
    throw InputError("a rectangle of " + std::to_string(nx) + " x " + std::to_string(ny) +
                     " vertices is too large: use at most 20 million vertices");
  Mesh mesh;
  mesh.reserve(nx * ny, 3 * nx * ny, 2 * nx * ny);
  std::vector<Vertex> grid(static_cast<std::size_t>(nx) * ny);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      grid[j * nx + i] = mesh.add_vertex(Point3(width * i / (nx - 1), height * j / (ny - 1), 0.0));
  for (int j = 0; j + 1 < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) {
      const Vertex a = grid[j * nx + i], b = grid[j * nx + i + 1];
      const Vertex c = grid[(j + 1) * nx + i + 1], d = grid[(j + 1) * nx + i];
      // Alternate the diagonal like a checkerboard so the cloth has no preferred shear direction.
      if ((i + j) % 2 == 0) {
        mesh.add_face(a, b, c);
        mesh.add_face(a, c, d);
      } else {
        mesh.add_face(a, b, d);
        mesh.add_face(b, c, d);
      }
    }
  }
  Garment g(std::move(mesh), material);
  g.name = "rectangle";
  return g;
}

Garment make_rectangle_spaced(double width, double height, double spacing, const Material& material) {
  RectSpec spec{width, height, spacing};
  spec.validate();
  const int nx = std::max(2, static_cast<int>(std::lround(width / spacing)) + 1);
  const int ny = std::max(2, static_cast<int>(std::lround(height / spacing)) + 1);
  return make_rectangle(width, height, nx, ny, material);
}

void RectSpec::validate() const {
  require_length(width, "garment width");
  require_length(height, "garment height");
  require_length(spacing, "garment spacing");
  if (spacing > width || spacing > height) {
    std::ostringstream msg;
    msg << "garment spacing " << spacing << " m is larger than the garment (" << width << " x "
        << height << " m): use a spacing smaller than both sides";
    throw InputError(msg.str());
  }
  if ((width / spacing + 1) * (height / spacing + 1) > 20e6)
    throw InputError("garment spacing is so small the cloth would have over 20 million vertices");
}

RectSpec RectSpec::parse(const std::string& spec) {
  const std::string usage = "expected rect:WIDTH,HEIGHT,SPACING in metres, e.g. rect:1.2,1.0,0.01";
  if (spec.rfind("rect:", 0) != 0)
    throw InputError("garment spec '" + spec + "' is not understood: " + usage);
  std::vector<double> values;
  std::string rest = spec.substr(5);
  std::size_t start = 0;
  while (start <= rest.size()) {
    const std::size_t comma = rest.find(',', start);
    const std::string token = rest.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    try {
      std::size_t used = 0;
      values.push_back(std::stod(token, &used));
      if (used != token.size()) throw std::invalid_argument(token);
    } catch (const std::exception&) {
      throw InputError("garment spec '" + spec + "': '" + token + "' is not a number; " + usage);
    }
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (values.size() != 3)
    throw InputError("garment spec '" + spec + "' has " + std::to_string(values.size()) +
                     " numbers: " + usage);
  RectSpec r{values[0], values[1], values[2]};
  r.validate();
  return r;
}

Garment make_panel(const std::vector<Vec2>& outline, double edge_length, const Material& material,
                   int panel_id) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  using Vb = CGAL::Delaunay_mesh_vertex_base_2<K>;
  using Fb = CGAL::Delaunay_mesh_face_base_2<K>;
  using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
  using Cdt = CGAL::Constrained_Delaunay_triangulation_2<K, Tds>;
  using Criteria = CGAL::Delaunay_mesh_size_criteria_2<Cdt>;

  require_length(edge_length, "panel edge length");
  if (outline.size() < 3)
    throw InputError("a panel outline needs at least 3 points, not " + std::to_string(outline.size()));
  CGAL::Polygon_2<K> polygon;
  for (std::size_t i = 0; i < outline.size(); ++i) {
    if (!all_finite(outline[i]))
      throw InputError("panel outline point " + std::to_string(i) + " is not a finite number");
    polygon.push_back(K::Point_2(outline[i].x(), outline[i].y()));
  }
  if (!polygon.is_simple())
    throw InputError("the panel outline crosses itself or repeats a point: give a simple polygon");
  const double area = std::abs(polygon.area());
  if (!(area > 0)) throw InputError("the panel outline encloses no area");
  if (area / (edge_length * edge_length) > 40e6)
    throw InputError("panel edge length is so small the cloth would have tens of millions of triangles");

  // Split the outline to the target length first so the border is as fine as the inside.
  Cdt cdt;
  std::vector<Cdt::Vertex_handle> ring;
  const std::size_t n = outline.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2 a = outline[i], b = outline[(i + 1) % n];
    const int pieces = std::max(1, static_cast<int>(std::ceil((b - a).norm() / edge_length - 1e-9)));
    for (int k = 0; k < pieces; ++k) {
      const Vec2 p = a + (b - a) * (double(k) / pieces);
      ring.push_back(cdt.insert(K::Point_2(p.x(), p.y())));
    }
  }
  for (std::size_t i = 0; i < ring.size(); ++i) cdt.insert_constraint(ring[i], ring[(i + 1) % ring.size()]);
  // 0.125 bounds the smallest angle near 20.7 degrees; the size bound is the longest edge.
  CGAL::refine_Delaunay_mesh_2(cdt, Criteria(0.125, edge_length));

  Mesh mesh;
  std::map<Cdt::Vertex_handle, Vertex> index;
  auto vertex_of = [&](Cdt::Vertex_handle h) {
    auto it = index.find(h);
    if (it != index.end()) return it->second;
    const Vertex v = mesh.add_vertex(Point3(h->point().x(), h->point().y(), 0.0));
    index.emplace(h, v);
    return v;
  };
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
    if (!f->is_in_domain()) continue;
    mesh.add_face(vertex_of(f->vertex(0)), vertex_of(f->vertex(1)), vertex_of(f->vertex(2)));
  }
  if (mesh.number_of_faces() == 0) throw InputError("the panel outline produced no triangles");
  Garment g(std::move(mesh), material);
  g.name = "panel";
  for (Face f : g.mesh().faces()) g.set_panel(f, panel_id);
  g.validate();
  return g;
}

}  // namespace kiji
