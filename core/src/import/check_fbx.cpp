// An FBX file checked before assimp 5.2 reads it: the text form's connections, and the binary
// form walked as its binary tokenizer walks it: see import_checks.h.
#include "import/import_checks.h"

#include "kiji/error.h"

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace kiji::detail {

namespace {

struct FbxProperty {
  char type = 0;
  std::int64_t integer = 0;  // 'I' and 'L'; an array's length
  std::string text;          // 'S'
};

struct FbxRecord {
  std::string name;
  std::vector<FbxProperty> properties;
  std::vector<FbxRecord> children;
};

// What assimp 5.2's FBX reader does not survive, in the binary form: records nested past its
// recursion (24,000 deep overflowed the stack), compressed arrays that declare more than the file
// could inflate to (it allocates the declared size first: 6.3 GB from 785 bytes), models that are
// their own ancestors or the child of two parents (it recurses without end, or copies the tree
// twice a level), a negative layer index (written before its array), a layer without its index
// and an animation curve without keys (read through a null pointer).
class FbxBinary {
 public:
  FbxBinary(const std::string& bytes, std::string what) : bytes_(bytes), what_(std::move(what)) {}

  void check() {
    if (bytes_.size() < 27 || bytes_.compare(0, 18, "Kaydara FBX Binary") != 0) return;  // assimp's to refuse
    std::uint32_t version = 0;
    for (int k = 3; k >= 0; --k) version = (version << 8) | static_cast<unsigned char>(bytes_[23 + k]);
    wide_ = version >= 7500;
    std::size_t at = 27;
    std::vector<FbxRecord> top;
    while (at < bytes_.size()) {
      FbxRecord record;
      if (!read(at, bytes_.size(), record, 1)) break;
      top.push_back(std::move(record));
    }
    const long double room = 64.0L * bytes_.size() + (1 << 20);
    if (declared_ > room)
      fail("its compressed arrays declare " + std::to_string(std::uint64_t(declared_)) + " bytes, over 64 times the file's size");
    for (const FbxRecord& record : top) check_values(record);
    check_models(top);
  }

 private:
  [[noreturn]] void fail(const std::string& why) const { throw InputError(what_ + ": " + why + "; export the file again"); }

  std::uint64_t word(std::size_t& at, std::size_t width) const {
    if (at + width > bytes_.size()) fail("its FBX data ends inside a record");
    std::uint64_t v = 0;
    for (std::size_t k = width; k-- > 0;) v = (v << 8) | static_cast<unsigned char>(bytes_[at + k]);
    at += width;
    return v;
  }

  // ReadScope: a record ending at its end offset, its properties, then records nested in it up to a
  // sentinel of zeros.
  bool read(std::size_t& at, std::size_t end, FbxRecord& record, int depth) {
    if (depth > 64) fail("its FBX records nest deeper than 64 levels");
    const std::size_t width = wide_ ? 8 : 4;
    const std::uint64_t stop = word(at, width);
    if (stop == 0) return false;
    if (stop > end || stop < at) fail("its FBX record ends out of its bounds");
    const std::uint64_t count = word(at, width), length = word(at, width);
    const std::uint64_t name = word(at, 1);
    if (at + name > bytes_.size()) fail("its FBX data ends inside a record");
    record.name = bytes_.substr(at, name);
    at += name;
    const std::size_t begin = at;
    if (length > bytes_.size() - begin) fail("its FBX record's properties run past the file");
    for (std::uint64_t i = 0; i < count; ++i) record.properties.push_back(property(at, begin + length));
    if (at != begin + length) fail("its FBX record's properties do not fill their length");
    const std::size_t sentinel = wide_ ? 25 : 13;
    if (at < stop) {
      if (stop - at < sentinel) fail("its FBX record lacks its closing zeros");
      while (at < stop - sentinel) {
        FbxRecord child;
        if (read(at, stop - sentinel, child, depth + 1)) record.children.push_back(std::move(child));
      }
      at += sentinel;
    }
    if (at != stop) fail("its FBX record does not end where it says");
    return true;
  }

  FbxProperty property(std::size_t& at, std::size_t end) {
    if (at >= end) fail("its FBX record has fewer properties than it declares");
    FbxProperty p;
    p.type = bytes_[at++];
    switch (p.type) {
      case 'Y': at += 2; break;
      case 'C': at += 1; break;
      case 'I': p.integer = static_cast<std::int32_t>(word(at, 4)); break;
      case 'F': at += 4; break;
      case 'D': at += 8; break;
      case 'L': p.integer = static_cast<std::int64_t>(word(at, 8)); break;
      case 'R': at += word(at, 4); break;
      case 'S': {
        const std::uint64_t n = word(at, 4);
        if (n > end - std::min(at, end)) fail("its FBX string runs past its record");
        p.text = bytes_.substr(at, n);
        at += n;
        break;
      }
      case 'b': at = end; break;
      case 'f': case 'd': case 'l': case 'i': case 'c': {
        const std::uint64_t length = word(at, 4), encoding = word(at, 4), packed = word(at, 4);
        const std::uint64_t stride = p.type == 'd' || p.type == 'l' ? 8 : p.type == 'c' ? 1 : 4;
        if (encoding == 1) declared_ += static_cast<long double>(length) * stride;
        else if (encoding != 0 || std::uint32_t(length * stride) != packed) fail("its FBX array's encoding or size is not one FBX defines");
        p.integer = static_cast<std::int64_t>(length);
        at += packed;
        break;
      }
      default:
        fail("its FBX record has a property of the unknown type " + std::to_string(static_cast<unsigned char>(p.type)));
    }
    if (at > end) fail("its FBX property runs past its record");
    return p;
  }

  void check_values(const FbxRecord& record) const {
    if (record.name == "TypedIndex" && !record.properties.empty() && record.properties[0].integer < 0)
      fail("its FBX layer has the index " + std::to_string(record.properties[0].integer));
    if (record.name == "Layer" && record.properties.empty()) fail("its FBX geometry has a layer without its index");
    if (record.name == "KeyTime" && !record.properties.empty() && record.properties[0].integer == 0 &&
        std::string("ldif").find(record.properties[0].type) != std::string::npos)
      fail("its FBX animation curve has no keys");
    for (const FbxRecord& child : record.children) check_values(child);
  }

  // Each model the child of one parent at most, and its ancestors no loop and no deeper than 1000.
  // assimp takes an object for a model where its record's name begins the word "Model".
  void check_models(const std::vector<FbxRecord>& top) const {
    std::map<std::int64_t, bool> objects;  // id -> is a model
    std::map<std::int64_t, std::int64_t> parent;
    for (const FbxRecord& section : top) {
      if (section.name != "Objects") continue;
      for (const FbxRecord& object : section.children)
        if (!object.properties.empty() && object.properties[0].type == 'L')
          objects[object.properties[0].integer] =
              !object.name.empty() && std::string("Model").compare(0, object.name.size(), object.name) == 0;
    }
    for (const FbxRecord& section : top) {
      if (section.name != "Connections") continue;
      for (const FbxRecord& c : section.children) {
        if (c.name != "C" || c.properties.size() < 3 || c.properties[1].type != 'L' || c.properties[2].type != 'L') continue;
        const std::string& type = c.properties[0].text;
        if (type == "PP" || (type == "OP" && c.properties.size() > 3 && !c.properties[3].text.empty())) continue;
        const std::int64_t child = c.properties[1].integer, to = c.properties[2].integer;
        const auto model = objects.find(child);
        // assimp walks the tree from the root down through links whose child and parent are models.
        const auto up = objects.find(to);
        if (model == objects.end() || !model->second || (to != 0 && (up == objects.end() || !up->second))) continue;
        if (!parent.emplace(child, to).second)
          fail("its FBX model " + std::to_string(child) + " has two parents (assimp would copy it, and all under it, twice)");
      }
    }
    for (const auto& [model, up] : parent) {
      std::int64_t at = up;
      for (std::size_t steps = 0; at != 0; ++steps) {
        if (steps > 1000 || steps > parent.size()) fail("its FBX model " + std::to_string(model) + " is its own ancestor, or over 1000 deep");
        const auto next = parent.find(at);
        if (next == parent.end()) break;
        at = next->second;
      }
    }
  }

  const std::string& bytes_;
  std::string what_;
  bool wide_ = false;
  long double declared_ = 0;
};

}  // namespace

void check_fbx_binary(const std::string& bytes, const std::string& what) { FbxBinary(bytes, what).check(); }

// assimp 5.2 follows an FBX model's parents without looking for a loop: a model connected to
// itself, or two to each other, recurse until the stack overflows. The text form's connections
// ('C: "OO",child,parent') are read here; the binary form is left to assimp.
void check_fbx_text_connections(const std::string& path, const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  std::map<long long, std::vector<long long>> parents;
  std::set<long long> models;
  std::string line;
  while (std::getline(in, line)) {
    std::size_t at = line.find_first_not_of(" \t");
    if (at != std::string::npos && line.compare(at, 6, "Model:") == 0) {
      char* after = nullptr;
      const long long id = std::strtoll(line.c_str() + at + 6, &after, 10);
      if (after != line.c_str() + at + 6) models.insert(id);
      continue;
    }
    if (at == std::string::npos || line.compare(at, 2, "C:") != 0) continue;
    const std::size_t oo = line.find("\"OO\"", at);
    if (oo == std::string::npos) continue;
    const char* c = line.c_str() + oo + 4;
    long long ids[2];
    bool ok = true;
    for (long long& id : ids) {
      while (*c == ' ' || *c == '\t' || *c == ',') ++c;
      // As assimp reads an id token: its leading digits (none: 0), whatever follows them up to the
      // next separator ignored, so "2000!" is 2000 to it and must be here.
      const char* start = c;
      unsigned long long v = 0;
      for (; *c >= '0' && *c <= '9'; ++c)
        if (v < (1ull << 59)) v = v * 10 + static_cast<unsigned>(*c - '0');
      while (*c && *c != ',' && *c != ' ' && *c != '\t' && *c != '\r') ++c;
      ok = ok && c != start;
      id = static_cast<long long>(v);
    }
    if (ok) parents[ids[0]].push_back(ids[1]);
  }
  // Depth-first along parents: an object met again on its own path is its own ancestor.
  std::map<long long, int> state;  // 1: on the path, 2: done
  for (const auto& [start, unused] : parents) {
    if (state[start]) continue;
    std::vector<std::pair<long long, std::size_t>> stack{{start, 0}};
    state[start] = 1;
    while (!stack.empty()) {
      auto& [id, next] = stack.back();
      const auto found = parents.find(id);
      if (found == parents.end() || next == found->second.size()) {
        state[id] = 2;
        stack.pop_back();
        continue;
      }
      const long long parent = found->second[next++];
      if (state[parent] == 1)
        throw InputError(what + ": its FBX connections make object " + std::to_string(parent) +
                         " its own ancestor; export the file again");
      if (state[parent] == 0) {
        state[parent] = 1;
        stack.push_back({parent, 0});
      }
    }
  }
  // A model linked to two parent models (or to one twice) is copied, with all under it, once for
  // each: the tree doubles a level.
  for (const auto& [child, ups] : parents) {
    if (!models.count(child)) continue;
    int links = 0;
    for (long long up : ups) links += up == 0 || models.count(up);
    if (links > 1)
      throw InputError(what + ": its FBX model " + std::to_string(child) + " has two parents; export the file again");
  }
}

}  // namespace kiji::detail
