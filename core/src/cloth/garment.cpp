#include "kiji/garment.h"

#include "kiji/error.h"

#include <CGAL/boost/graph/helpers.h>

#include <atomic>
#include <cmath>
#include <sstream>
#include <unordered_map>

namespace kiji {

namespace PMP = CGAL::Polygon_mesh_processing;

namespace {
std::uint64_t fresh_version() {
  static std::atomic<std::uint64_t> next{1};
  return next++;
}
}  // namespace

std::vector<Vertex> non_manifold_vertices(const Mesh& mesh) {
  std::vector<std::uint32_t> incoming(mesh.number_of_vertices() + mesh.number_of_removed_vertices(), 0);
  for (Halfedge h : mesh.halfedges()) ++incoming[mesh.target(h).idx()];
  std::vector<Vertex> out;
  for (Vertex v : mesh.vertices()) {
    if (mesh.is_isolated(v)) continue;
    std::uint32_t around = 0;
    for (Halfedge h : CGAL::halfedges_around_target(mesh.halfedge(v), mesh)) {
      (void)h;
      if (++around > incoming[v.idx()]) break;
    }
    if (around != incoming[v.idx()]) out.push_back(v);
  }
  return out;
}

void Garment::bump_topology_version() {
  // The step record stays: a solver's rebuild takes from it the long-range anchors of the vertices
  // an edit kept, and nothing else of it (the rest is of the mesh before; solver.cpp, rebuild).
  topology_version_ = fresh_version();
}

Garment::Garment() : topology_version_(fresh_version()) { attach_maps(); }

Garment::Garment(Mesh mesh, Material material) : mesh_(std::move(mesh)), topology_version_(fresh_version()) {
  material.validate();
  material_ = std::move(material);
  attach_maps();
  double min_x = 0, min_y = 0, extent = 0;
  if (!mesh_.is_empty()) {
    Box3 box = bounds();
    min_x = box.min().x();
    min_y = box.min().y();
    extent = std::max(box.sizes().x(), box.sizes().y());
  }
  pattern_scale_ = extent > 0 ? extent : 1.0;
  for (Edge e : mesh_.edges()) {
    rest_length_[e] = length(e);
    tear_threshold_[e] = material_.tear_ratio * rest_length_[e];
  }
  for (Face f : mesh_.faces()) {
    for (Halfedge h : CGAL::halfedges_around_face(mesh_.halfedge(f), mesh_)) {
      const Point3& p = mesh_.point(mesh_.target(h));
      uv_[h] = Vec2((p.x() - min_x) / pattern_scale_, (p.y() - min_y) / pattern_scale_);
    }
  }
  recompute_masses();
}

Garment::Garment(const Garment& other)
    : name(other.name),
      color(other.color),
      tacks(other.tacks),
      mesh_(other.mesh_),
      material_(other.material_),
      texture_(other.texture_),
      pattern_scale_(other.pattern_scale_),
      topology_version_(fresh_version()),
      sleep_record_(other.sleep_record_),
      step_record_(other.step_record_) {
  attach_maps();
}

Garment& Garment::operator=(const Garment& other) {
  if (this == &other) return *this;
  name = other.name;
  color = other.color;
  tacks = other.tacks;
  mesh_ = other.mesh_;
  material_ = other.material_;
  texture_ = other.texture_;
  pattern_scale_ = other.pattern_scale_;
  topology_version_ = fresh_version();  // a different mesh: solvers must rebuild
  sleep_record_ = other.sleep_record_;
  step_record_ = other.step_record_;
  attach_maps();
  return *this;
}

Garment::Garment(Garment&& other) noexcept
    : name(std::move(other.name)),
      color(other.color),
      tacks(std::move(other.tacks)),
      mesh_(std::move(other.mesh_)),
      material_(std::move(other.material_)),
      texture_(std::move(other.texture_)),
      pattern_scale_(other.pattern_scale_),
      topology_version_(fresh_version()),
      sleep_record_(std::move(other.sleep_record_)),
      step_record_(std::move(other.step_record_)) {
  attach_maps();
}

Garment& Garment::operator=(Garment&& other) noexcept {
  name = std::move(other.name);
  color = other.color;
  tacks = std::move(other.tacks);
  mesh_ = std::move(other.mesh_);
  material_ = std::move(other.material_);
  texture_ = std::move(other.texture_);
  pattern_scale_ = other.pattern_scale_;
  topology_version_ = fresh_version();
  sleep_record_ = std::move(other.sleep_record_);
  step_record_ = std::move(other.step_record_);
  attach_maps();
  return *this;
}

Garment::~Garment() = default;

void Garment::attach_maps() {
  rest_length_ = mesh_.add_property_map<Edge, double>("e:rest_length", 0.0).first;
  tear_threshold_ = mesh_.add_property_map<Edge, double>("e:tear_threshold", 0.0).first;
  uv_ = mesh_.add_property_map<Halfedge, Vec2>("h:uv", Vec2::Zero()).first;
  velocity_ = mesh_.add_property_map<Vertex, Vec3>("v:velocity", Vec3::Zero()).first;
  inverse_mass_ = mesh_.add_property_map<Vertex, double>("v:inverse_mass", 1.0).first;
  panel_ = mesh_.add_property_map<Face, int>("f:panel", 0).first;
}

void Garment::set_material(const Material& material) {
  material.validate();
  const double old_ratio = material_.tear_ratio;
  material_ = material;
  for (Edge e : mesh_.edges()) {
    // Thresholds that followed the old material follow the new one; custom ones are kept.
    if (std::abs(tear_threshold_[e] - old_ratio * rest_length_[e]) <= 1e-12 * rest_length_[e])
      tear_threshold_[e] = material_.tear_ratio * rest_length_[e];
  }
  recompute_masses();
}

double Garment::length(Edge e) const {
  const Halfedge h = mesh_.halfedge(e);
  return std::sqrt(CGAL::squared_distance(mesh_.point(mesh_.source(h)), mesh_.point(mesh_.target(h))));
}

double Garment::rest_area(Face f) const {
  double l[3];
  int i = 0;
  for (Halfedge h : CGAL::halfedges_around_face(mesh_.halfedge(f), mesh_)) {
    if (i < 3) l[i] = rest_length_[mesh_.edge(h)];
    ++i;
  }
  if (i != 3) return 0.0;
  const double s = 0.5 * (l[0] + l[1] + l[2]);
  const double a2 = s * (s - l[0]) * (s - l[1]) * (s - l[2]);
  return a2 > 0 ? std::sqrt(a2) : 0.0;
}

double Garment::mass(Vertex v) const {
  double area = 0.0;
  for (Face f : CGAL::faces_around_target(mesh_.halfedge(v), mesh_))
    if (f != Mesh::null_face()) area += rest_area(f) / 3.0;
  return area * material_.density;
}

void Garment::recompute_masses() {
  std::vector<double> area(vertex_capacity(), 0.0);
  for (Face f : mesh_.faces()) {
    const double a = rest_area(f) / 3.0;
    for (Vertex v : CGAL::vertices_around_face(mesh_.halfedge(f), mesh_)) area[v] += a;
  }
  for (Vertex v : mesh_.vertices()) {
    if (inverse_mass_[v] == 0.0) continue;  // pinned stays pinned
    const double m = area[v] * material_.density;
    inverse_mass_[v] = m > 0 ? 1.0 / m : 1.0;
  }
}

void Garment::set_pinned(Vertex v, bool pinned) {
  if (pinned) {
    inverse_mass_[v] = 0.0;
    velocity_[v] = Vec3::Zero();
  } else {
    const double m = mass(v);
    inverse_mass_[v] = m > 0 ? 1.0 / m : 1.0;
  }
}

double Garment::kinetic_energy() const {
  double e = 0.0;
  for (Vertex v : mesh_.vertices()) {
    if (inverse_mass_[v] == 0.0) continue;
    e += 0.5 * velocity_[v].squaredNorm() / inverse_mass_[v];
  }
  return e;
}

Box3 Garment::bounds() const {
  Box3 box;
  for (Vertex v : mesh_.vertices()) box.extend(position(v));
  return box;
}

bool Garment::is_valid() const {
  try {
    validate();
    return true;
  } catch (const Error&) {
    return false;
  }
}

void Garment::validate() const {
  if (!CGAL::is_valid_polygon_mesh(mesh_))
    throw TopologyError("garment '" + name + "' is not a valid polygon mesh");
  if (!mesh_.is_empty() && !CGAL::is_triangle_mesh(mesh_))
    throw TopologyError("garment '" + name + "' has faces that are not triangles");
  const std::vector<Vertex> bad = non_manifold_vertices(mesh_);
  if (!bad.empty())
    throw TopologyError("garment '" + name + "' has a non-manifold vertex " + std::to_string(bad.front().idx()));
  for (Vertex v : mesh_.vertices()) {
    if (mesh_.is_isolated(v))
      throw TopologyError("garment '" + name + "' has an isolated vertex " + std::to_string(v.idx()));
    if (!all_finite(position(v)) || !all_finite(velocity_[v]))
      throw InputError("garment '" + name + "' has a non-finite position or velocity at vertex " +
                       std::to_string(v.idx()));
  }
}

std::size_t Garment::count_pieces() const {
  std::vector<char> seen(mesh_.number_of_faces() + mesh_.number_of_removed_faces(), 0);
  std::vector<Face> stack;
  std::size_t pieces = 0;
  for (Face start : mesh_.faces()) {
    if (seen[start]) continue;
    ++pieces;
    seen[start] = 1;
    stack.push_back(start);
    while (!stack.empty()) {
      const Face f = stack.back();
      stack.pop_back();
      for (Halfedge h : CGAL::halfedges_around_face(mesh_.halfedge(f), mesh_)) {
        const Face n = mesh_.face(mesh_.opposite(h));
        if (n != Mesh::null_face() && !seen[n]) {
          seen[n] = 1;
          stack.push_back(n);
        }
      }
    }
  }
  return pieces;
}

void Garment::replace_mesh(Mesh mesh) {
  mesh_ = std::move(mesh);
  attach_maps();
  bump_topology_version();
}

void Garment::compact() {
  if (!mesh_.has_garbage()) return;
  auto old_index = mesh_.add_property_map<Vertex, std::uint32_t>("v:kiji_old_index", 0).first;
  for (Vertex v : mesh_.vertices()) old_index[v] = v.idx();
  mesh_.collect_garbage();
  std::unordered_map<std::uint32_t, Vertex> now;
  for (Vertex v : mesh_.vertices()) now[old_index[v]] = v;
  mesh_.remove_property_map(old_index);
  sleep_record_.reset();  // both are by vertex index
  step_record_.reset();
  for (auto& [a, b] : tacks) {
    a = now.at(a.idx());
    b = now.at(b.idx());
  }
  attach_maps();
  bump_topology_version();
}

void Garment::transform(const Eigen::Affine3d& t) {
  for (Vertex v : mesh_.vertices()) set_position(v, t * position(v));
  const Eigen::Matrix3d r = t.linear();
  for (Vertex v : mesh_.vertices()) velocity_[v] = r * velocity_[v];
}

}  // namespace kiji
