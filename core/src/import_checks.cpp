// Checks made on a model file before assimp reads it: see import_checks.h.
#include "import_checks.h"

#include "kiji/error.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string_view>

namespace kiji::detail {

namespace {

namespace fs = std::filesystem;

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

// assimp checks an OBJ face's indices only after it has built the meshes, and leaks them when it
// then refuses the file; the indices are checked here first, naming the line that is wrong.
// Positive indices may name any vertex of the file, negative ones count back from the face.
void check_obj_indices(const std::string& path, const std::string& what) {
  auto fail = [&](long long line, const std::string& text, const std::string& why) {
    throw InputError(what + ": line " + std::to_string(line) + " ('" +
                     text.substr(0, 80) + "') " + why + "; repair the file");
  };
  const char* const kinds[3] = {"vertex", "texture coordinate", "normal"};
  long long total[3] = {0, 0, 0};
  for (int pass = 0; pass < 2; ++pass) {
    std::ifstream in(path, std::ios::binary);
    long long so_far[3] = {0, 0, 0};
    long long number = 0;
    std::string line;
    while (std::getline(in, line)) {
      ++number;
      std::size_t at = line.find_first_not_of(" \t");
      if (at == std::string::npos) continue;
      const std::size_t end = line.find_first_of(" \t\r", at);
      const std::string key = line.substr(at, end == std::string::npos ? std::string::npos : end - at);
      if (key == "v" || key == "vt" || key == "vn") {
        ++so_far[key == "v" ? 0 : key == "vt" ? 1 : 2];
        continue;
      }
      if (pass == 0 || (key != "f" && key != "l" && key != "p") || end == std::string::npos) continue;
      // Each corner is v, v/vt, v//vn or v/vt/vn; what is not a number is left to assimp.
      const char* c = line.c_str() + end;
      while (*c) {
        while (*c == ' ' || *c == '\t' || *c == '\r') ++c;
        for (int component = 0; component < 3 && *c && *c != ' ' && *c != '\t' && *c != '\r'; ++component) {
          char* after = const_cast<char*>(c);
          errno = 0;
          const bool numeric = *c == '-' || *c == '+' || (*c >= '0' && *c <= '9');
          const long long i = numeric ? std::strtoll(c, &after, 10) : 0;
          if (after != c) {
            if (i == 0) fail(number, line, "refers to " + std::string(kinds[component]) + " 0 (OBJ counts from 1)");
            if (i > 0 && (i > total[component] || errno == ERANGE))
              fail(number, line, "refers to " + std::string(kinds[component]) + " " + std::to_string(i) +
                                     ", but the file has " + std::to_string(total[component]));
            if (i < 0 && (-i > so_far[component] || errno == ERANGE))
              fail(number, line, "refers to " + std::string(kinds[component]) + " " + std::to_string(i) +
                                     " (counted back), but only " + std::to_string(so_far[component]) +
                                     " come before it");
            c = after;
          }
          if (*c != '/') break;
          ++c;
        }
        while (*c && *c != ' ' && *c != '\t' && *c != '\r') ++c;
      }
    }
    std::copy(so_far, so_far + 3, total);
  }
}

// glTF allows only these two for an image (glTF 2.0, 5.18 image.mimeType).
void check_gltf_json(const std::string& text, const std::string& what) {
  const nlohmann::json doc = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) throw InputError(what + ": its glTF JSON is not valid JSON; export the file again");
  if (!doc.is_object() || !doc.contains("images")) return;
  const nlohmann::json& images = doc["images"];
  if (!images.is_array()) throw InputError(what + ": its glTF 'images' is not a list; export the file again");
  for (std::size_t i = 0; i < images.size(); ++i) {
    if (!images[i].is_object() || !images[i].contains("mimeType")) continue;
    const nlohmann::json& mime = images[i]["mimeType"];
    if (!mime.is_string() || (mime != "image/png" && mime != "image/jpeg"))
      throw InputError(what + ": its image " + std::to_string(i) + " has the MIME type " + mime.dump() +
                       ", and glTF allows only \"image/png\" and \"image/jpeg\"; export the file again");
  }
}

std::uint32_t le32(const char* p) {
  const auto* u = reinterpret_cast<const unsigned char*>(p);
  return u[0] | (u[1] << 8) | (u[2] << 16) | (std::uint32_t(u[3]) << 24);
}

// The word "ply" ending a line near the start of a file, as assimp finds a PLY file by its content
// (it need not be the very first bytes).
bool ply_magic(std::string_view head) {
  head = head.substr(0, 16);
  for (std::size_t at = head.find("ply"); at != std::string_view::npos; at = head.find("ply", at + 1)) {
    const bool starts = at == 0 || !std::isalnum(static_cast<unsigned char>(head[at - 1]));
    const bool ends = at + 3 < head.size() && (head[at + 3] == '\n' || head[at + 3] == '\r');
    if (starts && ends) return true;
  }
  return false;
}

}  // namespace

void check_before_assimp(const std::string& path, const std::string& what) {
  const std::string ext = lower_extension(path);
  if (ext == ".obj") {
    check_obj_indices(path, what);
    return;
  }
  std::ifstream in(path, std::ios::binary);
  char head[20] = {};
  in.read(head, sizeof head);
  const std::streamsize got = in.gcount();
  if (got >= 4 && std::memcmp(head, "glTF", 4) == 0) {
    // Binary glTF: a 12-byte header, then the JSON chunk (its length, "JSON", the text). A file
    // not laid out so is assimp's to refuse, as it does.
    std::error_code ec;
    const std::uintmax_t size = fs::file_size(path, ec);
    const std::uint32_t length = got == 20 ? le32(head + 12) : 0;
    if (got < 20 || std::memcmp(head + 16, "JSON", 4) != 0 || ec || length > size - 20) return;
    std::string text(length, '\0');
    in.read(text.data(), length);
    check_gltf_json(text, what);
  } else if (ext == ".gltf") {
    in.seekg(0);
    check_gltf_json(std::string(std::istreambuf_iterator<char>(in), {}), what);
  } else if (ext == ".ply" || ply_magic(std::string_view(head, static_cast<std::size_t>(got)))) {
    // assimp takes a file for PLY by the word near its start, not only at it. The header is text and
    // short; one whose first 64 KiB hold no whole end_header line never ends it (assimp then reads on
    // without end).
    in.clear();
    in.seekg(0);
    std::string start(64 * 1024, '\0');
    in.read(start.data(), static_cast<std::streamsize>(start.size()));
    start.resize(static_cast<std::size_t>(in.gcount()));
    const std::size_t at = start.find("\nend_header");
    const std::size_t after = at == std::string::npos ? at : at + 11;
    const bool line_ends = after != std::string::npos && after < start.size() &&
                           (start[after] == '\n' || (start[after] == '\r' && after + 1 < start.size() && start[after + 1] == '\n'));
    if (!line_ends)
      throw InputError(what + ": its PLY header has no end_header line in its first 64 KiB; export the file again");
  }
}

}  // namespace kiji::detail
