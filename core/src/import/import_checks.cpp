// Checks made on a model file around assimp's reading of it: see import_checks.h.
#include "import/import_checks.h"

#include "kiji/error.h"

#include <assimp/BaseImporter.h>
#include <assimp/DefaultIOSystem.h>
#include <assimp/IOStream.hpp>
#include <assimp/ai_assert.h>
#include <assimp/Importer.hpp>
#include <assimp/scene.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

// Debian builds assimp with its assertions on, and a failed one ends the process (a Collada
// primitive whose count differs from its list, a <skew>, an empty image path). Defined here, ahead
// of assimp's own in the order symbols are looked up, a failed assertion throws instead, and the
// import ends with its message as with any other error.
namespace Assimp {
void aiAssertViolation(const char* expression, const char* file, int line) {
  throw std::runtime_error(std::string("its check '") + expression + "' failed at " + file + ":" + std::to_string(line));
}
}  // namespace Assimp

namespace kiji::detail {

namespace fs = std::filesystem;

std::string lowercase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

std::string lower_extension(const std::string& path) { return lowercase(fs::path(path).extension().string()); }

namespace {

std::uint32_t le32(const char* p) {
  const auto* u = reinterpret_cast<const unsigned char*>(p);
  return u[0] | (u[1] << 8) | (u[2] << 16) | (std::uint32_t(u[3]) << 24);
}

// What assimp (5.2) would crash on, hang on or leak on, refused first: see prepare_importer.
void check_before_assimp(const std::string& path, const std::string& what) {
  const std::string ext = lower_extension(path);
  if (ext == ".obj") {
    check_obj_indices(path, what);
    return;
  }
  std::ifstream in(path, std::ios::binary);
  char head[21] = {};  // 20 bytes and a NUL
  in.read(head, sizeof head - 1);
  const std::streamsize got = in.gcount();
  // assimp 5.2 gives a file to the first importer that takes it, some by name and some by content,
  // so every check whose format the file may be read as is made.
  if (got >= 4 && std::memcmp(head, "glTF", 4) == 0) {
    // Binary glTF: a 12-byte header, then the JSON chunk (its length, "JSON", the text), then the
    // BIN chunk if the header's length leaves room for one. A file not laid out so is assimp's to
    // refuse, as it does; assimp allocates and fills what a chunk declares before reading it, so a
    // chunk longer than the file is refused here.
    std::error_code ec;
    const std::uintmax_t size = fs::file_size(path, ec);
    if (got < 20 || std::memcmp(head + 16, "JSON", 4) != 0 || ec) return;
    const std::uint32_t length = le32(head + 12);
    auto too_long = [&](const char* chunk, std::uint64_t declared, std::uint64_t room) {
      throw InputError(what + ": its glb " + chunk + " chunk declares " + std::to_string(declared) +
                       " bytes, but the file has " + std::to_string(room) + " after its start; the file is cut or corrupt, export it again");
    };
    if (length > size - 20) too_long("JSON", length, size - 20);
    std::string text(length, '\0');
    in.read(text.data(), length);
    const std::uint64_t bin = (20 + std::uint64_t(length) + 3) & ~std::uint64_t(3);
    char chunk[8] = {};
    if (bin < le32(head + 8) && bin + 8 <= size) {
      in.seekg(static_cast<std::streamoff>(bin));
      in.read(chunk, sizeof chunk);
      if (in.gcount() == 8 && std::memcmp(chunk + 4, "BIN", 4) == 0 && le32(chunk) > size - bin - 8)
        too_long("BIN", le32(chunk), size - bin - 8);
    }
    std::optional<std::string> data;
    if (in.gcount() == 8 && std::memcmp(chunk + 4, "BIN", 4) == 0) {
      data.emplace(le32(chunk), '\0');
      in.read(data->data(), static_cast<std::streamsize>(data->size()));
    }
    check_gltf_document(text, what, data, fs::path(path).parent_path());
  } else if (ext == ".gltf" || (got > 0 && head[std::strspn(head, " \t\r\n")] == '{')) {
    // A glTF document by name, or JSON that assimp may take for one by its content.
    in.clear();
    in.seekg(0);
    check_gltf_document(std::string(std::istreambuf_iterator<char>(in), {}), what, std::nullopt, fs::path(path).parent_path());
  }
  if (ext == ".fbx" || std::string_view(head, static_cast<std::size_t>(got)).find("; FBX") != std::string_view::npos) {
    if (std::string_view(head, static_cast<std::size_t>(got)).rfind("Kaydara", 0) != 0) {
      check_fbx_text_connections(path, what);
    } else {
      in.clear();
      in.seekg(0);
      check_fbx_binary(std::string(std::istreambuf_iterator<char>(in), {}), what);
    }
  }
  if (ext == ".stl" || stl_magic(path)) {
    in.clear();
    in.seekg(0);
    check_stl(std::string(std::istreambuf_iterator<char>(in), {}), what);
  }
  if (ext == ".off" || off_magic(std::string_view(head, static_cast<std::size_t>(got)))) {
    in.clear();
    in.seekg(0);
    check_off(std::string(std::istreambuf_iterator<char>(in), {}), what);
  }
  if (got >= 4 && std::memcmp(head, "PK\x03\x04", 4) == 0) {
    check_zipped_collada(path, what);
  }
  if (ext == ".dae" || collada_magic(path)) {
    in.clear();
    in.seekg(0);
    check_collada(std::string(std::istreambuf_iterator<char>(in), {}), what);
  }
  if (ext == ".ply" || ply_magic(std::string_view(head, static_cast<std::size_t>(got)))) {
    // assimp takes a file for PLY by the word near its start, not only at it. The header is text and
    // short; one whose first 64 KiB hold no whole end_header line never ends it (assimp then reads on
    // without end).
    in.clear();
    in.seekg(0);
    std::string bytes(std::istreambuf_iterator<char>(in), {});
    const std::string_view start = std::string_view(bytes).substr(0, 64 * 1024);
    const std::size_t at = start.find("\nend_header");
    const std::size_t after = at == std::string::npos ? at : at + 11;
    const bool line_ends = after != std::string::npos && after < start.size() &&
                           (start[after] == '\n' || (start[after] == '\r' && after + 1 < start.size() && start[after + 1] == '\n'));
    if (!line_ends)
      throw InputError(what + ": its PLY header has no end_header line in its first 64 KiB; export the file again");
    const std::size_t data = after + (start[after] == '\r' ? 2 : 1);
    check_ply_header(bytes, at, data, what);
    check_ply_as_assimp_reads(bytes, what);
  }
}

// assimp's MTL reader writes through a null material where a texture or anisotropy statement
// comes before the file's first newmtl (a segmentation fault). Which material files an OBJ opens
// (its mtllib lines, relative paths, a fallback to its own name) is assimp's to decide, so each is
// checked as assimp opens it.
class CheckingIOSystem : public Assimp::DefaultIOSystem {
 public:
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    Assimp::IOStream* stream = DefaultIOSystem::Open(file, mode);
    if (stream && lower_extension(file) == ".mtl") {
      std::string bytes(stream->FileSize(), '\0');
      bytes.resize(stream->Read(bytes.data(), 1, bytes.size()));
      stream->Seek(0, aiOrigin_SET);
      if (const std::string why = mtl_problem(bytes); !why.empty()) {
        Close(stream);
        throw std::runtime_error("its material file '" + std::string(file) + "' " + why);
      }
    }
    return stream;
  }
};

}  // namespace

void prepare_importer(Assimp::Importer& importer, const std::string& path, const std::string& what) {
  importer.SetIOHandler(new CheckingIOSystem);  // the importer's to delete
  if (Assimp::BaseImporter* ogex = importer.GetImporter("ogex")) {
    // Unregistered, the importer is no longer the Importer's to delete.
    if (importer.UnregisterLoader(ogex) == aiReturn_SUCCESS) delete ogex;
  }
  // As assimp picks an importer: by the whole end of the name, case aside.
  const std::string lower = lowercase(path);
  std::vector<Assimp::BaseImporter*> candidates;
  std::string matched;
  for (std::size_t i = 0; i < importer.GetImporterCount(); ++i) {
    Assimp::BaseImporter* candidate = importer.GetImporter(i);
    std::set<std::string> extensions;
    candidate->GetExtensionList(extensions);
    for (const std::string& e : extensions) {
      const std::string end = "." + e;
      if (end.size() <= lower.size() && lower.compare(lower.size() - end.size(), end.size(), end) == 0) {
        candidates.push_back(candidate);
        matched = end;
        break;
      }
    }
  }
  // A name no importer claims would be tried by content on every importer assimp has, most of them
  // neither checked here nor fuzzed: Kiji reads a file by its extension only.
  if (candidates.empty()) {
    const std::string ext = fs::path(path).extension().string();
    throw InputError(what + ": " + (ext.empty() ? std::string("its name has no extension") : "its extension '" + ext + "' is not one assimp reads") +
                     ": name the file after its format (.obj, .fbx, .dae, .zae, .glb, .gltf, .ply, .stl, .off, ...)");
  }
  check_before_assimp(path, what);
  if (candidates.size() < 2) return;
  for (Assimp::BaseImporter* candidate : candidates)
    if (candidate->CanRead(path, importer.GetIOHandler(), true)) return;
  throw InputError(what + ": assimp cannot read it as a " + matched + " file (its content is not laid out as one): " +
                   "export it again, or name it after its real format");
}

void post_process(Assimp::Importer& importer, unsigned post_processing, const std::string& what) {
  // The importer's own scene, changed in place as its post-processing steps change it.
  aiScene* scene = const_cast<aiScene*>(importer.GetScene());
  if (!scene) throw InputError(what + ": assimp gave no scene");
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    aiMesh* mesh = scene->mMeshes[m];
    if (!mesh) throw InputError(what + ": its mesh " + std::to_string(m) + " is missing; export it again");
    unsigned types = 0;
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      auto fail = [&](const std::string& why) {
        throw InputError(what + ": its mesh " + std::to_string(m) + " ('" + mesh->mName.C_Str() + "') has a face (" +
                         std::to_string(f) + ") " + why + "; repair the file");
      };
      if (face.mNumIndices == 0 || !face.mIndices) fail("of no corners");
      for (unsigned k = 0; k < face.mNumIndices; ++k)
        if (face.mIndices[k] >= mesh->mNumVertices)
          fail("naming vertex " + std::to_string(face.mIndices[k]) + " of " + std::to_string(mesh->mNumVertices));
      types |= face.mNumIndices == 1   ? aiPrimitiveType_POINT
               : face.mNumIndices == 2 ? aiPrimitiveType_LINE
               : face.mNumIndices == 3 ? aiPrimitiveType_TRIANGLE
                                       : aiPrimitiveType_POLYGON;
    }
    mesh->mPrimitiveTypes = types;
  }
  const aiScene* processed = nullptr;
  try {
    processed = importer.ApplyPostProcessing(post_processing);
  } catch (const std::exception& e) {
    throw InputError(what + ": assimp could not process it (" + e.what() + "); export it again");
  }
  if (!processed) {
    std::string err = importer.GetErrorString();
    throw InputError(what + ": assimp could not process it (" + (err.empty() ? std::string("no reason given") : err) +
                     "); export it again");
  }
}

}  // namespace kiji::detail
