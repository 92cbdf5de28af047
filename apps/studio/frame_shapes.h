// What the app reads of a published garment frame to aim with, without the session: its border
// loops (mesh vertices in order) and their corners, its pieces, its sewn seams (edges where the faces
// on the two sides have different uvs: two borders joined), and where a ray first meets the cloth or
// the body. A shape is computed once for each topology the simulation publishes.
#pragma once

#include "kiji/scene_frame.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace kiji::studio {

constexpr std::uint32_t kNone = ~0u;

struct GarmentShape {
  std::shared_ptr<const GarmentTopology> topology;
  std::vector<std::uint32_t> render_of;            // mesh vertex -> one of its render vertices (kNone: none)
  std::vector<std::vector<std::uint32_t>> loops;   // border loops, mesh vertices in the faces' turning order
  std::vector<int> loop_of, place_in_loop;         // mesh vertex -> its loop and place in it (-1: not on a border)
  std::vector<char> corner;                        // mesh vertex: the border turns there by 40 degrees or more (in the pattern)
  std::vector<int> piece_of_triangle;              // triangle -> its piece (connected by edges)
  std::vector<int> piece_of_border;                // mesh vertex on a border -> its piece (-1: not on a border)
  std::vector<std::uint32_t> piece_vertex;         // piece -> a mesh vertex of it
  std::vector<std::uint32_t> seams;                // sewn edges: render vertex pairs
  int pieces = 0;

  explicit GarmentShape(const GarmentFrame& g);
  Vec3 position(const GarmentFrame& g, std::uint32_t mesh_vertex) const;
  bool on_border(std::uint32_t v) const { return v < loop_of.size() && loop_of[v] >= 0; }
  // Whether the stretch of border `side` runs the way of its loop (the faces' turning order).
  bool runs_with_loop(const std::vector<std::uint32_t>& side) const;
  // The border vertices from `from` to `to` along their loop, going `forward` (the loop's order) or
  // back; empty if they are not on one loop.
  std::vector<std::uint32_t> along(std::uint32_t from, std::uint32_t to, bool forward) const;
  // The stretch of border between the corners on either side of v (the whole loop if it has fewer
  // than two corners), in the loop's order.
  std::vector<std::uint32_t> side_of(std::uint32_t v) const;
  // The piece's triangles (render vertex triples).
  std::vector<std::uint32_t> piece_triangles(int piece) const;
};

// Shapes of a frame's garments, made again only where the topology changed.
class ShapeCache {
 public:
  const GarmentShape* get(const SceneFrame& frame, std::size_t garment);

 private:
  std::vector<std::shared_ptr<const GarmentShape>> shapes_;
};

struct RayHit {
  bool hit = false;
  int garment = -1;        // -1: the body
  std::size_t triangle = 0;
  double t = 0;            // along the ray
  Vec3 point = Vec3::Zero();
};

// Where the ray from `origin` along the unit `dir` first meets a garment of the frame, or (with
// `body`) the body as well.
RayHit cast_ray(const SceneFrame& frame, const Vec3& origin, const Vec3& dir, bool body);

}  // namespace kiji::studio
