#include "scene_renderer.h"

#include <cmath>

namespace kiji::studio {

namespace {

const char* kShadedVertex = R"(#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in vec2 uv;
uniform mat4 model;
uniform mat4 view;
uniform mat4 view_projection;
out vec3 v_normal;
out vec2 v_uv;
out vec3 v_view;
void main() {
  vec4 world = model * vec4(position, 1.0);
  gl_Position = view_projection * world;
  v_normal = mat3(view) * mat3(model) * normal;
  v_uv = uv;
  v_view = (view * world).xyz;
}
)";

// Two-sided: cloth is seen from both sides. A headlight, so what the user looks at is lit, and a
// key light from above for shape.
const char* kShadedFragment = R"(#version 330 core
in vec3 v_normal;
in vec2 v_uv;
in vec3 v_view;
uniform vec3 color;
uniform bool use_texture;
uniform sampler2D tex;
uniform vec3 key;
out vec4 out_color;
void main() {
  vec3 n = normalize(v_normal);
  float head = abs(dot(n, normalize(-v_view)));
  float k = abs(dot(n, key));
  vec3 base = use_texture ? texture(tex, v_uv).rgb : color;
  out_color = vec4(base * (0.18 + 0.62 * head + 0.25 * k), 1.0);
}
)";

const char* kFlatVertex = R"(#version 330 core
layout(location = 0) in vec3 position;
uniform mat4 view_projection;
uniform float point_size;
void main() {
  gl_Position = view_projection * vec4(position, 1.0);
  gl_PointSize = point_size;
}
)";

const char* kFlatFragment = R"(#version 330 core
uniform vec3 color;
uniform float alpha;
out vec4 out_color;
void main() { out_color = vec4(color, alpha); }
)";

// Lines wider than a pixel, which a core profile need not draw: each segment becomes a quad facing
// the screen, `width` pixels across.
const char* kThickGeometry = R"(#version 330 core
layout(lines) in;
layout(triangle_strip, max_vertices = 4) out;
uniform vec2 viewport;
uniform float width;
void main() {
  vec4 a = gl_in[0].gl_Position, b = gl_in[1].gl_Position;
  if (a.w <= 0.0 || b.w <= 0.0) return;
  vec2 half_view = 0.5 * viewport;
  vec2 sa = a.xy / a.w * half_view, sb = b.xy / b.w * half_view;
  vec2 d = sb - sa;
  d = length(d) > 1e-6 ? normalize(d) : vec2(1.0, 0.0);
  vec2 n = vec2(-d.y, d.x) * 0.5 * width / half_view;
  gl_Position = a + vec4(n * a.w, 0.0, 0.0); EmitVertex();
  gl_Position = a - vec4(n * a.w, 0.0, 0.0); EmitVertex();
  gl_Position = b + vec4(n * b.w, 0.0, 0.0); EmitVertex();
  gl_Position = b - vec4(n * b.w, 0.0, 0.0); EmitVertex();
  EndPrimitive();
}
)";

void uniform(QOpenGLExtraFunctions* gl, QOpenGLShaderProgram& p, const char* name, const Eigen::Matrix4f& m) {
  gl->glUniformMatrix4fv(p.uniformLocation(name), 1, GL_FALSE, m.data());
}

void uniform(QOpenGLShaderProgram& p, const char* name, const Vec3& v) {
  p.setUniformValue(name, float(v.x()), float(v.y()), float(v.z()));
}

void fill(QOpenGLBuffer& b, const void* data, std::size_t bytes) {
  if (!b.isCreated()) b.create();
  b.bind();
  b.allocate(data, static_cast<int>(bytes));
}

template <typename T>
void fill(QOpenGLBuffer& b, const std::vector<T>& v) {
  fill(b, v.data(), v.size() * sizeof(T));
}

// A unit sphere: rings of latitude and longitude.
void sphere_mesh(std::vector<float>& p, std::vector<float>& n, std::vector<std::uint32_t>& idx) {
  const int rings = 10, segments = 16;
  for (int i = 0; i <= rings; ++i) {
    const double theta = M_PI * i / rings;
    for (int j = 0; j <= segments; ++j) {
      const double phi = 2 * M_PI * j / segments;
      const Vec3 v(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
      for (int k = 0; k < 3; ++k) {
        p.push_back(float(v[k]));
        n.push_back(float(v[k]));
      }
    }
  }
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const std::uint32_t a = i * (segments + 1) + j, b = a + segments + 1;
      idx.insert(idx.end(), {a, b, a + 1, a + 1, b, b + 1});
    }
}

Eigen::Matrix4f placed(const Vec3& at, double scale) {
  Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
  m.topLeftCorner<3, 3>() *= float(scale);
  m.block<3, 1>(0, 3) = at.cast<float>();
  return m;
}

}  // namespace

void SceneRenderer::GarmentGpu::destroy() {
  for (QOpenGLBuffer* b : {&positions, &normals, &uvs, &triangles, &edges, &points, &local_edges, &local_points, &leased})
    b->destroy();
  if (vao) vao->destroy();
  gl_texture.reset();
}

void SceneRenderer::Solid::destroy() {
  positions.destroy();
  normals.destroy();
  indices.destroy();
  if (vao) vao->destroy();
}

SceneRenderer::~SceneRenderer() = default;

bool SceneRenderer::initialize(QOpenGLExtraFunctions* gl, QString* error) {
  gl_ = gl;
  auto build = [&](QOpenGLShaderProgram& p, const char* vs, const char* fs) {
    if (!p.addShaderFromSourceCode(QOpenGLShader::Vertex, vs) || !p.addShaderFromSourceCode(QOpenGLShader::Fragment, fs) ||
        !p.link()) {
      if (error) *error = p.log();
      return false;
    }
    return true;
  };
  if (!build(shaded_, kShadedVertex, kShadedFragment) || !build(flat_, kFlatVertex, kFlatFragment)) return false;
  // Without the wide lines' program (no geometry shaders), lines are drawn a pixel wide.
  thick_ready_ = thick_.addShaderFromSourceCode(QOpenGLShader::Vertex, kFlatVertex) &&
                 thick_.addShaderFromSourceCode(QOpenGLShader::Geometry, kThickGeometry) &&
                 thick_.addShaderFromSourceCode(QOpenGLShader::Fragment, kFlatFragment) && thick_.link();
  std::vector<float> p, n;
  std::vector<std::uint32_t> idx;
  sphere_mesh(p, n, idx);
  make_solid(sphere_, p, n, idx);
  lines_vao_ = std::make_unique<QOpenGLVertexArrayObject>();
  lines_vao_->create();
  lines_vao_->bind();
  lines_.create();
  lines_.bind();
  gl_->glEnableVertexAttribArray(0);
  gl_->glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  lines_vao_->release();
  ready_ = true;
  return true;
}

void SceneRenderer::release() {
  for (auto& g : garments_) g->destroy();
  garments_.clear();
  body_.destroy();
  sphere_.destroy();
  lines_.destroy();
  if (lines_vao_) lines_vao_->destroy();
  body_id_ = ~0ull;
  ready_ = false;
}

void SceneRenderer::make_solid(Solid& s, const std::vector<float>& positions, const std::vector<float>& normals,
                               const std::vector<std::uint32_t>& indices) {
  if (!s.vao) {
    s.vao = std::make_unique<QOpenGLVertexArrayObject>();
    s.vao->create();
  }
  s.vao->bind();
  fill(s.positions, positions);
  gl_->glEnableVertexAttribArray(0);
  gl_->glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  fill(s.normals, normals);
  gl_->glEnableVertexAttribArray(1);
  gl_->glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  gl_->glDisableVertexAttribArray(2);
  gl_->glVertexAttrib2f(2, 0, 0);
  fill(s.indices, indices);
  s.vao->release();
  s.count = static_cast<int>(indices.size());
}

void SceneRenderer::upload_body(const Body& body) {
  std::vector<float> p, n(3 * body.vertices().size(), 0.0f);
  std::vector<Vec3> acc(body.vertices().size(), Vec3::Zero());
  std::vector<std::uint32_t> idx;
  for (const auto& t : body.triangles()) {
    const Vec3 a = body.vertices()[t[0]], b = body.vertices()[t[1]], c = body.vertices()[t[2]];
    const Vec3 fn = (b - a).cross(c - a);
    for (int k = 0; k < 3; ++k) {
      acc[t[k]] += fn;
      idx.push_back(static_cast<std::uint32_t>(t[k]));
    }
  }
  for (std::size_t i = 0; i < body.vertices().size(); ++i) {
    const Vec3 v = body.vertices()[i];
    const Vec3 nn = acc[i].norm() > 0 ? Vec3(acc[i].normalized()) : Vec3::UnitY();
    for (int k = 0; k < 3; ++k) {
      p.push_back(float(v[k]));
      n[3 * i + k] = float(nn[k]);
    }
  }
  make_solid(body_, p, n, idx);
}

void SceneRenderer::upload_garment(GarmentGpu& gpu, const GarmentFrame& g, std::uint64_t frame_number) {
  const bool new_topology = gpu.topology != g.topology;
  if (new_topology) {
    if (!gpu.vao) {
      gpu.vao = std::make_unique<QOpenGLVertexArrayObject>();
      gpu.vao->create();
    }
    gpu.vao->bind();
    fill(gpu.positions, g.positions);
    gl_->glEnableVertexAttribArray(0);
    gl_->glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
    fill(gpu.normals, g.normals);
    gl_->glEnableVertexAttribArray(1);
    gl_->glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
    fill(gpu.uvs, g.topology->uv);
    gl_->glEnableVertexAttribArray(2);
    gl_->glVertexAttribPointer(2, 2, GL_FLOAT, GL_FALSE, 0, nullptr);
    // Index buffers are filled with the VAO bound (core profile has no default one); the faces'
    // last, so that they stay the VAO's own.
    fill(gpu.edges, g.topology->edges);
    fill(gpu.points, g.topology->points);
    fill(gpu.triangles, g.topology->triangles);
    gpu.vao->release();
    gpu.topology = g.topology;
  } else if (gpu.frame != frame_number) {
    // Same size as before: overwrite in place.
    gpu.positions.bind();
    gpu.positions.write(0, g.positions.data(), static_cast<int>(g.positions.size() * sizeof(float)));
    gpu.normals.bind();
    gpu.normals.write(0, g.normals.data(), static_cast<int>(g.normals.size() * sizeof(float)));
  }
  gpu.frame = frame_number;
  if (gpu.texture != g.texture) {
    gpu.gl_texture.reset();
    if (g.texture && !g.texture->empty()) {
      // QOpenGLTexture uploads the image's first row at t = 0, as the texture's row 0 is v = 0.
      QImage image(g.texture->rgba.data(), g.texture->width, g.texture->height, QImage::Format_RGBA8888);
      gpu.gl_texture = std::make_unique<QOpenGLTexture>(image, QOpenGLTexture::GenerateMipMaps);
      gpu.gl_texture->setMinificationFilter(QOpenGLTexture::LinearMipMapLinear);
      gpu.gl_texture->setMagnificationFilter(QOpenGLTexture::Linear);
      gpu.gl_texture->setWrapMode(QOpenGLTexture::ClampToEdge);
    }
    gpu.texture = g.texture;
  }
}

void SceneRenderer::draw_solid(const Solid& s, const Eigen::Matrix4f& model, const Vec3& color, const Eigen::Matrix4f& vp,
                               const Eigen::Matrix4f& view) {
  shaded_.bind();
  uniform(gl_, shaded_, "model", model);
  uniform(gl_, shaded_, "view", view);
  uniform(gl_, shaded_, "view_projection", vp);
  uniform(shaded_, "color", color);
  shaded_.setUniformValue("use_texture", false);
  s.vao->bind();
  gl_->glDrawElements(GL_TRIANGLES, s.count, GL_UNSIGNED_INT, nullptr);
  s.vao->release();
}

void SceneRenderer::draw_lines(const std::vector<float>& xyz, const Vec3& color, const Eigen::Matrix4f& vp, GLenum mode,
                               float point_size, float alpha) {
  if (xyz.empty()) return;
  const bool thick = thick_ready_ && mode != GL_POINTS && point_size > 1;
  QOpenGLShaderProgram& p = thick ? thick_ : flat_;
  p.bind();
  uniform(gl_, p, "view_projection", vp);
  uniform(p, "color", color);
  p.setUniformValue("alpha", alpha);
  p.setUniformValue("point_size", point_size);
  if (thick) {
    p.setUniformValue("viewport", float(viewport_width_), float(viewport_height_));
    p.setUniformValue("width", point_size);
  }
  lines_vao_->bind();
  lines_.bind();
  lines_.allocate(xyz.data(), static_cast<int>(xyz.size() * sizeof(float)));
  gl_->glDrawArrays(mode, 0, static_cast<GLsizei>(xyz.size() / 3));
  lines_vao_->release();
}

void SceneRenderer::draw_topology(GarmentGpu& gpu, const GarmentFrame& g, const DrawOptions& options, const Vec3* centre,
                                  const Eigen::Matrix4f& vp) {
  if (options.edges == EdgeDisplay::None) return;
  const GarmentTopology& t = *g.topology;
  gpu.vao->bind();
  QOpenGLBuffer* edges = &gpu.edges;
  QOpenGLBuffer* points = &gpu.points;
  std::size_t edge_count = t.edges.size(), point_count = t.points.size();
  if (options.edges == EdgeDisplay::Local) {
    if (!centre) {
      gpu.vao->release();
      return;
    }
    const float cx = float(centre->x()), cy = float(centre->y()), cz = float(centre->z());
    const float r2 = float(options.local_radius * options.local_radius);
    const float* p = g.positions.data();
    auto near = [&](std::uint32_t i) {
      const float dx = p[3 * i] - cx, dy = p[3 * i + 1] - cy, dz = p[3 * i + 2] - cz;
      return dx * dx + dy * dy + dz * dz <= r2;
    };
    scratch_edges_.clear();
    scratch_points_.clear();
    for (std::size_t e = 0; e + 1 < t.edges.size(); e += 2)
      if (near(t.edges[e]) && near(t.edges[e + 1])) scratch_edges_.insert(scratch_edges_.end(), {t.edges[e], t.edges[e + 1]});
    for (std::uint32_t v : t.points)
      if (near(v)) scratch_points_.push_back(v);
    fill(gpu.local_edges, scratch_edges_);
    fill(gpu.local_points, scratch_points_);
    edges = &gpu.local_edges;
    points = &gpu.local_points;
    edge_count = scratch_edges_.size();
    point_count = scratch_points_.size();
  }
  if (edge_count > 0 || point_count > 0) {
  flat_.bind();
  uniform(gl_, flat_, "view_projection", vp);
  flat_.setUniformValue("alpha", 1.0f);
  uniform(flat_, "color", Vec3(0.12, 0.12, 0.16));
  flat_.setUniformValue("point_size", 1.0f);
  edges->bind();
  gl_->glDrawElements(GL_LINES, static_cast<GLsizei>(edge_count), GL_UNSIGNED_INT, nullptr);
  uniform(flat_, "color", Vec3(0.95, 0.95, 0.3));
  flat_.setUniformValue("point_size", 3.0f);
  points->bind();
  gl_->glDrawElements(GL_POINTS, static_cast<GLsizei>(point_count), GL_UNSIGNED_INT, nullptr);
  edges_drawn_ += edge_count / 2;
  }
  // The VAO's own index buffer back for the next draw of its faces.
  gpu.triangles.bind();
  gpu.vao->release();
}

void SceneRenderer::draw_leases(GarmentGpu& gpu, const GarmentFrame& g, std::size_t index, const PeerView& peers,
                                const Eigen::Matrix4f& vp) {
  const GarmentTopology& t = *g.topology;
  bool any = false;
  for (const LeaseInfo& lease : peers.leases) {
    if (lease.garment != index || lease.vertices.empty()) continue;
    // A mesh vertex index may be past the drawn ones (the lease is a few steps older than the frame).
    std::uint32_t top = 0;
    for (std::uint32_t m : t.mesh_vertex) top = std::max(top, m);
    scratch_held_.assign(std::size_t(top) + 1, 0);
    for (std::uint32_t v : lease.vertices)
      if (v <= top) scratch_held_[v] = 1;
    scratch_leased_.clear();
    for (std::size_t i = 0; i + 2 < t.triangles.size(); i += 3) {
      const std::uint32_t a = t.triangles[i], b = t.triangles[i + 1], c = t.triangles[i + 2];
      if (scratch_held_[t.mesh_vertex[a]] && scratch_held_[t.mesh_vertex[b]] && scratch_held_[t.mesh_vertex[c]])
        scratch_leased_.insert(scratch_leased_.end(), {a, b, c});
    }
    if (scratch_leased_.empty()) continue;
    if (!any) {
      any = true;
      gpu.vao->bind();
      flat_.bind();
      uniform(gl_, flat_, "view_projection", vp);
      flat_.setUniformValue("point_size", 1.0f);
      gl_->glEnable(GL_BLEND);
      gl_->glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    }
    uniform(flat_, "color", peers.colour_of(lease.holder));
    flat_.setUniformValue("alpha", 0.55f);
    fill(gpu.leased, scratch_leased_);
    gl_->glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(scratch_leased_.size()), GL_UNSIGNED_INT, nullptr);
  }
  if (!any) return;
  gl_->glDisable(GL_BLEND);
  gpu.triangles.bind();  // the VAO's own index buffer back
  gpu.vao->release();
}

void SceneRenderer::draw_peers(const PeerView& peers, const OrbitCamera& camera, const Eigen::Matrix4f& vp,
                               const Eigen::Matrix4f& view) {
  // Over everything: another user's pen behind the body is still where they point.
  gl_->glDisable(GL_DEPTH_TEST);
  const double size = std::max(0.006, 0.012 * camera.distance / 3.0);
  for (const PeerRow& p : peers.peers) {
    if (p.self || !p.present || !p.has_presence) continue;
    const PeerPresence& at = p.presence;
    if (at.eye != at.target) {
      // The viewpoint: a small camera at the eye, and its line of sight to what it looks at.
      draw_solid(sphere_, placed(at.eye, 0.8 * size), p.colour, vp, view);
      draw_lines({float(at.eye.x()), float(at.eye.y()), float(at.eye.z()), float(at.target.x()), float(at.target.y()),
                  float(at.target.z())},
                 p.colour, vp, GL_LINES);
      draw_lines({float(at.target.x()), float(at.target.y()), float(at.target.z())}, p.colour, vp, GL_POINTS, 7);
    }
    if (at.pointer != Vec3::Zero()) {
      draw_solid(sphere_, placed(at.pointer, size), p.colour, vp, view);
      const Vec3 axis = at.orientation * Vec3::UnitZ();
      const Vec3 end = at.pointer + 8 * size * axis;
      draw_lines({float(at.pointer.x()), float(at.pointer.y()), float(at.pointer.z()), float(end.x()), float(end.y()),
                  float(end.z())},
                 p.colour, vp, GL_LINES);
    }
  }
  gl_->glEnable(GL_DEPTH_TEST);
}

void SceneRenderer::draw_overlay(const Overlay& overlay, const Eigen::Matrix4f& vp) {
  gl_->glEnable(GL_BLEND);
  gl_->glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  for (const OverlayTint& t : overlay.tints) {
    if (t.garment >= garments_.size() || t.triangles.empty() || !garments_[t.garment]->vao) continue;
    GarmentGpu& gpu = *garments_[t.garment];
    gpu.vao->bind();
    flat_.bind();
    uniform(gl_, flat_, "view_projection", vp);
    flat_.setUniformValue("point_size", 1.0f);
    uniform(flat_, "color", t.colour);
    flat_.setUniformValue("alpha", t.alpha);
    fill(gpu.leased, t.triangles);
    gl_->glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(t.triangles.size()), GL_UNSIGNED_INT, nullptr);
    gpu.triangles.bind();  // the VAO's own index buffer back
    gpu.vao->release();
  }
  for (const OverlayLines& l : overlay.lines) {
    if (l.on_top) gl_->glDisable(GL_DEPTH_TEST);
    draw_lines(l.xyz, l.colour, vp, l.mode, l.size, l.alpha);
    if (l.on_top) gl_->glEnable(GL_DEPTH_TEST);
  }
  gl_->glDisable(GL_BLEND);
}

void SceneRenderer::draw(const SceneFrame& frame, const OrbitCamera& camera, const DrawOptions& options, int width,
                         int height, const PeerView* peers, const Overlay* overlay) {
  if (!ready_ || width <= 0 || height <= 0) return;
  edges_drawn_ = 0;
  viewport_width_ = width;
  viewport_height_ = height;
  const double aspect = double(width) / double(height);
  const Eigen::Matrix4f view = camera.view();
  const Eigen::Matrix4f vp = camera.projection(aspect) * view;
  gl_->glViewport(0, 0, width, height);
  gl_->glClearColor(0.93f, 0.93f, 0.95f, 1.0f);
  gl_->glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  gl_->glEnable(GL_DEPTH_TEST);
  gl_->glDepthFunc(GL_LEQUAL);
  gl_->glEnable(GL_PROGRAM_POINT_SIZE);
  gl_->glDisable(GL_CULL_FACE);

  shaded_.bind();
  const Vec3 key = (view.topLeftCorner<3, 3>().cast<double>() * Vec3(0.3, 1.0, 0.4)).normalized();
  uniform(shaded_, "key", key);
  shaded_.setUniformValue("tex", 0);

  if (options.show_floor) {
    std::vector<float> grid;
    for (int i = -8; i <= 8; ++i) {
      const float a = 0.25f * i;
      grid.insert(grid.end(), {a, 0, -2, a, 0, 2, -2, 0, a, 2, 0, a});
    }
    draw_lines(grid, Vec3(0.78, 0.78, 0.82), vp, GL_LINES);
  }

  if (frame.body && options.show_body) {
    if (frame.body->geometry_id() != body_id_) {
      upload_body(*frame.body);
      body_id_ = frame.body->geometry_id();
    }
    draw_solid(body_, Eigen::Matrix4f::Identity(), Vec3(0.72, 0.70, 0.68), vp, view);
  }

  // The point the topology is drawn around: the cloth the pointer would act on, else the pointer.
  const Vec3* centre = nullptr;
  Vec3 around;
  if (frame.has_pointer && options.show_pointer) {
    around = frame.hit.hit ? frame.hit.point : frame.pointer.position;
    centre = &around;
  }

  while (garments_.size() > frame.garments.size()) {
    garments_.back()->destroy();
    garments_.pop_back();
  }
  while (garments_.size() < frame.garments.size()) garments_.push_back(std::make_unique<GarmentGpu>());
  // Faces pushed back a little in depth, so that edges drawn on them are not hidden.
  gl_->glEnable(GL_POLYGON_OFFSET_FILL);
  gl_->glPolygonOffset(1.0f, 1.0f);
  for (std::size_t i = 0; i < frame.garments.size(); ++i) {
    const GarmentFrame& g = frame.garments[i];
    GarmentGpu& gpu = *garments_[i];
    if (!g.topology || g.topology->triangles.empty()) continue;
    upload_garment(gpu, g, frame.number);
    shaded_.bind();
    uniform(gl_, shaded_, "model", Eigen::Matrix4f::Identity());
    uniform(gl_, shaded_, "view", view);
    uniform(gl_, shaded_, "view_projection", vp);
    uniform(shaded_, "color", g.color);
    const bool textured = gpu.gl_texture != nullptr;
    shaded_.setUniformValue("use_texture", textured);
    if (textured) gpu.gl_texture->bind(0);
    gpu.vao->bind();
    gl_->glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(g.topology->triangles.size()), GL_UNSIGNED_INT, nullptr);
    gpu.vao->release();
    if (textured) gpu.gl_texture->release(0);
  }
  gl_->glDisable(GL_POLYGON_OFFSET_FILL);
  if (peers)
    for (std::size_t i = 0; i < frame.garments.size(); ++i)
      if (frame.garments[i].topology && !frame.garments[i].topology->triangles.empty())
        draw_leases(*garments_[i], frame.garments[i], i, *peers, vp);
  for (std::size_t i = 0; i < frame.garments.size(); ++i)
    if (frame.garments[i].topology && !frame.garments[i].topology->triangles.empty())
      draw_topology(*garments_[i], frame.garments[i], options, centre, vp);

  if (frame.has_pointer && options.show_pointer) {
    const double size = std::max(0.004, 0.008 * camera.distance / 3.0);
    const Vec3 tip = frame.pointer.position;
    const Vec3 pen_colour = frame.stroke_active ? Vec3(0.9, 0.35, 0.1) : Vec3(0.15, 0.35, 0.85);
    draw_solid(sphere_, placed(tip, size), pen_colour, vp, view);
    // The pen's body: from the tip back along its axis (the device's +Z, towards the user).
    const Vec3 axis = frame.pointer.orientation * Vec3::UnitZ();
    const Vec3 back = frame.pointer.ray.squaredNorm() > 0 ? Vec3(-frame.pointer.ray.normalized()) : axis;
    const Vec3 end = tip + 12 * size * back;
    draw_lines({float(tip.x()), float(tip.y()), float(tip.z()), float(end.x()), float(end.y()), float(end.z())},
               pen_colour, vp, GL_LINES);
    if (frame.hit.hit) {
      draw_solid(sphere_, placed(frame.hit.point, 0.6 * size), Vec3(1.0, 0.85, 0.1), vp, view);
      const Vec3 h = frame.hit.point;
      draw_lines({float(tip.x()), float(tip.y()), float(tip.z()), float(h.x()), float(h.y()), float(h.z())},
                 Vec3(1.0, 0.85, 0.1), vp, GL_LINES);
    }
    if (frame.force.norm() > 1e-4) {
      // The force on the hand, 5 cm a newton at the camera's usual distance.
      const Vec3 f_end = tip + frame.force * (0.05 * camera.distance / 3.0);
      draw_lines({float(tip.x()), float(tip.y()), float(tip.z()), float(f_end.x()), float(f_end.y()), float(f_end.z())},
                 Vec3(0.85, 0.1, 0.1), vp, GL_LINES);
    }
  }
  if (overlay) draw_overlay(*overlay, vp);
  if (peers) draw_peers(*peers, camera, vp, view);
}

}  // namespace kiji::studio
