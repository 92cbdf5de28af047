// A garment: a CGAL half-edge triangle mesh with the per-element properties cloth needs.
//
// The mesh is the truth for topology. Positions live in the mesh's points; the rest are property
// maps: rest length and tear threshold per edge, uv per halfedge (the uv of the halfedge's target
// vertex in the halfedge's face, so seams can carry two uvs), velocity and inverse mass per vertex
// (0 = pinned), and a panel id per face. Vertex indices are stable across topology edits (removed
// vertices stay as holes until compact()); halfedge, edge and face indices are not.
#pragma once

#include "kiji/material.h"
#include "kiji/texture.h"
#include "kiji/types.h"

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace kiji {

struct SleepRecord;  // the solver's, opaque here (see Garment::sleep_record)
struct StepRecord;   // the solver's, opaque here (see Garment::step_record)

// The vertices of a mesh that are non-manifold: whose faces do not form one fan (a "bowtie").
// O(n): one pass counts each vertex's incoming halfedges, one circulation per vertex compares.
// (CGAL's is_non_manifold_vertex allocates a map of every halfedge per call: O(n) a vertex.)
std::vector<Vertex> non_manifold_vertices(const Mesh& mesh);

class Garment {
 public:
  Garment();
  // Adopts a triangle mesh; rest lengths are the current edge lengths, uv the x/y of the points.
  explicit Garment(Mesh mesh, Material material = {});
  Garment(const Garment& other);
  Garment& operator=(const Garment& other);
  Garment(Garment&&) noexcept;
  Garment& operator=(Garment&&) noexcept;
  ~Garment();

  std::string name = "garment";

  Mesh& mesh() { return mesh_; }
  const Mesh& mesh() const { return mesh_; }

  const Material& material() const { return material_; }
  // Validates, then sets the material; rest lengths are kept, tear thresholds and masses follow it.
  void set_material(const Material& material);

  Texture& texture() { return texture_; }
  const Texture& texture() const { return texture_; }
  // Base colour (linear RGB in [0,1]) shown where there is no texture.
  Vec3 color{0.80, 0.25, 0.22};

  // Tacks: pairs of vertices held together (a zero-length spring in the solver) until they can be
  // merged. Sewing two separate border vertices tacks them: merging them alone would pinch the
  // cloth at one vertex; once a neighbouring pair is sewn too, the two pairs close as a seam. A
  // seam that closes (tack_seam) is all tacks, which a session sews as they meet (close_tacks).
  // Topology edits keep them up to date (a merged or removed vertex drops its tacks).
  std::vector<std::pair<Vertex, Vertex>> tacks;

  // --- per-vertex ---
  Vec3 position(Vertex v) const { return to_vec(mesh_.point(v)); }
  void set_position(Vertex v, const Vec3& p) { mesh_.point(v) = to_point(p); }
  Vec3& velocity(Vertex v) { return velocity_[v]; }
  const Vec3& velocity(Vertex v) const { return velocity_[v]; }
  double inverse_mass(Vertex v) const { return inverse_mass_[v]; }
  bool pinned(Vertex v) const { return inverse_mass_[v] == 0.0; }
  void set_pinned(Vertex v, bool pinned);
  // Lumped mass: a third of the rest area of each incident face times the areal density.
  double mass(Vertex v) const;
  // Recomputes every unpinned inverse mass from rest areas and density.
  void recompute_masses();

  // --- per-edge ---
  double rest_length(Edge e) const { return rest_length_[e]; }
  void set_rest_length(Edge e, double length) { rest_length_[e] = length; }
  // Length above which the edge tears (material tear_ratio times rest length, unless set).
  double tear_threshold(Edge e) const { return tear_threshold_[e]; }
  void set_tear_threshold(Edge e, double length) { tear_threshold_[e] = length; }
  double length(Edge e) const;
  double strain(Edge e) const { return length(e) / rest_length(e) - 1.0; }

  // --- per-halfedge / per-face ---
  Vec2 uv(Halfedge h) const { return uv_[h]; }
  void set_uv(Halfedge h, const Vec2& uv) { uv_[h] = uv; }
  int panel(Face f) const { return panel_[f]; }
  void set_panel(Face f, int panel) { panel_[f] = panel; }
  // Rest area of a face from its rest edge lengths (Heron).
  double rest_area(Face f) const;

  // Metres of flat pattern per unit of uv (uv spans [0,1] over the pattern's larger side).
  double pattern_scale() const { return pattern_scale_; }
  void set_pattern_scale(double metres_per_uv) { pattern_scale_ = metres_per_uv; }

  // Changed by every topology edit, copy and assignment, to a value no other garment has had: a
  // solver rebuilds its arrays when it differs from the one it saw.
  std::uint64_t topology_version() const { return topology_version_; }
  void bump_topology_version();

  // Where the cloth last fell asleep in a solver (see SolverParams::sleep_after): a solver built
  // anew for this garment (a new session, an undo, a cut or a tear elsewhere on it) starts with
  // every block still exactly as it slept asleep, instead of waking the whole garment. Each vertex
  // counts only while its position, zero velocity, inverse mass, edges and rest lengths are those it
  // slept with, so an edit of any of them wakes it. Written by the solver; copies share it.
  const std::shared_ptr<const SleepRecord>& sleep_record() const { return sleep_record_; }
  void set_sleep_record(std::shared_ptr<const SleepRecord> record) { sleep_record_ = std::move(record); }

  // What the solver carried from its last step to the next beyond the garment's own state: how it
  // ordered the cloth, its collision margins, the body's hold, and the cloth settling towards sleep.
  // A solver built anew for this garment with the same mesh (a session opened from its file, a peer
  // after a checkpoint, an undo) takes it up, so it steps on exactly as the one that wrote it would
  // have. After an edit, a solver takes from it only the long-range anchors of the vertices the
  // edit kept, so that the edit changes the limits only around itself. Written by the solver after
  // each step; copies share it.
  const std::shared_ptr<const StepRecord>& step_record() const { return step_record_; }
  void set_step_record(std::shared_ptr<const StepRecord> record) { step_record_ = std::move(record); }

  // One past the largest vertex index in use (removed vertices included): the size of flat arrays.
  std::size_t vertex_capacity() const { return mesh_.number_of_vertices() + mesh_.number_of_removed_vertices(); }

  // Sum of kinetic energy, 1/2 m v^2 over unpinned vertices.
  double kinetic_energy() const;
  Box3 bounds() const;
  // Throws TopologyError if the mesh is not a valid triangle mesh without isolated or non-manifold
  // vertices, InputError if a position or velocity is not finite.
  void validate() const;
  bool is_valid() const;
  // Number of connected pieces of cloth.
  std::size_t count_pieces() const;

  // Replaces the mesh (the topology edits build a new one); the garment's property maps are taken
  // from `mesh` by name where it has them. Bumps the topology version.
  void replace_mesh(Mesh mesh);

  // Removes the holes left by removed elements; vertex indices change; bumps the topology version.
  void compact();
  // Rigid or affine placement of the whole garment (positions only; rest state unchanged).
  void transform(const Eigen::Affine3d& t);

  // Property maps, for code that walks the mesh itself (tools, I/O).
  using EdgeDoubleMap = Mesh::Property_map<Edge, double>;
  using HalfedgeUvMap = Mesh::Property_map<Halfedge, Vec2>;
  using VertexVecMap = Mesh::Property_map<Vertex, Vec3>;
  using VertexDoubleMap = Mesh::Property_map<Vertex, double>;
  using FaceIntMap = Mesh::Property_map<Face, int>;

 private:
  void attach_maps();

  Mesh mesh_;
  Material material_;
  Texture texture_;
  double pattern_scale_ = 1.0;
  std::uint64_t topology_version_;
  EdgeDoubleMap rest_length_;
  EdgeDoubleMap tear_threshold_;
  HalfedgeUvMap uv_;
  VertexVecMap velocity_;
  VertexDoubleMap inverse_mass_;
  FaceIntMap panel_;
  std::shared_ptr<const SleepRecord> sleep_record_;
  std::shared_ptr<const StepRecord> step_record_;
};

}  // namespace kiji
