// Draws a SceneFrame with OpenGL 3.3 core (what Mesa's llvmpipe gives on a machine without a GPU):
// the body and the garments lit and shaded (with their painted texture), their edges and vertices
// everywhere, around the pointer or not at all, the pointer as a 3D pen with the cloth point it
// would act on, and the force the hand feels; in a shared session, the other peers' pointers and
// viewpoints and the cloth each has leased, in each peer's colour. GPU buffers are kept between
// frames and refilled only with what changed.
#pragma once

#include "orbit_camera.h"
#include "peer_link.h"

#include "kiji/scene_frame.h"

#include <QOpenGLBuffer>
#include <QOpenGLExtraFunctions>
#include <QOpenGLShaderProgram>
#include <QOpenGLTexture>
#include <QOpenGLVertexArrayObject>

#include <memory>
#include <vector>

namespace kiji::studio {

// The paper's figure 10 and tables 1-2: a garment's topology drawn everywhere, only in the region
// around the pointer, or not at all.
enum class EdgeDisplay { None, Local, All };

// What the viewport draws over the scene to aim with: lines and points (a pointer's drop line, a
// trail, a seam's pairs, highlights), and garment faces tinted (a selected piece).
struct OverlayLines {
  std::vector<float> xyz;
  Vec3 colour{1, 1, 1};
  GLenum mode = GL_LINES;  // GL_LINES, GL_LINE_STRIP, GL_LINE_LOOP or GL_POINTS
  float size = 1;          // line width or point size, pixels
  float alpha = 1;
  bool on_top = false;     // drawn over whatever is in front of it
};
struct OverlayTint {
  std::size_t garment = 0;
  std::vector<std::uint32_t> triangles;  // render vertices, three a face
  Vec3 colour{1, 1, 1};
  float alpha = 0.5f;
};
struct Overlay {
  std::vector<OverlayLines> lines;
  std::vector<OverlayTint> tints;
};

struct DrawOptions {
  EdgeDisplay edges = EdgeDisplay::Local;
  double local_radius = 0.12;  // metres around the pointer
  bool show_body = true;
  bool show_floor = true;
  bool show_pointer = true;  // the pen, the cloth point it would act on, the force it feels
};

class SceneRenderer {
 public:
  SceneRenderer() = default;
  ~SceneRenderer();
  // Creates the shaders and buffers; the context must be current. Returns false with a message when
  // the context cannot run them.
  bool initialize(QOpenGLExtraFunctions* gl, QString* error);
  // Frees the GPU resources (the context must be current).
  void release();
  // `peers`: a shared session's other users, drawn over the scene (null: none).
  void draw(const SceneFrame& frame, const OrbitCamera& camera, const DrawOptions& options, int width, int height,
            const PeerView* peers = nullptr, const Overlay* overlay = nullptr);
  // Edges and vertices drawn in the last frame, for the benchmark.
  std::size_t edges_drawn() const { return edges_drawn_; }

 private:
  struct GarmentGpu {
    std::shared_ptr<const GarmentTopology> topology;
    std::shared_ptr<const Texture> texture;
    std::uint64_t frame = 0;
    std::unique_ptr<QOpenGLVertexArrayObject> vao, edge_vao;
    QOpenGLBuffer positions{QOpenGLBuffer::VertexBuffer}, normals{QOpenGLBuffer::VertexBuffer},
        uvs{QOpenGLBuffer::VertexBuffer};
    QOpenGLBuffer triangles{QOpenGLBuffer::IndexBuffer}, edges{QOpenGLBuffer::IndexBuffer},
        points{QOpenGLBuffer::IndexBuffer}, local_edges{QOpenGLBuffer::IndexBuffer},
        local_points{QOpenGLBuffer::IndexBuffer}, leased{QOpenGLBuffer::IndexBuffer};
    std::unique_ptr<QOpenGLTexture> gl_texture;
    void destroy();
  };
  struct Solid {
    std::unique_ptr<QOpenGLVertexArrayObject> vao;
    QOpenGLBuffer positions{QOpenGLBuffer::VertexBuffer}, normals{QOpenGLBuffer::VertexBuffer};
    QOpenGLBuffer indices{QOpenGLBuffer::IndexBuffer};
    int count = 0;
    void destroy();
  };

  void upload_garment(GarmentGpu& gpu, const GarmentFrame& g, std::uint64_t frame_number);
  void upload_body(const Body& body);
  void make_solid(Solid& solid, const std::vector<float>& positions, const std::vector<float>& normals,
                  const std::vector<std::uint32_t>& indices);
  void draw_solid(const Solid& solid, const Eigen::Matrix4f& model, const Vec3& color, const Eigen::Matrix4f& vp,
                  const Eigen::Matrix4f& view);
  void draw_lines(const std::vector<float>& xyz, const Vec3& color, const Eigen::Matrix4f& vp, GLenum mode,
                  float point_size = 1, float alpha = 1);
  void draw_overlay(const Overlay& overlay, const Eigen::Matrix4f& vp);
  void draw_topology(GarmentGpu& gpu, const GarmentFrame& g, const DrawOptions& options, const Vec3* centre,
                     const Eigen::Matrix4f& vp);
  // The faces of garment `index` whose three vertices a peer leases, tinted in its colour.
  void draw_leases(GarmentGpu& gpu, const GarmentFrame& g, std::size_t index, const PeerView& peers,
                   const Eigen::Matrix4f& vp);
  void draw_peers(const PeerView& peers, const OrbitCamera& camera, const Eigen::Matrix4f& vp, const Eigen::Matrix4f& view);

  QOpenGLExtraFunctions* gl_ = nullptr;
  QOpenGLShaderProgram shaded_, flat_, thick_;
  bool thick_ready_ = false;
  int viewport_width_ = 1, viewport_height_ = 1;
  std::vector<std::unique_ptr<GarmentGpu>> garments_;
  std::uint64_t body_id_ = ~0ull;
  Solid body_, sphere_;
  std::unique_ptr<QOpenGLVertexArrayObject> lines_vao_;
  QOpenGLBuffer lines_{QOpenGLBuffer::VertexBuffer};
  std::vector<std::uint32_t> scratch_edges_, scratch_points_, scratch_leased_;
  std::vector<char> scratch_held_;
  std::size_t edges_drawn_ = 0;
  bool ready_ = false;
};

}  // namespace kiji::studio
