// Body::load: any mesh file assimp reads, welded into one surface in metres with +Y up.
#include "kiji/body.h"

#include "base/byte_io.h"
#include "import/import_checks.h"
#include "import/isolated.h"
#include "kiji/error.h"

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <algorithm>
#include <unordered_map>

namespace kiji {

namespace {

namespace fs = std::filesystem;

[[noreturn]] void fail(const std::string& path, const std::string& problem) {
  throw InputError("cannot load body '" + path + "': " + problem);
}

// A numeric metadata entry whatever type the importer stored it as (FBX uses float or double
// depending on how assimp was built).
std::optional<double> meta_number(const aiMetadata* meta, const char* key) {
  if (!meta) return std::nullopt;
  for (unsigned i = 0; i < meta->mNumProperties; ++i) {
    if (std::strcmp(meta->mKeys[i].C_Str(), key) != 0) continue;
    const aiMetadataEntry& e = meta->mValues[i];
    if (!e.mData) return std::nullopt;
    switch (e.mType) {
      case AI_BOOL: return *static_cast<const bool*>(e.mData) ? 1.0 : 0.0;
      case AI_INT32: return static_cast<double>(*static_cast<const std::int32_t*>(e.mData));
      case AI_UINT64: return static_cast<double>(*static_cast<const std::uint64_t*>(e.mData));
      case AI_FLOAT: return static_cast<double>(*static_cast<const float*>(e.mData));
      case AI_DOUBLE: return *static_cast<const double*>(e.mData);
      default: return std::nullopt;
    }
  }
  return std::nullopt;
}

std::string meta_string(const aiMetadata* meta, const char* key) {
  if (!meta) return {};
  for (unsigned i = 0; i < meta->mNumProperties; ++i)
    if (std::strcmp(meta->mKeys[i].C_Str(), key) == 0 && meta->mValues[i].mType == AI_AISTRING)
      return static_cast<const aiString*>(meta->mValues[i].mData)->C_Str();
  return {};
}

Eigen::Matrix4d to_eigen(const aiMatrix4x4& m) {
  Eigen::Matrix4d r;
  r << m.a1, m.a2, m.a3, m.a4, m.b1, m.b2, m.b3, m.b4, m.c1, m.c2, m.c3, m.c4, m.d1, m.d2, m.d3, m.d4;
  return r;
}

// The proper rotation that takes the file's up axis to +Y. For +Z up it is the usual
// (x, y, z) -> (x, z, -y), which turns a Z-up body facing -Y (Blender's front) to face +Z.
Eigen::Matrix3d rotation_to_y_up(Axis up) {
  Eigen::Matrix3d r;
  switch (up) {
    case Axis::PosY: r.setIdentity(); break;
    case Axis::NegY: r << 1, 0, 0, 0, -1, 0, 0, 0, -1; break;
    case Axis::PosZ: r << 1, 0, 0, 0, 0, 1, 0, -1, 0; break;
    case Axis::NegZ: r << 1, 0, 0, 0, 0, -1, 0, 1, 0; break;
    case Axis::PosX: r << 0, -1, 0, 1, 0, 0, 0, 0, 1; break;
    case Axis::NegX: r << 0, 1, 0, -1, 0, 0, 0, 0, 1; break;
  }
  return r;
}

std::optional<Axis> axis_of(const Eigen::Vector3d& d) {
  const double tol = 1e-4;
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d e = Eigen::Vector3d::Zero();
    e[k] = 1;
    if ((d - e).norm() < tol) return k == 0 ? Axis::PosX : k == 1 ? Axis::PosY : Axis::PosZ;
    if ((d + e).norm() < tol) return k == 0 ? Axis::NegX : k == 1 ? Axis::NegY : Axis::NegZ;
  }
  return std::nullopt;
}

// assimp's Collada importer bakes the file's <unit> and <up_axis> into the root node as
// scale * rotation (a <visual_scene> has no transform of its own). Reading them back lets the
// options replace them instead of being applied on top of them.
struct ColladaConversion {
  double unit = 1;
  Axis up = Axis::PosY;
};

std::optional<ColladaConversion> collada_conversion(const aiNode* root) {
  const Eigen::Matrix4d m = to_eigen(root->mTransformation);
  if (!m.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1)) || !m.col(3).head<3>().isZero()) return std::nullopt;
  const Eigen::Matrix3d a = m.topLeftCorner<3, 3>();
  const double s = a.col(0).norm();
  if (!(s > 0) || !std::isfinite(s)) return std::nullopt;
  const Eigen::Matrix3d r = a / s;
  if (!(r.transpose() * r).isIdentity(1e-4) || r.determinant() < 0) return std::nullopt;
  // r takes the file's up axis to +Y, so the file's up axis is r^T * Y.
  auto up = axis_of(r.transpose() * Eigen::Vector3d::UnitY());
  if (!up) return std::nullopt;
  return ColladaConversion{s, *up};
}

struct MeshSoup {
  std::vector<Vec3> vertices;
  std::vector<std::array<int, 3>> triangles;
  std::size_t meshes = 0;  // mesh instances that gave triangles
};

void collect(const aiScene* scene, const aiNode* node, const Eigen::Matrix4d& parent, bool skip_own,
             MeshSoup& soup) {
  const Eigen::Matrix4d t = skip_own ? parent : Eigen::Matrix4d(parent * to_eigen(node->mTransformation));
  for (unsigned i = 0; i < node->mNumMeshes; ++i) {
    if (node->mMeshes[i] >= scene->mNumMeshes) continue;
    const aiMesh* mesh = scene->mMeshes[node->mMeshes[i]];
    if (!(mesh->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
    const int base = static_cast<int>(soup.vertices.size());
    const std::size_t before = soup.triangles.size();
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& p = mesh->mVertices[v];
      const Eigen::Vector4d q = t * Eigen::Vector4d(p.x, p.y, p.z, 1.0);
      soup.vertices.emplace_back(q.head<3>());
    }
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines are not a surface
      bool ok = true;
      for (int k = 0; k < 3; ++k) ok = ok && face.mIndices[k] < mesh->mNumVertices;
      if (!ok) continue;
      soup.triangles.push_back({base + static_cast<int>(face.mIndices[0]),
                                base + static_cast<int>(face.mIndices[1]),
                                base + static_cast<int>(face.mIndices[2])});
    }
    if (soup.triangles.size() > before) ++soup.meshes;
  }
  for (unsigned c = 0; c < node->mNumChildren; ++c) collect(scene, node->mChildren[c], t, false, soup);
}

struct PositionHash {
  std::size_t operator()(const Vec3& p) const {
    std::size_t h = 0;
    for (int k = 0; k < 3; ++k) {
      const double c = p[k] == 0.0 ? 0.0 : p[k];  // -0 and +0 are one position
      std::uint64_t bits;
      std::memcpy(&bits, &c, sizeof bits);
      h ^= std::hash<std::uint64_t>()(bits) + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2);
    }
    return h;
  }
};

// Welds vertices at exactly the same position (the same file position transformed by the same
// node transform lands on the same doubles), drops degenerate triangles and unused vertices.
MeshSoup weld(const MeshSoup& in) {
  std::unordered_map<Vec3, int, PositionHash> index;
  index.reserve(in.vertices.size());
  std::vector<int> remap(in.vertices.size());
  std::vector<Vec3> unique;
  for (std::size_t i = 0; i < in.vertices.size(); ++i) {
    auto [it, inserted] = index.emplace(in.vertices[i], static_cast<int>(unique.size()));
    if (inserted) unique.push_back(in.vertices[i]);
    remap[i] = it->second;
  }
  MeshSoup out;
  std::vector<int> used(unique.size(), -1);
  for (const auto& t : in.triangles) {
    const std::array<int, 3> w{remap[t[0]], remap[t[1]], remap[t[2]]};
    if (w[0] == w[1] || w[1] == w[2] || w[0] == w[2]) continue;
    const Vec3 n = (unique[w[1]] - unique[w[0]]).cross(unique[w[2]] - unique[w[0]]);
    if (!(n.squaredNorm() > 0)) continue;
    std::array<int, 3> r;
    for (int k = 0; k < 3; ++k) {
      if (used[w[k]] < 0) {
        used[w[k]] = static_cast<int>(out.vertices.size());
        out.vertices.push_back(unique[w[k]]);
      }
      r[k] = used[w[k]];
    }
    out.triangles.push_back(r);
  }
  return out;
}

Vec3 axis_vector(Axis a) {
  switch (a) {
    case Axis::PosX: return Vec3::UnitX();
    case Axis::NegX: return -Vec3::UnitX();
    case Axis::PosY: return Vec3::UnitY();
    case Axis::NegY: return -Vec3::UnitY();
    case Axis::PosZ: return Vec3::UnitZ();
    case Axis::NegZ: return -Vec3::UnitZ();
  }
  return Vec3::UnitZ();
}

// Area-weighted centroid of the triangles whose centroid is at a height within [lo, hi).
std::optional<Vec3> slice_centroid(const MeshSoup& s, double lo, double hi) {
  Vec3 sum = Vec3::Zero();
  double area = 0;
  for (const auto& t : s.triangles) {
    const Vec3 &a = s.vertices[t[0]], &b = s.vertices[t[1]], &c = s.vertices[t[2]];
    const Vec3 centre = (a + b + c) / 3.0;
    if (centre.y() < lo || centre.y() >= hi) continue;
    const double w = 0.5 * (b - a).cross(c - a).norm();
    sum += w * centre;
    area += w;
  }
  if (!(area > 0)) return std::nullopt;
  return sum / area;
}

// The way a standing body faces (Y up), from its feet: toes reach forward of the ankles, so the
// feet's centroid lies ahead of the shins' (by 2-5 % of the height in the bodies tried: a scanned
// human, Quake II characters), while left and right cancel. Nothing when the cue is under 1 %
// (a body without feet, or in a robe).
std::optional<Vec3> front_from_feet(const MeshSoup& s) {
  Box3 box;
  for (const Vec3& p : s.vertices) box.extend(p);
  const double h = box.sizes().y(), y0 = box.min().y();
  if (!(h > 0)) return std::nullopt;
  const auto feet = slice_centroid(s, y0, y0 + 0.04 * h);
  const auto shins = slice_centroid(s, y0 + 0.08 * h, y0 + 0.16 * h);
  if (!feet || !shins) return std::nullopt;
  const Vec3 d = *feet - *shins;
  if (std::max(std::abs(d.x()), std::abs(d.z())) < 0.01 * h) return std::nullopt;
  return std::abs(d.x()) > std::abs(d.z()) ? Vec3(d.x() > 0 ? 1 : -1, 0, 0) : Vec3(0, 0, d.z() > 0 ? 1 : -1);
}

// The turn about +Y that takes a horizontal axis to +Z.
Eigen::Matrix3d turn_to_face_z(const Vec3& front) {
  Eigen::Matrix3d r;
  if (front.x() > 0.5) r << 0, 0, -1, 0, 1, 0, 1, 0, 0;
  else if (front.x() < -0.5) r << 0, 0, 1, 0, 1, 0, -1, 0, 0;
  else if (front.z() < -0.5) r << -1, 0, 0, 0, 1, 0, 0, 0, -1;
  else r.setIdentity();
  return r;
}

double median_edge(const MeshSoup& s) {
  std::vector<double> lengths;
  lengths.reserve(3 * s.triangles.size());
  for (const auto& t : s.triangles)
    for (int k = 0; k < 3; ++k) lengths.push_back((s.vertices[t[(k + 1) % 3]] - s.vertices[t[k]]).norm());
  if (lengths.empty()) return 0;
  auto mid = lengths.begin() + lengths.size() / 2;
  std::nth_element(lengths.begin(), mid, lengths.end());
  return *mid;
}

// One step of Loop subdivision: every triangle into four, new points on the edges, every point
// moved towards its neighbours (Loop 1987, with Warren's weights). An edge with one face, or more
// than two (a game model's parts meeting along an edge), is kept as a crease, and a vertex where
// creases meet other than two at a time stays where it is.
MeshSoup loop_subdivide(const MeshSoup& in) {
  const std::size_t nv = in.vertices.size();
  struct EdgeInfo {
    int index = -1;   // the edge's new point
    int faces = 0;
    Vec3 opposite = Vec3::Zero();  // the sum of the faces' third corners
  };
  std::unordered_map<std::uint64_t, EdgeInfo> edges;
  edges.reserve(3 * in.triangles.size() / 2 + 1);
  auto key = [](int a, int b) {
    return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | static_cast<std::uint32_t>(std::max(a, b));
  };
  for (const auto& t : in.triangles)
    for (int k = 0; k < 3; ++k) {
      EdgeInfo& e = edges[key(t[k], t[(k + 1) % 3])];
      ++e.faces;
      e.opposite += in.vertices[t[(k + 2) % 3]];
    }
  MeshSoup out;
  out.meshes = in.meshes;
  out.vertices.resize(nv + edges.size());
  std::vector<Vec3> ring(nv, Vec3::Zero()), crease(nv, Vec3::Zero());
  std::vector<int> degree(nv, 0), creases(nv, 0);
  int next = static_cast<int>(nv);
  for (auto& [k, e] : edges) {
    const int a = static_cast<int>(k >> 32), b = static_cast<int>(k & 0xffffffffu);
    const Vec3 &pa = in.vertices[a], &pb = in.vertices[b];
    e.index = next++;
    out.vertices[e.index] = e.faces == 2 ? Vec3(0.375 * (pa + pb) + 0.125 * e.opposite) : Vec3(0.5 * (pa + pb));
    ring[a] += pb;
    ring[b] += pa;
    ++degree[a];
    ++degree[b];
    if (e.faces != 2) {
      crease[a] += pb;
      crease[b] += pa;
      ++creases[a];
      ++creases[b];
    }
  }
  for (std::size_t i = 0; i < nv; ++i) {
    const Vec3& p = in.vertices[i];
    if (creases[i] == 2) {
      out.vertices[i] = 0.75 * p + 0.125 * crease[i];
    } else if (creases[i] > 0 || degree[i] == 0) {
      out.vertices[i] = p;
    } else {
      const double n = degree[i];
      const double beta = n > 3 ? 3.0 / (8.0 * n) : 3.0 / 16.0;
      out.vertices[i] = (1 - n * beta) * p + beta * ring[i];
    }
  }
  out.triangles.reserve(4 * in.triangles.size());
  for (const auto& t : in.triangles) {
    const int ab = edges[key(t[0], t[1])].index, bc = edges[key(t[1], t[2])].index,
              ca = edges[key(t[2], t[0])].index;
    out.triangles.push_back({t[0], ab, ca});
    out.triangles.push_back({ab, t[1], bc});
    out.triangles.push_back({ca, bc, t[2]});
    out.triangles.push_back({ab, bc, ca});
  }
  return out;
}

void check_options(const std::string& path, const BodyImportOptions& o) {
  if (o.scale && !(std::isfinite(*o.scale) && *o.scale > 0)) {
    std::ostringstream m;
    m << "the scale option is " << *o.scale << ": give metres per file unit as a positive number";
    fail(path, m.str());
  }
  if (o.height && !(std::isfinite(*o.height) && *o.height > 0)) {
    std::ostringstream m;
    m << "the height option is " << *o.height << ": give the body's height in metres as a positive number";
    fail(path, m.str());
  }
}

void check_file(const std::string& path) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (path.empty()) fail(path, "no file name was given: name a mesh file (OBJ, Collada, FBX, glTF, ...)");
  if (ec || !fs::exists(st)) fail(path, "the file does not exist: check the path");
  if (fs::is_directory(st)) fail(path, "it is a directory, not a file: name a mesh file inside it");
  if (!fs::is_regular_file(st)) fail(path, "it is not a regular file: name a mesh file");
  std::ifstream probe(path, std::ios::binary);
  if (!probe) fail(path, "the file cannot be opened for reading: check its permissions");
  if (fs::file_size(path, ec) == 0 && !ec) fail(path, "the file is empty: export the body again");
}

// The whole of a loaded body, report included, as the reading process hands it back.
std::string encode_loaded(const Body& b) {
  detail::ByteWriter w;
  w.str(b.name());
  const BodyImportReport& r = b.report();
  for (const std::string* s : {&r.format, &r.up_source, &r.scale_source, &r.front_source}) w.str(*s);
  w.u8(static_cast<std::uint8_t>(r.up));
  w.u8(static_cast<std::uint8_t>(r.front));
  w.f64(r.scale);
  w.i32(r.smoothing);
  w.u64(r.meshes_merged);
  w.u64(r.vertices_before_weld);
  w.u64(b.vertices().size());
  for (const Vec3& v : b.vertices()) w.vec3(v);
  w.u64(b.triangles().size());
  for (const auto& t : b.triangles())
    for (int k : t) w.i32(k);
  return w.take();
}

// Read as strictly as any outside bytes: the process that wrote them read a hostile file.
Body decode_loaded(std::string_view bytes, const std::string& path) {
  detail::ByteReader r(bytes, "the body read from '" + path + "'");
  std::string name = r.str(4096, "its name");
  BodyImportReport rep;
  for (std::string* s : {&rep.format, &rep.up_source, &rep.scale_source, &rep.front_source})
    *s = r.str(4096, "its report");
  auto axis = [&] {
    const std::uint8_t a = r.u8();
    if (a > static_cast<std::uint8_t>(Axis::NegZ)) r.fail("an unknown axis");
    return static_cast<Axis>(a);
  };
  rep.up = axis();
  rep.front = axis();
  rep.scale = r.finite("its scale");
  rep.smoothing = r.i32();
  rep.meshes_merged = r.u64();
  rep.vertices_before_weld = r.u64();
  const std::uint64_t nv = r.u64();
  if (nv > r.left() / 24) r.fail("more vertices than bytes");
  std::vector<Vec3> vertices(nv);
  for (Vec3& v : vertices) v = r.vec3("a vertex");
  const std::uint64_t nt = r.u64();
  if (nt > r.left() / 12) r.fail("more triangles than bytes");
  std::vector<std::array<int, 3>> triangles(nt);
  for (auto& t : triangles)
    for (int& k : t) k = r.i32();
  if (!r.at_end()) r.fail("bytes are left over");
  return Body::from_triangles(std::move(vertices), std::move(triangles), std::move(name), std::move(rep));
}

Body load_here(const std::string& path, const BodyImportOptions& options);

}  // namespace

std::string Body::default_path() { return "/usr/share/assimp/models/Collada/human.zae"; }

Body Body::load(const std::string& path, const BodyImportOptions& options) {
  check_options(path, options);
  check_file(path);
  if (!options.limits.isolate) return load_here(path, options);
  const std::string bytes = detail::run_isolated([&] { return encode_loaded(load_here(path, options)); },
                                                 options.limits, "cannot load body '" + path + "'");
  return decode_loaded(bytes, path);
}

namespace {

Body load_here(const std::string& path, const BodyImportOptions& options) {
  Assimp::Importer importer;
  detail::prepare_importer(importer, path, "cannot load body '" + path + "'");
  // Without normals, uvs and colours, Collada's seam-split corners become identical and weld.
  // A body is its surface: what FBX holds beside it is not read (assimp's FBX reader frees a bone
  // twice for two clusters of one name, reads an empty animation curve through a null pointer,
  // adds rotation keys without end, and frees a texture's content twice).
  for (const char* part : {AI_CONFIG_IMPORT_FBX_READ_ANIMATIONS, AI_CONFIG_IMPORT_FBX_READ_WEIGHTS,
                           AI_CONFIG_IMPORT_FBX_READ_MATERIALS, AI_CONFIG_IMPORT_FBX_READ_TEXTURES,
                           AI_CONFIG_IMPORT_FBX_READ_CAMERAS, AI_CONFIG_IMPORT_FBX_READ_LIGHTS})
    importer.SetPropertyBool(part, false);
  importer.SetPropertyInteger(
      AI_CONFIG_PP_RVC_FLAGS,
      aiComponent_NORMALS | aiComponent_TANGENTS_AND_BITANGENTS | aiComponent_COLORS |
          aiComponent_TEXCOORDS | aiComponent_BONEWEIGHTS | aiComponent_ANIMATIONS |
          aiComponent_TEXTURES | aiComponent_LIGHTS | aiComponent_CAMERAS | aiComponent_MATERIALS);
  const aiScene* scene = nullptr;
  try {
    // Post-processed apart, below, after Kiji has checked the faces.
    scene = importer.ReadFile(path, 0);
  } catch (const std::exception& e) {
    fail(path, std::string("assimp failed while reading it (") + e.what() + "): check the file is a mesh file");
  }
  if (!scene || !scene->mRootNode) {
    std::string err = importer.GetErrorString();
    while (!err.empty() && (err.back() == '.' || err.back() == '\n' || err.back() == ' ')) err.pop_back();
    fail(path, "assimp cannot read it (" + (err.empty() ? std::string("no reason given") : err) +
                   "): use a format assimp reads (OBJ, Collada, FBX, glTF, PLY, STL, ...) or export it again");
  }
  detail::post_process(importer, aiProcess_RemoveComponent | aiProcess_Triangulate | aiProcess_SortByPType,
                       "cannot load body '" + path + "'");
  scene = importer.GetScene();

  BodyImportReport report;
  report.format = meta_string(scene->mMetaData, "SourceAsset_Format");
  if (report.format.empty()) report.format = fs::path(path).extension().string();

  // Non-finite coordinates are checked before welding: NaN never equals itself and would upset it.
  bool any_triangles = false;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* mesh = scene->mMeshes[m];
    if (!(mesh->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
    any_triangles = any_triangles || mesh->mNumFaces > 0;
    report.vertices_before_weld += mesh->mNumVertices;
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& p = mesh->mVertices[v];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
        std::ostringstream msg;
        msg << "mesh " << m;
        if (mesh->mName.length) msg << " ('" << mesh->mName.C_Str() << "')";
        msg << " has a non-finite coordinate (" << p.x << ", " << p.y << ", " << p.z << ") at vertex " << v
            << ": repair the mesh or export it again";
        fail(path, msg.str());
      }
    }
  }
  if (!any_triangles)
    fail(path, "it has no triangles (only points, lines or nothing): a body needs a surface; export the mesh "
               "with its faces");

  try {
    scene = importer.ApplyPostProcessing(aiProcess_JoinIdenticalVertices);
  } catch (const std::exception& e) {
    fail(path, std::string("assimp failed to weld its vertices (") + e.what() + ")");
  }
  if (!scene) fail(path, std::string("assimp failed to weld its vertices (") + importer.GetErrorString() + ")");

  // Where the up axis and unit come from: options, else what the file says, else +Y and metres.
  std::optional<Axis> file_front;
  Axis up = Axis::PosY;
  double scale = 1.0;
  report.up_source = "default (+Y)";
  report.scale_source = "default (metres)";
  bool skip_root = false;
  if (report.format.find("Collada") != std::string::npos) {
    if (auto c = collada_conversion(scene->mRootNode)) {
      skip_root = true;  // the root holds only the conversion, which is applied below instead
      up = c->up;
      scale = c->unit;
      report.up_source = "file metadata";
      report.scale_source = "file metadata";
    }
  } else {
    // FBX: UnitScaleFactor is centimetres per file unit; UpAxis 0/1/2 = x/y/z with UpAxisSign.
    if (auto f = meta_number(scene->mMetaData, "UnitScaleFactor"); f && std::isfinite(*f) && *f > 0) {
      scale = *f / 100.0;
      report.scale_source = "file metadata";
    }
    auto axis = meta_number(scene->mMetaData, "UpAxis");
    auto sign = meta_number(scene->mMetaData, "UpAxisSign");
    if (axis && (*axis == 0 || *axis == 1 || *axis == 2)) {
      const bool neg = sign && *sign < 0;
      const int k = static_cast<int>(*axis);
      up = k == 0 ? (neg ? Axis::NegX : Axis::PosX) : k == 1 ? (neg ? Axis::NegY : Axis::PosY)
                                                             : (neg ? Axis::NegZ : Axis::PosZ);
      report.up_source = "file metadata";
    }
    // FBX: FrontAxis 0/1/2 = x/y/z with FrontAxisSign, the way its front view looks at a model.
    auto front_axis = meta_number(scene->mMetaData, "FrontAxis");
    auto front_sign = meta_number(scene->mMetaData, "FrontAxisSign");
    if (front_axis && (*front_axis == 0 || *front_axis == 1 || *front_axis == 2)) {
      const bool neg = front_sign && *front_sign < 0;
      const int k = static_cast<int>(*front_axis);
      file_front = k == 0 ? (neg ? Axis::NegX : Axis::PosX) : k == 1 ? (neg ? Axis::NegY : Axis::PosY)
                                                                    : (neg ? Axis::NegZ : Axis::PosZ);
    }
  }
  if (report.format.find("glTF") != std::string::npos) file_front = Axis::PosZ;  // its specification's front
  if (options.up) {
    up = *options.up;
    report.up_source = "option";
  }
  if (options.scale) {
    scale = *options.scale;
    report.scale_source = "option";
  }

  MeshSoup soup;
  collect(scene, scene->mRootNode, Eigen::Matrix4d::Identity(), skip_root, soup);
  report.meshes_merged = soup.meshes;
  const Eigen::Matrix3d rot = rotation_to_y_up(up);
  for (Vec3& p : soup.vertices) p = rot * p;

  MeshSoup body = weld(soup);
  if (body.triangles.empty())
    fail(path, "all of its triangles are degenerate (zero area): a body needs a surface; check the export");
  if (options.smooth && body.triangles.size() >= 100) {
    Box3 box;
    for (const Vec3& p : body.vertices) box.extend(p);
    // Three levels take a 680-triangle game character to 1 cm triangles (43,000 of them).
    while (report.smoothing < 3 && median_edge(body) > 0.01 * box.sizes().y() && body.triangles.size() <= 125000) {
      body = loop_subdivide(body);
      ++report.smoothing;
    }
  }

  if (options.height) {
    Box3 box;
    for (const Vec3& p : body.vertices) box.extend(p);
    const double h = box.sizes().y();
    if (!(h > 0) || !std::isfinite(h))
      fail(path, "it is flat along its up axis (" + axis_name(up) +
                     "), so it cannot be scaled to a height: set the up axis option");
    scale = *options.height / h;
    report.scale_source = "height option";
  }
  for (Vec3& p : body.vertices) p *= scale;
  report.up = up;
  report.scale = scale;

  // Which way it faces: the option, else (when asked to find it) the file, else its feet; then
  // turned to face +Z. Found nowhere, it stays as the file has it.
  auto horizontal = [&](Axis a) -> std::optional<Vec3> {
    const Vec3 f = rot * axis_vector(a);
    if (std::abs(f.y()) > 0.5) return std::nullopt;
    return f;
  };
  std::optional<Vec3> front;
  if (options.front) {
    front = horizontal(*options.front);
    if (!front)
      fail(path, "the front axis option (" + axis_name(*options.front) + ") is along its up axis (" +
                     axis_name(up) + "): give one of the four axes across it");
    report.front_source = "option";
  } else if (options.find_front && file_front && (front = horizontal(*file_front))) {
    report.front_source = report.format.find("glTF") != std::string::npos ? "glTF convention" : "file metadata";
  } else if (options.find_front && (front = front_from_feet(body))) {
    report.front_source = "feet";
  } else {
    front = Vec3::UnitZ();
    report.front_source = "as the file has it";
  }
  report.front = axis_of(rot.transpose() * *front).value_or(Axis::PosZ);
  const Eigen::Matrix3d turn = turn_to_face_z(*front);
  for (Vec3& p : body.vertices) p = turn * p;

  if (options.recenter) {
    Box3 box;
    for (const Vec3& p : body.vertices) box.extend(p);
    const Vec3 c = box.center();
    const Vec3 shift(-c.x(), -box.min().y(), -c.z());
    for (Vec3& p : body.vertices) p += shift;
  }
  for (const Vec3& p : body.vertices)
    if (!all_finite(p))
      fail(path, "its coordinates overflow when scaled to metres: check the scale and height options");

  return Body::from_triangles(std::move(body.vertices), std::move(body.triangles), fs::path(path).stem().string(),
                              std::move(report));
}

}  // namespace

}  // namespace kiji
