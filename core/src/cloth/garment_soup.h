// The face soup that topology edits and the garment codec work on: a garment lowered to lists of
// vertices (by index, holes kept), faces with their corner uvs and panels, edge data by vertex pair,
// and tacks; and the one way back to a mesh (commit), which checks the result before it replaces
// anything. Internal to the core.
#pragma once

#include "kiji/garment.h"

#include <array>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace kiji::detail {

using Index = std::uint32_t;

struct VertexData {
  Vec3 position = Vec3::Zero();
  Vec3 velocity = Vec3::Zero();
  double inverse_mass = 1.0;
  bool alive = false;
};

struct EdgeData {
  double rest = 0;
  double threshold = 0;
};

inline std::uint64_t edge_key(Index a, Index b) {
  if (a > b) std::swap(a, b);
  return (std::uint64_t(a) << 32) | b;
}

struct Soup {
  std::vector<VertexData> vertices;         // by vertex index
  std::vector<std::array<Index, 3>> faces;  // counter-clockwise corners
  std::vector<std::array<Vec2, 3>> uvs;     // uv at each corner
  std::vector<int> panels;
  std::unordered_map<std::uint64_t, EdgeData> edges;
  std::vector<std::pair<Index, Index>> tacks;

  Index add_vertex(const VertexData& d) {
    vertices.push_back(d);
    return static_cast<Index>(vertices.size() - 1);
  }
  void add_face(std::array<Index, 3> f, std::array<Vec2, 3> uv, int panel) {
    faces.push_back(f);
    uvs.push_back(uv);
    panels.push_back(panel);
  }
  void erase_faces(const std::vector<char>& drop) {
    std::size_t out = 0;
    for (std::size_t i = 0; i < faces.size(); ++i) {
      if (drop[i]) continue;
      faces[out] = faces[i];
      uvs[out] = uvs[i];
      panels[out] = panels[i];
      ++out;
    }
    faces.resize(out);
    uvs.resize(out);
    panels.resize(out);
  }
  // Faces incident to each vertex.
  std::vector<std::vector<Index>> incidence() const {
    std::vector<std::vector<Index>> inc(vertices.size());
    for (Index f = 0; f < faces.size(); ++f)
      for (Index v : faces[f]) inc[v].push_back(f);
    return inc;
  }
};

// The garment as a soup: vertices by index (removed ones not alive), faces in face-index order.
Soup to_soup(const Garment& g);
// Splits every vertex whose faces fall into separate fans into one vertex a fan; returns how many
// vertices were added.
std::size_t split_fans(Soup& s);
// Throws TopologyError (naming `what`) if the soup is not a manifold triangle mesh.
void check_manifold(const Soup& s, const std::string& what);
// Builds the mesh from the soup and swaps it into the garment (masses recomputed from the rest
// areas); the garment is untouched on error.
void commit(Garment& g, const Soup& s, const std::string& what);

}  // namespace kiji::detail
