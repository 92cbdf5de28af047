// Garment files written through assimp: glTF binary with an embedded PNG, and OBJ + MTL + PNG.
#include "kiji/io.h"

#include "kiji/error.h"
#include "base/png_codec.h"

#include <assimp/Exporter.hpp>
#include <assimp/material.h>
#include <assimp/scene.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <tuple>
#include <unordered_map>

namespace kiji {

namespace {

namespace fs = std::filesystem;

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

// Area-weighted vertex normals, so the exported cloth shades smoothly in any viewer.
std::vector<Vec3> vertex_normals(const Garment& g) {
  const Mesh& m = g.mesh();
  std::vector<Vec3> n(g.vertex_capacity(), Vec3::Zero());
  for (Face f : m.faces()) {
    const Halfedge h = m.halfedge(f);
    const Vertex a = m.source(h), b = m.target(h), c = m.target(m.next(h));
    const Vec3 fn = (g.position(b) - g.position(a)).cross(g.position(c) - g.position(a));
    n[a] += fn;
    n[b] += fn;
    n[c] += fn;
  }
  for (Vec3& v : n) {
    const double len = v.norm();
    v = len > 0 ? Vec3(v / len) : Vec3(0, 0, 1);
  }
  return n;
}

// One exported vertex per (mesh vertex, uv) pair: a corner whose uv differs from its vertex's
// other corners (a seam) gets a copy of the vertex.
struct CornerKey {
  std::uint32_t vertex;
  double u, v;
  bool operator==(const CornerKey& o) const { return vertex == o.vertex && u == o.u && v == o.v; }
};
struct CornerHash {
  std::size_t operator()(const CornerKey& k) const {
    std::uint64_t a, b;
    std::memcpy(&a, &k.u, 8);
    std::memcpy(&b, &k.v, 8);
    return std::hash<std::uint64_t>()(a * 0x9e3779b97f4a7c15ULL ^ b) ^ (std::size_t(k.vertex) << 1);
  }
};

std::unique_ptr<aiScene> build_scene(const Garment& g, const std::string& texture_ref) {
  const Mesh& m = g.mesh();
  const std::vector<Vec3> normals = vertex_normals(g);

  std::unordered_map<CornerKey, unsigned, CornerHash> corners;
  std::vector<CornerKey> order;
  std::vector<std::array<unsigned, 3>> faces;
  faces.reserve(m.number_of_faces());
  for (Face f : m.faces()) {
    std::array<unsigned, 3> tri{};
    int k = 0;
    for (Halfedge h : CGAL::halfedges_around_face(m.halfedge(f), m)) {
      if (k == 3) break;
      const Vec2 uv = g.uv(h);
      const CornerKey key{static_cast<std::uint32_t>(m.target(h).idx()), uv.x(), uv.y()};
      auto [it, inserted] = corners.emplace(key, static_cast<unsigned>(order.size()));
      if (inserted) order.push_back(key);
      tri[k++] = it->second;
    }
    faces.push_back(tri);
  }

  auto scene = std::make_unique<aiScene>();
  scene->mRootNode = new aiNode();
  scene->mRootNode->mName.Set(g.name);
  scene->mRootNode->mNumMeshes = 1;
  scene->mRootNode->mMeshes = new unsigned[1]{0};

  scene->mNumMeshes = 1;
  scene->mMeshes = new aiMesh*[1]{new aiMesh()};
  aiMesh* mesh = scene->mMeshes[0];
  mesh->mName.Set(g.name);
  mesh->mMaterialIndex = 0;
  mesh->mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
  mesh->mNumVertices = static_cast<unsigned>(order.size());
  mesh->mVertices = new aiVector3D[order.size()];
  mesh->mNormals = new aiVector3D[order.size()];
  mesh->mTextureCoords[0] = new aiVector3D[order.size()];
  mesh->mNumUVComponents[0] = 2;
  for (std::size_t i = 0; i < order.size(); ++i) {
    const Vertex v(order[i].vertex);
    const Vec3 p = g.position(v);
    mesh->mVertices[i] = aiVector3D(static_cast<ai_real>(p.x()), static_cast<ai_real>(p.y()),
                                    static_cast<ai_real>(p.z()));
    const Vec3& n = normals[v];
    mesh->mNormals[i] = aiVector3D(static_cast<ai_real>(n.x()), static_cast<ai_real>(n.y()),
                                   static_cast<ai_real>(n.z()));
    mesh->mTextureCoords[0][i] =
        aiVector3D(static_cast<ai_real>(order[i].u), static_cast<ai_real>(order[i].v), 0);
  }
  mesh->mNumFaces = static_cast<unsigned>(faces.size());
  mesh->mFaces = new aiFace[faces.size()];
  for (std::size_t f = 0; f < faces.size(); ++f) {
    mesh->mFaces[f].mNumIndices = 3;
    mesh->mFaces[f].mIndices = new unsigned[3]{faces[f][0], faces[f][1], faces[f][2]};
  }

  scene->mNumMaterials = 1;
  scene->mMaterials = new aiMaterial*[1]{new aiMaterial()};
  aiMaterial* mat = scene->mMaterials[0];
  const aiString name(g.name);
  mat->AddProperty(&name, AI_MATKEY_NAME);
  const aiColor4D color(static_cast<ai_real>(g.color.x()), static_cast<ai_real>(g.color.y()),
                        static_cast<ai_real>(g.color.z()), 1);
  mat->AddProperty(&color, 1, AI_MATKEY_COLOR_DIFFUSE);
  mat->AddProperty(&color, 1, AI_MATKEY_BASE_COLOR);
  const int two_sided = 1;  // cloth is seen from both sides
  mat->AddProperty(&two_sided, 1, AI_MATKEY_TWOSIDED);
  if (!texture_ref.empty()) {
    const aiString ref(texture_ref);
    mat->AddProperty(&ref, AI_MATKEY_TEXTURE_DIFFUSE(0));
  }
  return scene;
}

std::vector<std::uint8_t> texture_png(const Garment& g, const std::string& path) {
  const Texture& t = g.texture();
  if (t.rgba.size() != static_cast<std::size_t>(t.width) * t.height * 4)
    throw InputError("cannot export '" + path + "': the garment's texture is " + std::to_string(t.width) + "x" +
                     std::to_string(t.height) + " but holds " + std::to_string(t.rgba.size()) + " bytes");
  std::vector<std::uint8_t> png;
  std::string error;
  // Texture row 0 is v = 0, which assimp (and OBJ) put at the bottom of the image.
  if (!detail::encode_png(t.width, t.height, t.rgba.data(), true, png, error))
    throw InputError("cannot export '" + path + "': encoding its texture as PNG failed: " + error);
  return png;
}

void check_writable(const std::string& path, const std::string& what) {
  std::error_code ec;
  if (fs::is_directory(path, ec))
    throw InputError("cannot export '" + path + "': it is a directory; give a file name ending in " + what);
  // Opening a FIFO to write waits for a reader: only a new or a regular file is written.
  if (fs::exists(path, ec) && !fs::is_regular_file(path, ec))
    throw InputError("cannot export '" + path + "': it exists and is not a regular file (a FIFO or a device); "
                     "give a file name ending in " + what);
  std::ofstream probe(path, std::ios::binary | std::ios::app);
  if (!probe)
    throw InputError("cannot export '" + path + "': the file cannot be written; check that its folder exists "
                     "and is writable");
}

}  // namespace

void export_garment(const Garment& garment, const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext != ".glb" && ext != ".obj")
    throw InputError("cannot export '" + path + "': unknown extension '" + ext +
                     "'; use .glb (glTF binary) or .obj (with .mtl and .png)");
  if (garment.mesh().number_of_faces() == 0)
    throw InputError("cannot export '" + path + "': the garment has no faces");
  for (Vertex v : garment.mesh().vertices())
    if (!all_finite(garment.position(v)))
      throw InputError("cannot export '" + path + "': vertex " + std::to_string(v.idx()) +
                       " has a non-finite position; reset the simulation");
  check_writable(path, ext);

  const bool textured = !garment.texture().empty();
  std::unique_ptr<aiScene> scene;
  const fs::path fpath(path);
  if (ext == ".glb") {
    scene = build_scene(garment, textured ? "*0" : "");
    if (textured) {
      const std::vector<std::uint8_t> png = texture_png(garment, path);
      auto* tex = new aiTexture();
      tex->mWidth = static_cast<unsigned>(png.size());  // mHeight 0: compressed data of mWidth bytes
      tex->mHeight = 0;
      std::strncpy(tex->achFormatHint, "png", sizeof tex->achFormatHint - 1);
      tex->pcData = new aiTexel[(png.size() + sizeof(aiTexel) - 1) / sizeof(aiTexel)];
      std::memcpy(tex->pcData, png.data(), png.size());
      scene->mNumTextures = 1;
      scene->mTextures = new aiTexture*[1]{tex};
    }
  } else {
    const std::string png_name = fpath.stem().string() + ".png";
    if (textured) {
      const fs::path png_path = fpath.parent_path() / png_name;
      std::string error;
      if (!detail::write_file(png_path.string(), texture_png(garment, path), error))
        throw InputError("cannot export '" + path + "': its texture '" + png_path.string() +
                         "' cannot be written: " + error);
    }
    scene = build_scene(garment, textured ? png_name : "");
  }

  Assimp::Exporter exporter;
  const char* id = ext == ".glb" ? "glb2" : "obj";
  aiReturn r = aiReturn_FAILURE;
  try {
    r = exporter.Export(scene.get(), id, path);
  } catch (const std::exception& e) {
    throw InputError("cannot export '" + path + "': assimp failed (" + e.what() + ")");
  }
  if (r != aiReturn_SUCCESS)
    throw InputError("cannot export '" + path + "': assimp could not write it (" +
                     exporter.GetErrorString() + "); check the folder is writable");
}

}  // namespace kiji
