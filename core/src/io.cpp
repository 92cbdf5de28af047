// Garment files through assimp: glTF binary with an embedded PNG, and OBJ + MTL + PNG.
#include "kiji/io.h"

#include "kiji/error.h"
#include "import_checks.h"
#include "isolated.h"
#include "kiji/operation.h"
#include "png_codec.h"

#include <assimp/Exporter.hpp>
#include <assimp/Importer.hpp>
#include <assimp/material.h>
#include <assimp/postprocess.h>
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

// The texture a material refers to: embedded ("*0", or by file name in 5.2's glTF importer) or a
// PNG file beside the model. Other image formats are left out (libkiji decodes PNG only).
Texture read_texture(const aiScene* scene, const aiMaterial* mat, const std::string& model_path) {
  aiString ref;
  if (mat->GetTexture(aiTextureType_BASE_COLOR, 0, &ref) != AI_SUCCESS &&
      mat->GetTexture(aiTextureType_DIFFUSE, 0, &ref) != AI_SUCCESS)
    return {};
  const std::string where = "cannot import '" + model_path + "': its texture '" + ref.C_Str() + "'";
  Texture t;
  std::string error;
  if (const aiTexture* emb = scene->GetEmbeddedTexture(ref.C_Str())) {
    if (!emb->pcData) throw InputError(where + " is embedded without data; export the garment again");
    if (emb->mHeight == 0) {  // compressed: mWidth bytes of an image file
      if (!detail::decode_png(reinterpret_cast<const std::uint8_t*>(emb->pcData), emb->mWidth, true, t.width,
                              t.height, t.rgba, error)) {
        if (error.rfind("not a PNG", 0) == 0) return {};
        throw InputError(where + " is a broken PNG (" + error + "); export the garment again");
      }
      return t;
    }
    // Raw texels, mWidth x mHeight of them: bounded as a PNG's size is, before allocating.
    if (const std::string problem = detail::image_size_problem(emb->mWidth, emb->mHeight); !problem.empty())
      throw InputError(where + " is refused: its " + problem + "; export the garment with a smaller texture");
    t.width = static_cast<int>(emb->mWidth);
    t.height = static_cast<int>(emb->mHeight);
    t.rgba.resize(static_cast<std::size_t>(t.width) * t.height * 4);
    for (int y = 0; y < t.height; ++y)
      for (int x = 0; x < t.width; ++x) {
        const aiTexel& s = emb->pcData[static_cast<std::size_t>(t.height - 1 - y) * t.width + x];
        std::uint8_t* d = t.texel(x, y);
        d[0] = s.r, d[1] = s.g, d[2] = s.b, d[3] = s.a;
      }
    return t;
  }
  fs::path file(ref.C_Str());
  if (file.is_relative()) file = fs::path(model_path).parent_path() / file;
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext != ".png") return {};
  std::vector<std::uint8_t> bytes;
  if (!detail::read_file(file.string(), detail::kMaxPngFileBytes, bytes, error))
    throw InputError(where + " cannot be read from '" + file.string() + "' (" + error +
                     "); keep the PNG beside the model");
  if (!detail::decode_png(bytes.data(), bytes.size(), true, t.width, t.height, t.rgba, error))
    throw InputError(where + " is not a readable PNG (" + error + "); export the garment again");
  return t;
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

namespace {
Garment import_garment_here(const std::string& path, const Material& material);
}  // namespace

Garment import_garment(const std::string& path, const Material& material, const ImportLimits& limits) {
  material.validate();
  const std::string ext = lower_extension(path);
  if (ext != ".glb" && ext != ".gltf" && ext != ".obj")
    throw InputError("cannot import garment '" + path + "': unknown extension '" + ext +
                     "'; use .glb, .gltf or .obj");
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError("cannot import garment '" + path + "': the file does not exist");
  if (!fs::is_regular_file(path, ec))
    throw InputError("cannot import garment '" + path + "': it is not a regular file");
  if (fs::file_size(path, ec) == 0)
    throw InputError("cannot import garment '" + path + "': the file is empty; export the garment again");
  if (!limits.isolate) return import_garment_here(path, material);
  const std::string bytes = detail::run_isolated([&] { return encode_garment(import_garment_here(path, material)); },
                                                 limits, "cannot import garment '" + path + "'");
  // Any size the file held: the counts are still checked against the bytes before anything is allocated.
  DecodeLimits any_size;
  any_size.max_vertices = any_size.max_faces = std::numeric_limits<std::uint32_t>::max();
  any_size.max_string = std::size_t{1} << 24;
  try {
    return decode_garment(bytes, any_size);
  } catch (const InputError& e) {
    throw InputError("cannot import garment '" + path + "': " + e.what());
  }
}

namespace {

Garment import_garment_here(const std::string& path, const Material& material) {
  Assimp::Importer importer;
  detail::prepare_importer(importer, path, "cannot import garment '" + path + "'");
  const aiScene* scene = nullptr;
  try {
    // Post-processed apart, below, after Kiji has checked the faces.
    scene = importer.ReadFile(path, 0);
  } catch (const std::exception& e) {
    throw InputError("cannot import garment '" + path + "': assimp failed (" + e.what() + ")");
  }
  if (!scene)
    throw InputError("cannot import garment '" + path + "': assimp cannot read it (" +
                     importer.GetErrorString() + "); export the garment again");
  detail::post_process(importer, aiProcess_Triangulate | aiProcess_PreTransformVertices,
                       "cannot import garment '" + path + "'");
  scene = importer.GetScene();

  // Weld corners that share a position into one vertex; the uv stays with the corner.
  struct Corner {
    int vertex;
    Vec2 uv;
  };
  struct Key {
    float x, y, z;
    bool operator<(const Key& o) const { return std::tie(x, y, z) < std::tie(o.x, o.y, o.z); }
  };
  std::map<Key, int> index;
  std::vector<Vec3> points;
  std::vector<std::array<Corner, 3>> triangles;
  const aiMaterial* first_material = nullptr;
  std::string mesh_name;
  for (unsigned mi = 0; mi < scene->mNumMeshes; ++mi) {
    const aiMesh* am = scene->mMeshes[mi];
    if (!(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
    if (!first_material && am->mMaterialIndex < scene->mNumMaterials)
      first_material = scene->mMaterials[am->mMaterialIndex];
    if (mesh_name.empty()) mesh_name = am->mName.C_Str();
    std::vector<int> vid(am->mNumVertices);
    for (unsigned v = 0; v < am->mNumVertices; ++v) {
      const aiVector3D& p = am->mVertices[v];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        throw InputError("cannot import garment '" + path + "': vertex " + std::to_string(v) +
                         " has a non-finite position; repair the file");
      auto [it, inserted] = index.emplace(Key{p.x, p.y, p.z}, static_cast<int>(points.size()));
      if (inserted) points.emplace_back(p.x, p.y, p.z);
      vid[v] = it->second;
    }
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3 || !face.mIndices) continue;
      std::array<Corner, 3> tri;
      for (int k = 0; k < 3; ++k) {
        // The importer's own checks differ by format and version: every index is checked here.
        const unsigned i = face.mIndices[k];
        if (i >= am->mNumVertices)
          throw InputError("cannot import garment '" + path + "': face " + std::to_string(f + 1) + " of mesh '" +
                           am->mName.C_Str() + "' refers to vertex " + std::to_string(i + 1) + ", but the mesh has " +
                           std::to_string(am->mNumVertices) + " vertices; repair the file");
        tri[k].vertex = vid[i];
        tri[k].uv = am->mTextureCoords[0] ? Vec2(am->mTextureCoords[0][i].x, am->mTextureCoords[0][i].y)
                                          : Vec2(points[vid[i]].x(), points[vid[i]].y());
        if (!all_finite(tri[k].uv))
          throw InputError("cannot import garment '" + path + "': vertex " + std::to_string(i + 1) +
                           " has a texture coordinate that is not a finite number; repair the file");
      }
      if (tri[0].vertex == tri[1].vertex || tri[1].vertex == tri[2].vertex || tri[0].vertex == tri[2].vertex)
        continue;  // collapsed by the weld: no area
      triangles.push_back(tri);
    }
  }
  if (triangles.empty())
    throw InputError("cannot import garment '" + path + "': it has no triangles; a garment is a surface");

  Mesh mesh;
  std::vector<int> used(points.size(), -1);
  std::vector<Vertex> vmap;
  for (const auto& tri : triangles)
    for (const Corner& c : tri)
      if (used[c.vertex] < 0) {
        used[c.vertex] = static_cast<int>(vmap.size());
        vmap.push_back(mesh.add_vertex(to_point(points[c.vertex])));
      }
  std::vector<Face> faces;
  faces.reserve(triangles.size());
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    const auto& tri = triangles[t];
    const Face f = mesh.add_face(vmap[used[tri[0].vertex]], vmap[used[tri[1].vertex]], vmap[used[tri[2].vertex]]);
    if (f == Mesh::null_face())
      throw InputError("cannot import garment '" + path + "': triangle " + std::to_string(t) +
                       " makes the surface non-manifold (an edge shared by more than two faces, or faces "
                       "with opposite orientation); repair the mesh");
    faces.push_back(f);
  }

  Garment g(std::move(mesh), material);
  // Faces added one by one can each be accepted and still leave a vertex where two sheets meet at a
  // point (found by fuzz_garment_obj): the whole surface is checked once it is built.
  try {
    g.validate();
  } catch (const Error& e) {
    throw InputError("cannot import garment '" + path + "': its triangles do not make a valid surface (" + e.what() +
                     "); repair the mesh");
  }
  double length3 = 0, length_uv = 0;
  for (std::size_t t = 0; t < faces.size(); ++t) {
    const Mesh& m = g.mesh();
    for (Halfedge h : CGAL::halfedges_around_face(m.halfedge(faces[t]), m)) {
      const Vertex target = m.target(h);
      for (const Corner& c : triangles[t])
        if (vmap[used[c.vertex]] == target) g.set_uv(h, c.uv);
    }
  }
  // The file does not carry the pattern's scale: estimate metres per uv unit from the edges.
  for (Face f : g.mesh().faces())
    for (Halfedge h : CGAL::halfedges_around_face(g.mesh().halfedge(f), g.mesh())) {
      length3 += g.rest_length(g.mesh().edge(h));
      length_uv += (g.uv(h) - g.uv(g.mesh().prev(h))).norm();
    }
  if (length_uv > 0 && std::isfinite(length3 / length_uv)) g.set_pattern_scale(length3 / length_uv);

  g.name = !mesh_name.empty() ? mesh_name : fs::path(path).stem().string();
  if (first_material) {
    aiColor4D c;
    if (first_material->Get(AI_MATKEY_BASE_COLOR, c) == AI_SUCCESS ||
        first_material->Get(AI_MATKEY_COLOR_DIFFUSE, c) == AI_SUCCESS)
      if (std::isfinite(c.r) && std::isfinite(c.g) && std::isfinite(c.b)) g.color = Vec3(c.r, c.g, c.b);
    g.texture() = read_texture(scene, first_material, path);
  }
  return g;
}

}  // namespace

}  // namespace kiji
