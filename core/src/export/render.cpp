// The software rasteriser behind render(): perspective camera, z-buffer, smooth normals, a light
// at the camera with an ambient term, perspective-correct uv for textures.
#include "kiji/render.h"

#include "kiji/error.h"
#include "base/parallel.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <mutex>
#include <optional>
#include <sstream>
#include <vector>

namespace kiji {

namespace {

constexpr float kAmbient = 0.25f;
constexpr float kDiffuse = 0.75f;  // ambient + diffuse = 1: a surface facing the camera shows its colour
constexpr float kNear = 1e-3f;
const Vec3 kBodyColor{0.42, 0.42, 0.42};

using V2 = Eigen::Vector2f;
using V3 = Eigen::Vector3f;

float srgb_to_linear(float c) { return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f); }
float linear_to_srgb(float c) {
  c = std::clamp(c, 0.0f, 1.0f);
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

struct ColorTables {
  std::array<float, 256> to_linear;
  std::array<std::uint8_t, 4097> to_srgb;
  ColorTables() {
    for (int i = 0; i < 256; ++i) to_linear[i] = srgb_to_linear(i / 255.0f);
    for (int i = 0; i <= 4096; ++i)
      to_srgb[i] = static_cast<std::uint8_t>(std::lround(255.0f * linear_to_srgb(i / 4096.0f)));
  }
  std::uint8_t encode(float linear) const {
    return to_srgb[static_cast<int>(std::clamp(linear, 0.0f, 1.0f) * 4096.0f + 0.5f)];
  }
};
const ColorTables& tables() {
  static const ColorTables t;
  return t;
}

// A corner ready for the rasteriser: camera-space position and normal, its uv, and where it falls
// on the screen.
struct Corner {
  V3 p;  // camera space: x right, y up, z forward (depth)
  V3 n;
  V2 uv;
  V3 s;  // pixel x, pixel y, 1 / depth (for corners in front of the near plane)
};

struct View {
  V3 eye, right, up, forward;
  float focal = 1, cx = 0, cy = 0;
  V3 to_camera(const Vec3& w) const {
    const V3 d = w.cast<float>() - eye;
    return {d.dot(right), d.dot(up), d.dot(forward)};
  }
  V3 to_screen(const V3& p) const {
    const float iz = 1.0f / p.z();
    return {cx + focal * p.x() * iz, cy - focal * p.y() * iz, iz};
  }
  V3 dir_to_camera(const Vec3& w) const {
    const V3 d = w.cast<float>();
    return {d.dot(right), d.dot(up), d.dot(forward)};
  }
};

struct Surface {
  const Texture* texture = nullptr;  // null: plain colour
  V3 color;                          // linear
};

class Raster {
 public:
  Raster(int width, int height, const View& view)
      : w_(width), h_(height), view_(view),
        depth_(static_cast<std::size_t>(width) * height, 0.0f),
        color_(static_cast<std::size_t>(width) * height * 3, 0.0f),
        covered_(static_cast<std::size_t>(width) * height, 0) {}

  // Clips the triangle against the near plane (a fan of at most two triangles), then fills its
  // pixels in rows [row0, row1): threads drawing disjoint bands of rows share the raster.
  void triangle(const Corner& a, const Corner& b, const Corner& c, const Surface& s, int row0, int row1) {
    if (a.p.z() >= kNear && b.p.z() >= kNear && c.p.z() >= kNear) return fill(a, b, c, s, row0, row1);
    const Corner in[3] = {a, b, c};
    Corner out[4];
    int n = 0;
    for (int i = 0; i < 3; ++i) {
      const Corner& p = in[i];
      const Corner& q = in[(i + 1) % 3];
      const bool p_in = p.p.z() >= kNear, q_in = q.p.z() >= kNear;
      if (p_in) out[n++] = p;
      if (p_in != q_in) {
        const float t = (kNear - p.p.z()) / (q.p.z() - p.p.z());
        const V3 at = p.p + t * (q.p - p.p);
        out[n++] = Corner{at, p.n + t * (q.n - p.n), p.uv + t * (q.uv - p.uv), view_.to_screen(at)};
      }
    }
    for (int i = 1; i + 1 < n; ++i) fill(out[0], out[i], out[i + 1], s, row0, row1);
  }

  int height() const { return h_; }
  int width() const { return w_; }
  // The depth of the nearest surface drawn at a pixel (infinity where nothing is).
  float depth_at(int x, int y) const {
    const float z_inv = depth_[static_cast<std::size_t>(y) * w_ + x];
    return z_inv > 0 ? 1.0f / z_inv : std::numeric_limits<float>::infinity();
  }

  Image finish() const {
    Image img;
    img.width = w_;
    img.height = h_;
    img.rgba.resize(static_cast<std::size_t>(w_) * h_ * 4);
    const ColorTables& ct = tables();
    parallel::for_range(h_, 32, [&](int y0, int y1) {
      for (int y = y0; y < y1; ++y) {
        // A light neutral gradient, lighter at the top, so any surface stands out against it.
        const float t = static_cast<float>(y) / std::max(1, h_ - 1);
        const std::uint8_t bg = static_cast<std::uint8_t>(std::lround(238 - 38 * t));
        for (int x = 0; x < w_; ++x) {
          const std::size_t i = static_cast<std::size_t>(y) * w_ + x;
          std::uint8_t* p = &img.rgba[4 * i];
          if (covered_[i]) {
            for (int k = 0; k < 3; ++k) p[k] = ct.encode(color_[3 * i + k]);
          } else {
            p[0] = p[1] = bg;
            p[2] = static_cast<std::uint8_t>(std::min(255, bg + 4));
          }
          p[3] = 255;
        }
      }
    });
    return img;
  }

 private:
  V3 sample(const Texture& t, V2 uv) const {
    // Bilinear, clamped at the edges; texture row 0 is v = 0.
    const float fx = std::clamp(uv.x(), 0.0f, 1.0f) * t.width - 0.5f;
    const float fy = std::clamp(uv.y(), 0.0f, 1.0f) * t.height - 0.5f;
    const int x0 = std::clamp(static_cast<int>(std::floor(fx)), 0, t.width - 1);
    const int y0 = std::clamp(static_cast<int>(std::floor(fy)), 0, t.height - 1);
    const int x1 = std::min(x0 + 1, t.width - 1), y1 = std::min(y0 + 1, t.height - 1);
    const float ax = std::clamp(fx - x0, 0.0f, 1.0f), ay = std::clamp(fy - y0, 0.0f, 1.0f);
    const auto& lin = tables().to_linear;
    V3 c = V3::Zero();
    const int xs[2] = {x0, x1}, ys[2] = {y0, y1};
    const float wx[2] = {1 - ax, ax}, wy[2] = {1 - ay, ay};
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) {
        const std::uint8_t* p = t.texel(xs[i], ys[j]);
        c += wx[i] * wy[j] * V3(lin[p[0]], lin[p[1]], lin[p[2]]);
      }
    return c;
  }

  void fill(const Corner& a, const Corner& b, const Corner& c, const Surface& s, int row0, int row1) {
    const Corner* v[3] = {&a, &b, &c};
    float sx[3], sy[3], iz[3];
    for (int i = 0; i < 3; ++i) {
      sx[i] = v[i]->s.x();
      sy[i] = v[i]->s.y();
      iz[i] = v[i]->s.z();
      if (!std::isfinite(sx[i]) || !std::isfinite(sy[i])) return;
    }
    const float area = (sx[1] - sx[0]) * (sy[2] - sy[0]) - (sx[2] - sx[0]) * (sy[1] - sy[0]);
    if (!(std::abs(area) > 1e-12f)) return;
    const float inv_area = 1.0f / area;
    // The pixels whose centre (x + 0.5, y + 0.5) is within the triangle's box: most triangles of a
    // fine cloth are smaller than a pixel, and cover the centre of one or none.
    const int x_min = std::max(0, static_cast<int>(std::ceil(std::min({sx[0], sx[1], sx[2]}) - 0.5f)));
    const int x_max = std::min(w_ - 1, static_cast<int>(std::floor(std::max({sx[0], sx[1], sx[2]}) - 0.5f)));
    const int y_min = std::max(row0, static_cast<int>(std::ceil(std::min({sy[0], sy[1], sy[2]}) - 0.5f)));
    const int y_max = std::min(row1 - 1, static_cast<int>(std::floor(std::max({sy[0], sy[1], sy[2]}) - 0.5f)));
    if (x_min > x_max || y_min > y_max) return;

    // Attributes divided by depth interpolate linearly on screen (perspective-correct).
    V3 n_z[3];
    V2 uv_z[3];
    for (int i = 0; i < 3; ++i) {
      n_z[i] = v[i]->n * iz[i];
      uv_z[i] = v[i]->uv * iz[i];
    }
    for (int y = y_min; y <= y_max; ++y) {
      const float py = y + 0.5f;
      for (int x = x_min; x <= x_max; ++x) {
        const float px = x + 0.5f;
        // Barycentric weights from the edge functions; the sign of `area` covers either winding.
        const float b0 = ((sx[1] - px) * (sy[2] - py) - (sx[2] - px) * (sy[1] - py)) * inv_area;
        const float b1 = ((sx[2] - px) * (sy[0] - py) - (sx[0] - px) * (sy[2] - py)) * inv_area;
        const float b2 = 1.0f - b0 - b1;
        if (b0 < 0 || b1 < 0 || b2 < 0) continue;
        const float z_inv = b0 * iz[0] + b1 * iz[1] + b2 * iz[2];
        const std::size_t i = static_cast<std::size_t>(y) * w_ + x;
        if (z_inv <= depth_[i]) continue;
        depth_[i] = z_inv;
        covered_[i] = 1;
        const float z = 1.0f / z_inv;
        V3 n = (b0 * n_z[0] + b1 * n_z[1] + b2 * n_z[2]) * z;
        const float nn = n.norm();
        // The light sits at the camera: Lambert against the direction back along the pixel's ray.
        const V3 ray((px - view_.cx) / view_.focal, -(py - view_.cy) / view_.focal, 1.0f);
        const float lambert = nn > 0 ? std::abs(n.dot(ray)) / (nn * ray.norm()) : 1.0f;  // cloth: both sides
        V3 albedo = s.color;
        if (s.texture) albedo = sample(*s.texture, (b0 * uv_z[0] + b1 * uv_z[1] + b2 * uv_z[2]) * z);
        const V3 c = albedo * (kAmbient + kDiffuse * lambert);
        color_[3 * i] = c.x();
        color_[3 * i + 1] = c.y();
        color_[3 * i + 2] = c.z();
      }
    }
  }

  int w_, h_;
  View view_;
  std::vector<float> depth_;  // 1 / depth; 0 = nothing drawn
  std::vector<float> color_;  // linear RGB
  std::vector<std::uint8_t> covered_;
};

View make_view(const Camera& cam, int width, int height) {
  if (!all_finite(cam.eye) || !all_finite(cam.target) || !all_finite(cam.up))
    throw InputError("camera has a non-finite eye, target or up: set finite coordinates");
  if (!(cam.fov_degrees > 0 && cam.fov_degrees < 179)) {
    std::ostringstream m;
    m << "camera field of view " << cam.fov_degrees << " degrees is out of range: use 1 to 179";
    throw InputError(m.str());
  }
  const Vec3 f = cam.target - cam.eye;
  if (!(f.norm() > 0)) throw InputError("camera eye and target are the same point: move the eye back");
  View v;
  const Vec3 forward = f.normalized();
  Vec3 right = forward.cross(cam.up);
  if (right.norm() < 1e-9 * std::max(1.0, cam.up.norm())) {
    // Looking straight along `up`: any perpendicular will do.
    right = forward.cross(std::abs(forward.y()) < 0.9 ? Vec3::UnitY() : Vec3::UnitZ());
  }
  right.normalize();
  const Vec3 up = right.cross(forward);
  v.eye = cam.eye.cast<float>();
  v.forward = forward.cast<float>();
  v.right = right.cast<float>();
  v.up = up.cast<float>();
  v.focal = static_cast<float>(0.5 * height / std::tan(0.5 * cam.fov_degrees * M_PI / 180.0));
  v.cx = 0.5f * width;
  v.cy = 0.5f * height;
  return v;
}

// Triangles to draw into a raster, in drawing order, each with the bands of rows it reaches. The
// image is drawn in bands, in parallel: each triangle in the bands its rows reach, in drawing order
// within each, which gives the same picture as drawing all of it in one, whatever the band count.
class Batch {
 public:
  explicit Batch(int height) : height_(height), bands_(std::min({height, 4 * parallel::thread_count(), 128})) {
    band_of_row_.resize(height);
    for (int y = 0; y < height; ++y) band_of_row_[y] = static_cast<std::uint8_t>(std::int64_t(y) * bands_ / height);
  }

  void add_body(const Body& body, const View& view) {
    const auto& vs = body.vertices();
    const auto& ts = body.triangles();
    const int nv = static_cast<int>(vs.size()), nt = static_cast<int>(ts.size());
    Part& part = new_part(nv, nt);
    // Vertex normals: the faces' (area-weighted) summed in triangle order, as one thread would.
    std::vector<Vec3> fn(nt), n(nv, Vec3::Zero());
    parallel::for_range(nt, kGrain, [&](int b0, int b1) {
      for (int t = b0; t < b1; ++t) fn[t] = (vs[ts[t][1]] - vs[ts[t][0]]).cross(vs[ts[t][2]] - vs[ts[t][0]]);
    });
    for (int t = 0; t < nt; ++t)
      for (int k = 0; k < 3; ++k) n[ts[t][k]] += fn[t];
    parallel::for_range(nv, kGrain, [&](int b0, int b1) {
      for (int i = b0; i < b1; ++i) {
        part.p[i] = view.to_camera(vs[i]);
        part.n[i] = view.dir_to_camera(n[i]);
        part.s[i] = view.to_screen(part.p[i]);
      }
    });
    part.surface = Surface{nullptr, kBodyColor.cast<float>()};
    const int id = static_cast<int>(parts_.size()) - 1;
    const std::size_t first = tris_.size() - nt;
    parallel::for_range(nt, kGrain, [&](int b0, int b1) {
      for (int t = b0; t < b1; ++t) add(part, {id, {ts[t][0], ts[t][1], ts[t][2]}, {-1, -1, -1}}, first + t);
    });
  }

  void add_garment(const Garment& g, const View& view) {
    const Mesh& m = g.mesh();
    const int nv = static_cast<int>(g.vertex_capacity());
    const int nf = static_cast<int>(m.number_of_faces() + m.number_of_removed_faces());
    Part& part = new_part(nv, nf);
    parallel::for_range(nv, kGrain, [&](int b0, int b1) {
      for (int i = b0; i < b1; ++i) {
        const Vertex v(i);
        if (m.is_removed(v)) continue;
        part.p[i] = view.to_camera(g.position(v));
        part.s[i] = view.to_screen(part.p[i]);
      }
    });
    // Each face's corners, normal and bands (in parallel); the vertex normals summed in face order.
    std::vector<Tri> ft(nf);
    std::vector<Vec3> fn(nf);
    std::vector<unsigned char> is_tri(nf, 0);
    const int id = static_cast<int>(parts_.size()) - 1;
    const std::size_t first = tris_.size() - nf;
    parallel::for_range(nf, kGrain, [&](int b0, int b1) {
      for (int f = b0; f < b1; ++f) {
        const Face face(f);
        if (m.is_removed(face)) continue;
        Tri t{id, {}, {}};
        int k = 0;
        for (Halfedge h : CGAL::halfedges_around_face(m.halfedge(face), m)) {
          if (k == 3) break;
          t.v[k] = static_cast<int>(m.target(h).idx());
          t.h[k++] = static_cast<int>(h.idx());
        }
        if (k != 3) continue;
        const Vec3 a = g.position(Vertex(t.v[0])), b = g.position(Vertex(t.v[1])), c = g.position(Vertex(t.v[2]));
        fn[f] = (b - a).cross(c - a);
        ft[f] = t;
        is_tri[f] = 1;
        add(part, t, first + f);  // needs the corners on the screen only, not the normals
      }
    });
    std::vector<Vec3> n(nv, Vec3::Zero());
    for (int f = 0; f < nf; ++f)
      if (is_tri[f])
        for (int q = 0; q < 3; ++q) n[ft[f].v[q]] += fn[f];
    parallel::for_range(nv, kGrain, [&](int b0, int b1) {
      for (int i = b0; i < b1; ++i)
        if (!m.is_removed(Vertex(i))) part.n[i] = view.dir_to_camera(n[i]);
    });
    const bool textured = !g.texture().empty() &&
                          g.texture().rgba.size() == static_cast<std::size_t>(g.texture().width) * g.texture().height * 4;
    part.surface = Surface{textured ? &g.texture() : nullptr, g.color.cast<float>()};
    if (textured) part.garment = &g;
  }

  void draw(Raster& raster) const {
    // Each band's triangles, in drawing order: most triangles of a fine cloth reach none.
    std::vector<std::vector<int>> in_band(bands_);
    for (std::size_t t = 0; t < tris_.size(); ++t)
      for (int b = reach_[t][0]; b <= reach_[t][1]; ++b) in_band[b].push_back(static_cast<int>(t));
    parallel::for_range(bands_, 1, [&](int b0, int b1) {
      for (int b = b0; b < b1; ++b) {
        const int row0 = static_cast<int>((std::int64_t(b) * height_ + bands_ - 1) / bands_);
        const int row1 = static_cast<int>((std::int64_t(b + 1) * height_ + bands_ - 1) / bands_);
        for (const int t : in_band[b]) {
          const Tri& tri = tris_[t];
          const Part& part = parts_[tri.part];
          Corner c[3];
          for (int k = 0; k < 3; ++k) {
            const V2 uv = part.garment ? V2(part.garment->uv(Halfedge(tri.h[k])).cast<float>()) : V2::Zero();
            c[k] = Corner{part.p[tri.v[k]], part.n[tri.v[k]], uv, part.s[tri.v[k]]};
          }
          raster.triangle(c[0], c[1], c[2], part.surface, row0, row1);
        }
      }
    });
  }

 private:
  static constexpr int kGrain = 4096;
  struct Part {
    std::vector<V3> p, n, s;           // a vertex's position, normal and screen point
    const Garment* garment = nullptr;  // its uv (by halfedge), if it has a texture
    Surface surface;
  };
  struct Tri {
    int part;
    int v[3];
    int h[3];  // halfedges, for the uv
  };

  // A part of nv vertices with `slots` triangle slots after the others' (the body's in triangle
  // order, a garment's in face index order); a slot that is not drawn (off the screen, removed,
  // not a triangle) reaches no band.
  Part& new_part(int nv, int slots) {
    parts_.emplace_back();
    Part& part = parts_.back();
    part.p.resize(nv);
    part.n.resize(nv);
    part.s.resize(nv);
    tris_.resize(tris_.size() + slots);
    reach_.resize(reach_.size() + slots, kNone);
    return part;
  }

  void add(const Part& part, const Tri& t, std::size_t slot) {
    float lo = std::numeric_limits<float>::max(), hi = -lo, left = lo, right = -lo;
    bool all_in_front = true;
    for (int k = 0; k < 3; ++k) {
      if (!(part.p[t.v[k]].z() >= kNear)) all_in_front = false;
      lo = std::min(lo, part.s[t.v[k]].y());
      hi = std::max(hi, part.s[t.v[k]].y());
      left = std::min(left, part.s[t.v[k]].x());
      right = std::max(right, part.s[t.v[k]].x());
    }
    std::array<std::uint8_t, 2> r{0, static_cast<std::uint8_t>(bands_ - 1)};  // clipped at the near plane: all
    if (all_in_front) {
      if (!(hi >= 0 && lo <= height_)) return;  // off the screen, or not finite
      // No pixel's centre within its box (most triangles of a fine cloth): it covers none.
      if (std::ceil(lo - 0.5f) > std::floor(hi - 0.5f) || std::ceil(left - 0.5f) > std::floor(right - 0.5f)) return;
      r[0] = band_of_row_[std::clamp(static_cast<int>(std::floor(lo)) - 1, 0, height_ - 1)];
      r[1] = band_of_row_[std::clamp(static_cast<int>(std::ceil(hi)) + 1, 0, height_ - 1)];
    }
    tris_[slot] = t;
    reach_[slot] = r;
  }

  static constexpr std::array<std::uint8_t, 2> kNone{1, 0};  // first > last: no band
  int height_, bands_;
  std::vector<std::uint8_t> band_of_row_;
  std::deque<Part> parts_;  // stable addresses while parts are added
  std::vector<Tri> tris_;
  std::vector<std::array<std::uint8_t, 2>> reach_;
};

// What the body alone draws in a view: a body does not move, so while the camera and the image size
// stay the same (a session's frames), the next frame starts from a copy of it. One layer is kept,
// for the body drawn last, and only for images of up to 2.5 million pixels (17 bytes a pixel).
struct BodyLayer {
  std::uint64_t body = 0;
  Camera camera;
  int width = 0, height = 0;
  std::optional<Raster> raster;
};

bool same_camera(const Camera& a, const Camera& b) {
  return a.eye == b.eye && a.target == b.target && a.up == b.up && a.fov_degrees == b.fov_degrees;
}

Raster body_layer(const Body& body, const Camera& camera, const View& view, int width, int height) {
  static std::mutex mutex;
  static BodyLayer kept;
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (kept.raster && kept.body == body.geometry_id() && kept.width == width && kept.height == height &&
        same_camera(kept.camera, camera))
      return *kept.raster;
  }
  Raster raster(width, height, view);
  Batch batch(height);
  batch.add_body(body, view);
  batch.draw(raster);
  if (std::int64_t(width) * height <= 2500000) {
    std::lock_guard<std::mutex> lock(mutex);
    kept = BodyLayer{body.geometry_id(), camera, width, height, raster};
  }
  return raster;
}

}  // namespace

Camera Camera::framing(const Box3& box) {
  Camera c;
  if (box.isEmpty() || !all_finite(box.min()) || !all_finite(box.max())) return c;
  const Vec3 centre = box.center();
  const Vec3 half = (0.5 * box.sizes()).cwiseMax(1e-3);
  // The box's front face fits the vertical field of view, which is the narrower one for images
  // wider than tall, with a small margin.
  const double tan_half = std::tan(0.5 * c.fov_degrees * M_PI / 180.0);
  const double distance = half.z() + 1.08 * std::max(half.x(), half.y()) / tan_half;
  c.target = centre;
  c.eye = centre + Vec3(0.0, 0.0, distance);
  c.up = Vec3::UnitY();
  return c;
}

namespace {

// The scene drawn into a raster: the body first (from the last frame's layer when the body, camera
// and size are the same), then each garment in turn over it.
Raster draw_scene(const std::vector<const Garment*>& garments, const Body* body, const Camera& camera, int width,
                  int height) {
  if (width < 1 || height < 1 || width > 16384 || height > 16384)
    throw InputError("image size " + std::to_string(width) + "x" + std::to_string(height) +
                     " is out of range: use 1 to 16384 pixels a side");
  for (std::size_t i = 0; i < garments.size(); ++i)
    if (!garments[i]) throw InputError("garment " + std::to_string(i) + " to render is null");
  const View view = make_view(camera, width, height);
  Raster raster = body ? body_layer(*body, camera, view, width, height) : Raster(width, height, view);
  if (!garments.empty()) {
    Batch batch(height);
    for (const Garment* g : garments) batch.add_garment(*g, view);
    batch.draw(raster);
  }
  return raster;
}

}  // namespace

Image render(const std::vector<const Garment*>& garments, const Body* body, const Camera& camera,
             int width, int height) {
  return draw_scene(garments, body, camera, width, height).finish();
}

std::vector<bool> visible_points(const std::vector<const Garment*>& garments, const Body* body, const Camera& camera,
                                 int width, int height, const std::vector<Vec3>& points, double tolerance) {
  if (!(std::isfinite(tolerance) && tolerance >= 0))
    throw InputError("visible_points: the tolerance must be a distance of 0 or more metres");
  const Raster raster = draw_scene(garments, body, camera, width, height);
  const View view = make_view(camera, width, height);
  std::vector<bool> seen(points.size(), false);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!all_finite(points[i])) continue;
    const V3 p = view.to_camera(points[i]);
    if (!(p.z() >= kNear)) continue;
    const V3 s = view.to_screen(p);
    const int x = static_cast<int>(std::floor(s.x())), y = static_cast<int>(std::floor(s.y()));
    if (x < 0 || y < 0 || x >= width || y >= height) continue;
    seen[i] = p.z() <= raster.depth_at(x, y) + tolerance;
  }
  return seen;
}

}  // namespace kiji
