// What a viewport draws of a session, as the simulation thread last published it: vertex arrays
// ready for a GPU, the body, the pointer and the cloth point it would act on. A frame is immutable
// once published and shared by pointer, so a UI draws it with no lock while the next step runs;
// what did not change (a garment's topology, its texture, the body) is shared with the frame before.
#pragma once

#include "kiji/body.h"
#include "kiji/texture.h"
#include "kiji/tool_event.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace kiji {

class Session;

// A garment's mesh as drawn: one render vertex for each distinct (vertex, uv) corner, so that a uv
// seam draws with both its uvs. Rebuilt only when the garment's topology version changes.
struct GarmentTopology {
  std::uint64_t topology_version = 0;
  std::vector<std::uint32_t> mesh_vertex;  // render vertex -> the mesh's vertex index
  std::vector<float> uv;                   // 2 a render vertex
  std::vector<std::uint32_t> triangles;    // 3 a face, render vertices
  std::vector<std::uint32_t> edges;        // 2 a mesh edge, render vertices
  std::vector<std::uint32_t> points;       // 1 a mesh vertex, a render vertex of it
  std::size_t vertex_count = 0, face_count = 0;  // of the mesh
};

struct GarmentFrame {
  std::string name;
  std::shared_ptr<const GarmentTopology> topology;
  std::vector<float> positions;  // 3 a render vertex, world metres
  std::vector<float> normals;    // 3 a render vertex, unit (area-weighted over the faces around)
  std::shared_ptr<const Texture> texture;  // null: no texture (draw `color`); the same pointer while unchanged
  Vec3 color{0.8, 0.25, 0.22};
  Box3 bounds;
  std::vector<std::uint32_t> tacks;  // 2 a tack (a seam closing), mesh vertices
};

struct SceneFrame {
  std::uint64_t number = 0;  // counts published frames
  double time = 0;           // the session's clock
  std::vector<GarmentFrame> garments;
  std::shared_ptr<const Body> body;  // the same pointer while the body does not change

  // The pointing device, when there is one: where it is, what it would act on, what it feels.
  bool has_pointer = false;
  ToolEvent pointer;
  SurfaceHit hit;
  Vec3 force{0, 0, 0};

  bool stroke_active = false;
  std::string stroke_tool;
  // The stroke took hold of cloth as it began (the tool attached it to the hand or pinned it to
  // move it): a mouse then moves the pointer on a plane, pulling the cloth, rather than along the
  // cloth's surface under the cursor.
  bool stroke_holds_cloth = false;
  bool simulating = true;
  bool can_undo = false, can_redo = false;
  std::size_t vertices = 0, faces = 0;  // over every garment

  Box3 bounds() const;  // of the garments and the body
};

// Builds frames of one session, keeping what is shared between them.
class SceneFrameBuilder {
 public:
  // A new frame of the session (the caller holds its lock). `textures_may_have_changed`: a tool or
  // an edit ran since the last frame, so textures are compared with the last frame's and copied
  // where they differ; otherwise they are shared as they were.
  std::shared_ptr<SceneFrame> build(const Session& session, bool textures_may_have_changed);

 private:
  struct Cache {
    std::shared_ptr<const GarmentTopology> topology;
    std::shared_ptr<const Texture> texture;
  };
  std::vector<Cache> garments_;
  std::shared_ptr<const Body> body_;
  std::uint64_t number_ = 0;
};

}  // namespace kiji
