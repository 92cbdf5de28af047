// Garment files read back through assimp (.glb, .gltf, .obj), in a child process under limits.
#include "kiji/io.h"

#include "kiji/error.h"
#include "import/import_checks.h"
#include "import/isolated.h"
#include "kiji/codec.h"
#include "base/png_codec.h"

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
