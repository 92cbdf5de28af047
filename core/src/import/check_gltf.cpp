// The glTF 2.0 that Kiji hands to assimp: see import_checks.h.
#include "import/import_checks.h"

#include "kiji/error.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace kiji::detail {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kMostDepth = 64;        // of the JSON; assimp's JSON reader recurses
constexpr int kMostExtrasDepth = 8;   // of a node's or scene's extras: assimp copies each level twice
constexpr int kMostNodeDepth = 256;   // of the node tree: assimp recurses twice a level

int depth(const json& value) {
  int most = 0;
  if (value.is_object() || value.is_array())
    for (const json& child : value) most = std::max(most, depth(child));
  return value.is_object() || value.is_array() ? most + 1 : 0;
}

std::uint64_t element_size(const json& accessor) {
  const std::string type = accessor["type"].get<std::string>();
  const std::uint64_t components = type == "SCALAR" ? 1 : type == "VEC2" ? 2 : type == "VEC3" ? 3 : type == "VEC4" ? 4
                                   : type == "MAT2"  ? 4 : type == "MAT3" ? 9 : 16;
  const long long c = accessor["componentType"].get<long long>();
  return components * (c == 5120 || c == 5121 ? 1 : c == 5122 || c == 5123 ? 2 : 4);
}

// A glTF document checked against what assimp 5.2's glTF 2 importer reads safely, everything else
// refused with its reason. Its importer reads accessors, buffer views and buffers by what they
// declare, checked against the wrong sizes or not at all (a byte offset that wraps, a stride below
// its element, a sparse accessor's parts); follows every node as often as it is listed (a node
// listed twice doubles the tree a level); builds faces past an index list too short for its mode;
// dereferences skins, morph targets and animation channels that lack their parts; and recurses
// through the JSON, the node tree and extras without a limit.
class GltfProfile {
 public:
  GltfProfile(const json& doc, const std::optional<std::string>& bin, fs::path folder, std::string what)
      : doc_(doc), bin_(bin), folder_(std::move(folder)), what_(std::move(what)) {}

  void check() {
    check_asset();
    check_extensions();
    for (std::size_t i = 0; i < size("buffers"); ++i) check_buffer(i);
    for (std::size_t i = 0; i < size("bufferViews"); ++i) check_view(i);
    for (std::size_t i = 0; i < size("accessors"); ++i) check_accessor(i);
    for (std::size_t i = 0; i < size("images"); ++i) check_image(i);
    for (std::size_t i = 0; i < size("meshes"); ++i) check_mesh(i);
    check_nodes();
    for (std::size_t i = 0; i < size("skins"); ++i) check_skin(i);
    for (std::size_t i = 0; i < size("animations"); ++i) check_animation(i);
  }

 private:
  [[noreturn]] void fail(const std::string& why) const {
    throw InputError(what_ + ": " + why + "; export the file again");
  }
  std::size_t size(const char* list) const {
    if (!doc_.contains(list)) return 0;
    if (!doc_[list].is_array()) fail(std::string("its glTF '") + list + "' is not a list");
    return doc_[list].size();
  }
  const json& item(const char* list, std::size_t i) const {
    const json& v = doc_[list][i];
    if (!v.is_object()) fail(std::string("its glTF ") + list + " " + std::to_string(i) + " is not an object");
    return v;
  }
  // An index into `list`, or a count or offset where list is null: a whole number, not 0.0.
  std::optional<std::uint64_t> number(const json& object, const char* key, const std::string& where,
                                      const char* list = nullptr) const {
    if (!object.contains(key)) return std::nullopt;
    const json& v = object[key];
    if (!v.is_number_unsigned())
      fail(where + "'s " + key + " is " + v.dump().substr(0, 40) + ", which is not a whole number");
    const std::uint64_t n = v.get<std::uint64_t>();
    if (list && n >= size(list)) fail(where + "'s " + key + " names " + list + " " + std::to_string(n) + ", which it lacks");
    return n;
  }

  std::uint64_t count(std::uint64_t accessor) const {
    return doc_["accessors"][accessor].value("count", std::uint64_t(0));  // a whole number: checked
  }

  void check_asset() const {
    const json* version = doc_.contains("asset") && doc_["asset"].is_object() && doc_["asset"].contains("version")
                              ? &doc_["asset"]["version"]
                              : nullptr;
    if (!version || !version->is_string() || version->get<std::string>().rfind("2.", 0) != 0)
      fail("it is not glTF 2.0 (its asset.version is " + (version ? version->dump().substr(0, 20) : "missing") + ")");
  }

  void check_extensions() const {
    // Draco writes attributes of any width into four-value buffers; the texture transform is read
    // without looking at its arrays' lengths.
    for (const char* list : {"extensionsUsed", "extensionsRequired"})
      if (doc_.contains(list) && doc_[list].is_array())
        for (const json& name : doc_[list])
          if (name == "KHR_draco_mesh_compression" || name == "KHR_texture_transform")
            fail("it uses the extension " + name.get<std::string>() + ", which Kiji does not read");
    for (const char* list : {"nodes", "scenes"})
      for (std::size_t i = 0; i < size(list); ++i)
        for (const char* key : {"extras", "extensions"})
          if (doc_[list][i].is_object() && doc_[list][i].contains(key) && depth(doc_[list][i][key]) > kMostExtrasDepth)
            fail(std::string("its ") + (list == std::string("nodes") ? "node " : "scene ") + std::to_string(i) + "'s " + key + " nest deeper than " +
                 std::to_string(kMostExtrasDepth) + " levels");
  }

  // A buffer's bytes as assimp reads them: a glb's BIN chunk for buffer 0 (whatever its uri), a
  // base64 data: URI, or a regular file beside the document.
  void check_buffer(std::size_t i) {
    const json& buffer = item("buffers", i);
    const std::string where = "its buffer " + std::to_string(i);
    const std::uint64_t length = number(buffer, "byteLength", where).value_or(0);
    std::string_view bytes;
    if (i == 0 && bin_) {
      bytes = *bin_;  // assimp takes a glb's binary chunk for buffer 0, whatever its uri
    } else if (buffer.contains("uri")) {
      if (!buffer["uri"].is_string()) fail(where + "'s uri is not text");
      owned_.push_back(std::make_unique<std::string>(read_uri(
          buffer["uri"].get<std::string>(), where, {"application/octet-stream", "application/gltf-buffer"}, length)));
      bytes = *owned_.back();
    } else {
      fail(where + " has no data (no uri, and no glb binary chunk)");
    }
    if (bytes.size() < length)
      fail(where + " declares " + std::to_string(length) + " bytes, but holds " + std::to_string(bytes.size()));
    buffers_[i] = bytes;
    lengths_[i] = length;
  }

  std::string read_uri(const std::string& uri, const std::string& where, const std::vector<std::string>& types,
                       std::uint64_t length) const {
    for (unsigned char c : uri)
      if (c < 0x20 || c == 0x7f) fail(where + "'s uri holds a control character");
    if (uri.rfind("data:", 0) == 0) {
      const std::size_t comma = uri.find(',');
      const std::string head = uri.substr(0, comma);
      bool known = false;
      for (const std::string& type : types) known = known || head == "data:" + type + ";base64";
      if (comma == std::string::npos || !known)
        fail(where + "'s data URI is not one of " + types.front() + " in base64 ('" + head.substr(0, 60) + "')");
      const std::optional<std::string> bytes = base64(std::string_view(uri).substr(comma + 1));
      if (!bytes) fail(where + "'s data URI is not valid base64");
      return *bytes;
    }
    // assimp opens the document's folder joined with the uri, as text; so is it opened here.
    if (uri.empty() || uri[0] == '/' || uri.find(':') != std::string::npos || uri.find("..") != std::string::npos ||
        uri.find('%') != std::string::npos || uri.find('\\') != std::string::npos)
      fail(where + "'s uri '" + uri.substr(0, 60) + "' is not a plain file name beside the document");
    const fs::path file = folder_.empty() ? fs::path(uri) : fs::path(folder_.string() + "/" + uri);
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) fail(where + "'s file '" + uri.substr(0, 60) + "' is not a file beside the document");
    std::ifstream in(file, std::ios::binary);
    std::string bytes(std::min<std::uint64_t>(length, fs::file_size(file, ec)), '\0');
    in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    bytes.resize(static_cast<std::size_t>(in.gcount()));
    return bytes;
  }

  // Strict base64: its alphabet, padding only at the end, whole groups of four.
  static std::optional<std::string> base64(std::string_view text) {
    if (text.size() % 4 != 0) return std::nullopt;
    std::string out;
    unsigned bits = 0, held = 0;
    for (std::size_t i = 0; i < text.size(); ++i) {
      const char c = text[i];
      if (c == '=') {
        if (i + 2 < text.size() || (i + 1 < text.size() && text[i + 1] != '=')) return std::nullopt;
        break;
      }
      const int v = c >= 'A' && c <= 'Z' ? c - 'A' : c >= 'a' && c <= 'z' ? c - 'a' + 26 : c >= '0' && c <= '9' ? c - '0' + 52
                    : c == '+' ? 62 : c == '/' ? 63 : -1;
      if (v < 0) return std::nullopt;
      bits = (bits << 6) | unsigned(v);
      held += 6;
      if (held >= 8) {
        held -= 8;
        out.push_back(static_cast<char>((bits >> held) & 0xff));
      }
    }
    return out;
  }

  void check_view(std::size_t i) const {
    const json& view = item("bufferViews", i);
    const std::string where = "its bufferView " + std::to_string(i);
    const std::uint64_t buffer = number(view, "buffer", where, "buffers").value_or(~0ull);
    if (buffer == ~0ull) fail(where + " names no buffer");
    const std::uint64_t offset = number(view, "byteOffset", where).value_or(0);
    const std::uint64_t length = number(view, "byteLength", where).value_or(0);
    const std::uint64_t room = lengths_.at(buffer);
    if (offset > room || length > room - offset)
      fail(where + " reaches byte " + std::to_string(offset) + " + " + std::to_string(length) + " of a buffer of " +
           std::to_string(room));
    if (const auto stride = number(view, "byteStride", where); stride && (*stride < 4 || *stride > 252 || *stride % 4))
      fail(where + "'s byteStride " + std::to_string(*stride) + " is not one glTF allows (4 to 252, a multiple of 4)");
  }

  void check_accessor(std::size_t i) const {
    const json& accessor = item("accessors", i);
    const std::string where = "its accessor " + std::to_string(i);
    static const char* const types[] = {"SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4"};
    const json type = accessor.contains("type") ? accessor["type"] : json();
    if (!type.is_string() || std::find(std::begin(types), std::end(types), type.get<std::string>()) == std::end(types))
      fail(where + "'s type " + type.dump().substr(0, 20) +
           " is not one of glTF's SCALAR, VEC2, VEC3, VEC4, MAT2, MAT3 and MAT4");
    static const int components[] = {5120, 5121, 5122, 5123, 5125, 5126};
    const json component = accessor.contains("componentType") ? accessor["componentType"] : json();
    if (!component.is_number_integer() ||
        std::find(std::begin(components), std::end(components), component.get<long long>()) == std::end(components))
      fail(where + "'s componentType " + component.dump().substr(0, 20) +
           " is not one of glTF's 5120, 5121, 5122, 5123, 5125 and 5126");
    if (accessor.contains("sparse")) fail(where + " is sparse, which Kiji does not read");
    const std::uint64_t elements = number(accessor, "count", where).value_or(0);
    const std::uint64_t offset = number(accessor, "byteOffset", where).value_or(0);
    const auto view_index = number(accessor, "bufferView", where, "bufferViews");
    if (!view_index) fail(where + " has no bufferView (its values would all be zero)");
    const json& view = doc_["bufferViews"][*view_index];
    const std::uint64_t element = element_size(accessor);
    const std::uint64_t stride = view.contains("byteStride") ? view["byteStride"].get<std::uint64_t>() : element;
    if (stride < element)
      fail(where + "'s elements of " + std::to_string(element) + " bytes overlap in its bufferView's stride of " +
           std::to_string(stride));
    const std::uint64_t length = view.contains("byteLength") ? view["byteLength"].get<std::uint64_t>() : 0;
    // In a long double: counts, strides and offsets of 64 bits cannot overflow it.
    const long double need = static_cast<long double>(offset) +
                             (elements == 0 ? 0.0L : static_cast<long double>(elements - 1) * stride + element);
    if (need > static_cast<long double>(length))
      fail(where + " reads " + std::to_string(elements) + " elements to byte " + std::to_string(std::uint64_t(std::min(need, 1e19L))) +
           " of a bufferView of " + std::to_string(length));
  }

  void check_image(std::size_t i) const {
    const json& image = item("images", i);
    const std::string where = "its image " + std::to_string(i);
    if (image.contains("mimeType")) {
      const json& mime = image["mimeType"];
      if (!mime.is_string() || (mime != "image/png" && mime != "image/jpeg"))
        fail(where + " has the MIME type " + mime.dump().substr(0, 40) + ", and glTF allows only \"image/png\" and \"image/jpeg\"");
    }
    number(image, "bufferView", where, "bufferViews");
    if (image.contains("uri")) {
      if (!image["uri"].is_string()) fail(where + "'s uri is not text");
      const std::string uri = image["uri"].get<std::string>();
      for (unsigned char c : uri)
        if (c < 0x20 || c == 0x7f) fail(where + "'s uri holds a control character");
      if (uri.rfind("data:", 0) == 0) read_uri(uri, where, {"image/png", "image/jpeg"}, 0);
    }
  }

  void check_mesh(std::size_t i) {
    const json& mesh = item("meshes", i);
    if (!mesh.contains("primitives") || !mesh["primitives"].is_array()) fail("its mesh " + std::to_string(i) + " has no primitives");
    const json& primitives = mesh["primitives"];
    for (std::size_t j = 0; j < primitives.size(); ++j) {
      const json& p = primitives[j];
      const std::string where = "its mesh " + std::to_string(i) + "'s primitive " + std::to_string(j);
      if (!p.is_object() || !p.contains("attributes") || !p["attributes"].is_object() || !p["attributes"].contains("POSITION"))
        fail(where + " has no POSITION attribute, so no vertices");
      for (const auto& [name, index] : p["attributes"].items()) number(p["attributes"], name.c_str(), where, "accessors");
      const std::uint64_t vertices = count(p["attributes"]["POSITION"].get<std::uint64_t>());
      if (p.contains("extensions")) fail(where + " has extensions, which Kiji does not read");
      const std::uint64_t mode = number(p, "mode", where).value_or(4);
      if (mode > 6) fail(where + "'s mode " + std::to_string(mode) + " is not one glTF defines (0 to 6)");
      std::uint64_t corners = vertices;
      if (const auto indices = number(p, "indices", where, "accessors")) {
        corners = count(*indices);
        check_indices(*indices, vertices, where);
      }
      // Strips, loops and fans read two or three corners whatever their count.
      const std::uint64_t least = mode == 2 || mode == 3 ? 2 : mode == 5 || mode == 6 ? 3 : 0;
      if (corners < least)
        fail(where + " has " + std::to_string(corners) + " corners, and its mode " + std::to_string(mode) + " needs " +
             std::to_string(least) + " at least");
      if (p.contains("targets")) {
        if (!p["targets"].is_array()) fail(where + "'s targets are not a list");
        for (const json& target : p["targets"]) {
          if (!target.is_object()) fail(where + "'s morph target is not an object");
          for (const auto& [name, index] : target.items()) {
            if (name != "POSITION" && name != "NORMAL" && name != "TANGENT")
              fail(where + "'s morph target has the attribute " + name.substr(0, 40) + " (glTF's are POSITION, NORMAL and TANGENT)");
            number(target, name.c_str(), where + "'s morph target", "accessors");
          }
        }
      }
    }
  }

  // Every index names one of the primitive's vertices: assimp builds strips, loops and fans from
  // the face before and leaves a face empty on a bad index, so the next reads through a null pointer.
  void check_indices(std::uint64_t index, std::uint64_t vertices, const std::string& where) {
    if (!checked_.insert({index, vertices}).second) return;
    const json& accessor = doc_["accessors"][index];
    const long long c = accessor["componentType"].get<long long>();
    if (accessor["type"] != "SCALAR" || (c != 5121 && c != 5123 && c != 5125))
      fail(where + "'s indices are not unsigned whole numbers (a SCALAR of 5121, 5123 or 5125)");
    const json& view = doc_["bufferViews"][accessor["bufferView"].get<std::size_t>()];
    if (view.contains("byteStride")) fail(where + "'s indices lie in a bufferView with a byteStride, which glTF forbids");
    const std::string_view bytes = buffers_.at(view["buffer"].get<std::uint64_t>());
    const std::uint64_t size = c == 5121 ? 1 : c == 5123 ? 2 : 4;
    const std::uint64_t start = (view.contains("byteOffset") ? view["byteOffset"].get<std::uint64_t>() : 0) +
                                (accessor.contains("byteOffset") ? accessor["byteOffset"].get<std::uint64_t>() : 0);
    const std::uint64_t n = count(index);
    const auto* data = reinterpret_cast<const unsigned char*>(bytes.data() + start);  // in bounds: checked above
    for (std::uint64_t i = 0; i < n; ++i) {
      std::uint64_t v = 0;
      for (std::uint64_t k = 0; k < size; ++k) v |= std::uint64_t(data[i * size + k]) << (8 * k);
      if (v >= vertices)
        fail(where + "'s index " + std::to_string(i) + " names vertex " + std::to_string(v) + ", but it has " +
             std::to_string(vertices));
    }
  }

  // A tree: each node the child of one parent at most and not also a root of the scene, and no
  // deeper than assimp's recursion copes with.
  void check_nodes() const {
    const std::size_t nodes = size("nodes");
    std::vector<int> parents(nodes, 0);
    for (std::size_t i = 0; i < nodes; ++i) {
      const json& node = item("nodes", i);
      const std::string where = "its node " + std::to_string(i);
      number(node, "mesh", where, "meshes");
      number(node, "skin", where, "skins");
      number(node, "camera", where, "cameras");
      if (!node.contains("children")) continue;
      if (!node["children"].is_array()) fail(where + "'s children are not a list");
      for (const json& child : node["children"]) {
        if (!child.is_number_unsigned() || child.get<std::uint64_t>() >= nodes)
          fail(where + " has the child " + child.dump().substr(0, 20) + ", which is not one of its nodes");
        if (++parents[child.get<std::size_t>()] > 1)
          fail("its node " + child.dump() + " is the child of two nodes (assimp would copy it, and all under it, twice)");
      }
    }
    const std::size_t scene = doc_.contains("scene") && doc_["scene"].is_number_unsigned() ? doc_["scene"].get<std::size_t>() : 0;
    if (scene >= size("scenes")) return;  // assimp's to refuse or to read without a scene
    const json& roots = item("scenes", scene).contains("nodes") ? doc_["scenes"][scene]["nodes"] : json::array();
    if (!roots.is_array()) fail("its scene " + std::to_string(scene) + "'s nodes are not a list");
    std::vector<std::pair<std::size_t, int>> stack;
    std::set<std::size_t> seen;
    for (const json& root : roots) {
      if (!root.is_number_unsigned() || root.get<std::uint64_t>() >= nodes)
        fail("its scene " + std::to_string(scene) + " has the node " + root.dump().substr(0, 20) + ", which it lacks");
      if (parents[root.get<std::size_t>()] > 0 || !seen.insert(root.get<std::size_t>()).second)
        fail("its node " + root.dump() + " is a root of its scene twice, or also a child (assimp would copy it twice)");
      stack.emplace_back(root.get<std::size_t>(), 1);
    }
    while (!stack.empty()) {
      const auto [node, level] = stack.back();
      stack.pop_back();
      if (level > kMostNodeDepth) fail("its node tree is deeper than " + std::to_string(kMostNodeDepth) + " levels");
      const json& n = doc_["nodes"][node];
      if (n.contains("children"))
        for (const json& child : n["children"])
          if (seen.insert(child.get<std::size_t>()).second) stack.emplace_back(child.get<std::size_t>(), level + 1);
    }
  }

  void check_skin(std::size_t i) const {
    const json& skin = item("skins", i);
    const std::string where = "its skin " + std::to_string(i);
    if (!skin.contains("joints") || !skin["joints"].is_array()) fail(where + " has no joints");
    for (const json& joint : skin["joints"])
      if (!joint.is_number_unsigned() || joint.get<std::uint64_t>() >= size("nodes"))
        fail(where + " has the joint " + joint.dump().substr(0, 20) + ", which is not one of its nodes");
    const auto matrices = number(skin, "inverseBindMatrices", where, "accessors");
    if (!matrices) fail(where + " has no inverseBindMatrices (assimp reads them anyway)");
    const json& accessor = doc_["accessors"][*matrices];
    if (accessor["type"] != "MAT4" || accessor["componentType"] != 5126 ||
        count(*matrices) < skin["joints"].size())
      fail(where + "'s inverseBindMatrices are not a float MAT4 for each of its " + std::to_string(skin["joints"].size()) +
           " joints");
  }

  void check_animation(std::size_t i) const {
    const json& animation = item("animations", i);
    const std::string where = "its animation " + std::to_string(i);
    if (!animation.contains("samplers") || !animation["samplers"].is_array() || !animation.contains("channels") ||
        !animation["channels"].is_array())
      fail(where + " has no samplers or no channels");
    const json& samplers = animation["samplers"];
    for (std::size_t s = 0; s < samplers.size(); ++s) {
      const json& sampler = samplers[s];
      const std::string at = where + "'s sampler " + std::to_string(s);
      if (!sampler.is_object()) fail(at + " is not an object");
      const auto input = number(sampler, "input", at, "accessors"), output = number(sampler, "output", at, "accessors");
      if (!input || !output) fail(at + " lacks its input or output");
      const std::uint64_t keys = count(*input), values = count(*output);
      const bool cubic = sampler.contains("interpolation") && sampler["interpolation"] == "CUBICSPLINE";
      if (keys == 0 || values < (cubic ? 3 * keys : keys))
        fail(at + " has " + std::to_string(keys) + " keys and " + std::to_string(values) + " values, too few for its keys");
    }
    for (const json& channel : animation["channels"]) {
      if (!channel.is_object() || !channel.contains("target") || !channel["target"].is_object())
        fail(where + " has a channel without a target");
      number(channel, "sampler", where + "'s channel", nullptr);
      if (!channel.contains("sampler") || channel["sampler"].get<std::uint64_t>() >= samplers.size())
        fail(where + " has a channel naming a sampler it lacks");
      if (!number(channel["target"], "node", where + "'s channel target", "nodes"))
        fail(where + " has a channel whose target names no node");
    }
  }

  const json& doc_;
  const std::optional<std::string>& bin_;
  fs::path folder_;
  std::string what_;
  std::map<std::uint64_t, std::string_view> buffers_;
  std::vector<std::unique_ptr<std::string>> owned_;
  std::map<std::uint64_t, std::uint64_t> lengths_;
  std::set<std::pair<std::uint64_t, std::uint64_t>> checked_;  // (indices accessor, vertices)
};

}  // namespace

void check_gltf_document(const std::string& text, const std::string& what, const std::optional<std::string>& bin,
                         const fs::path& folder) {
  // Each object's keys once (assimp's JSON reader keeps the first of a key, this one the last), and
  // no deeper than assimp's recursive reader copes with.
  std::vector<std::set<std::string>> keys;
  bool repeated = false, deep = false;
  const json doc = json::parse(
      text,
      [&](int level, json::parse_event_t event, json& value) {
        if (level > kMostDepth) deep = true;
        if (event == json::parse_event_t::object_start) keys.emplace_back();
        else if (event == json::parse_event_t::object_end && !keys.empty()) keys.pop_back();
        else if (event == json::parse_event_t::key && !keys.empty() && !keys.back().insert(value.get<std::string>()).second)
          repeated = true;
        return !deep;
      },
      /*allow_exceptions=*/false);
  if (doc.is_discarded() && !deep) throw InputError(what + ": its glTF JSON is not valid JSON; export the file again");
  if (deep) throw InputError(what + ": its glTF JSON nests deeper than " + std::to_string(kMostDepth) + " levels; export the file again");
  if (repeated) throw InputError(what + ": its glTF JSON gives an object the same key twice; export the file again");
  if (!doc.is_object()) throw InputError(what + ": its glTF JSON is not an object; export the file again");
  GltfProfile(doc, bin, folder, what).check();
}

}  // namespace kiji::detail
