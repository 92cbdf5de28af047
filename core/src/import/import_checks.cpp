// Checks made on a model file around assimp's reading of it: see import_checks.h.
#include "import/import_checks.h"

#include "kiji/error.h"

#include <assimp/BaseImporter.h>
#include <assimp/DefaultIOSystem.h>
#include <assimp/IOStream.hpp>
#include <assimp/ai_assert.h>
#include <assimp/Importer.hpp>
#include <assimp/scene.h>

#include <nlohmann/json.hpp>
#include <unzip.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <sstream>
#include <string_view>
#include <utility>
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

namespace {

namespace fs = std::filesystem;

std::string lowercase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

std::string lower_extension(const std::string& path) { return lowercase(fs::path(path).extension().string()); }

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
  // assimp ends a line at "\r", NUL and a form feed as well as "\n": a face after a lone "\r" is
  // a face to it, so lines are split here as it splits them.
  std::string text;
  {
    std::ifstream in(path, std::ios::binary);
    text.assign(std::istreambuf_iterator<char>(in), {});
    std::string split;
    split.reserve(text.size());
    for (std::size_t i = 0; i < text.size(); ++i) {
      const char c = text[i];
      if (c == '\r' && i + 1 < text.size() && text[i + 1] == '\n') continue;
      split += c == '\r' || c == '\0' || c == '\f' ? '\n' : c;
    }
    text.swap(split);
  }
  // What assimp builds for each group, object and material name costs hundreds of times its line
  // (390 times for groups, 2,800 for materials: gigabytes from a few megabytes), it searches its
  // objects one by one for each name and re-reads a material file for each mtllib line (minutes
  // from 1 MB), and its triangulation takes a time that grows with the square of a face's corners.
  constexpr long long kMostGroups = 20000, kMostObjects = 10000, kMostMaterials = 1024, kMostLibraries = 16,
                      kMostCorners = 1000;
  long long groups = 0, objects = 0, libraries = 0;
  std::set<std::string> materials;
  for (int pass = 0; pass < 2; ++pass) {
    std::istringstream in(text);
    long long so_far[3] = {0, 0, 0};
    long long number = 0;
    std::string line;
    while (std::getline(in, line)) {
      ++number;
      std::size_t at = line.find_first_not_of(" \t");
      if (at == std::string::npos) continue;
      const std::size_t end = line.find_first_of(" \t\r", at);
      const std::string key = line.substr(at, end == std::string::npos ? std::string::npos : end - at);
      if (pass == 0) {
        const bool too_many = (key[0] == 'g' && ++groups > kMostGroups) || (key[0] == 'o' && ++objects > kMostObjects) ||
                              (key == "mtllib" && ++libraries > kMostLibraries) ||
                              (key == "usemtl" && materials.insert(line.substr(at)).second &&
                               static_cast<long long>(materials.size()) > kMostMaterials);
        if (too_many)
          fail(number, line, "is one over the most Kiji reads (" + std::to_string(kMostGroups) + " groups, " +
                                 std::to_string(kMostObjects) + " objects, " + std::to_string(kMostMaterials) +
                                 " material names, " + std::to_string(kMostLibraries) + " mtllib lines)");
      }
      // As assimp tells lines apart: by their first characters, not their whole first word ("vtx"
      // is a texture coordinate, "f/" a face).
      const bool texture = key.rfind("vt", 0) == 0, normal = key.rfind("vn", 0) == 0;
      if (key == "v" || texture || normal) {
        ++so_far[texture ? 1 : normal ? 2 : 0];
        continue;
      }
      if (pass == 0 || (key[0] != 'f' && key[0] != 'l' && key[0] != 'p')) continue;
      // Its face reader runs on past a character it does not expect (a vertical tab, a
      // continuation) into what earlier lines left in its buffer, taking their numbers for corners.
      for (std::size_t i = key.size() + at; i < line.size() && line[i] != '#'; ++i)
        if (!std::isdigit(static_cast<unsigned char>(line[i])) && std::string_view(" \t/+-").find(line[i]) == std::string_view::npos)
          fail(number, line, "holds a character (byte " + std::to_string(static_cast<unsigned char>(line[i])) +
                                 ") that is not a number, a slash or a space");
      {
        std::istringstream words(line.substr(key.size() + at));
        long long corners = 0;
        for (std::string word; words >> word && word[0] != '#';) ++corners;
        if (corners > kMostCorners)
          fail(number, line, "has " + std::to_string(corners) + " corners, and Kiji reads " + std::to_string(kMostCorners) + " at most");
      }
      if (key[0] == 'l') {
        // A line of one corner gets no room in assimp's arrays, yet it moves on by one: the next
        // line's corners are written past their end.
        std::istringstream words(line.substr(key.size() + at));
        int corners = 0;
        for (std::string word; words >> word && word[0] != '#';) ++corners;
        if (corners < 2) fail(number, line, "is a line of " + std::to_string(corners) + " corners; a line has 2 at least");
      }
      if (end == std::string::npos) continue;
      // Each corner is v, v/vt, v//vn or v/vt/vn (a slash may end it); assimp reads other shapes,
      // such as '////////4444', past the end of its line.
      std::istringstream corners(line.substr(end));
      for (std::string corner; corners >> corner;) {
        if (corner[0] == '#') break;  // a comment ends the line
        auto bad = [&] {
          fail(number, line, "has the corner '" + corner.substr(0, 40) + "', which is not v, v/vt, v//vn or v/vt/vn");
        };
        std::size_t at = 0;
        for (int component = 0; component < 3; ++component) {
          if (component > 0) {
            if (at == corner.size()) break;
            if (corner[at] != '/') bad();
            ++at;
            if (at == corner.size()) break;
            if (component == 1 && corner[at] == '/') continue;  // v//vn
          }
          const char* from = corner.c_str() + at;
          char* after = const_cast<char*>(from);
          errno = 0;
          const bool numeric = *from == '-' || *from == '+' || (*from >= '0' && *from <= '9');
          const long long i = numeric ? std::strtoll(from, &after, 10) : 0;
          if (after == from) bad();
          if (i == 0) fail(number, line, "refers to " + std::string(kinds[component]) + " 0 (OBJ counts from 1)");
          // Out of range first: strtoll then gives LLONG_MIN, which cannot be negated.
          if (i > 0 && (errno == ERANGE || i > total[component]))
            fail(number, line, "refers to " + std::string(kinds[component]) + " " + std::to_string(i) +
                                   ", but the file has " + std::to_string(total[component]));
          if (i < 0 && (errno == ERANGE || -i > so_far[component]))
            fail(number, line, "refers to " + std::string(kinds[component]) + " " + std::to_string(i) +
                                   " (counted back), but only " + std::to_string(so_far[component]) +
                                   " come before it");
          at = static_cast<std::size_t>(after - corner.c_str());
        }
        if (at != corner.size()) bad();
      }
    }
    std::copy(so_far, so_far + 3, total);
  }
}


// assimp 5.2's OFF reader does not move on to the next face when it drops one of 0 or over 9
// corners, but still counts it off the mesh's faces: enough of them wrap that count and it reads
// past its arrays. It also allocates what the header declares before reading a line, and copies a
// assimp's number reader (fast_atoreal_move) does not move past an integer part of 20 digits or
// more (it overflows 64 bits), and the warning it logs copies all the text after it: a reader that
// loops over values then reads the same number again and again, copying the rest of the file each
// time (a 1 MB ASCII STL of such numbers took 44 s). Digits after a decimal point are cut at 15
// and never overflow. The position of such a number in `text`, if it holds one.
std::optional<std::size_t> long_integer(std::string_view text) {
  for (std::size_t i = 0; i < text.size();) {
    if (!std::isdigit(static_cast<unsigned char>(text[i]))) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j < text.size() && std::isdigit(static_cast<unsigned char>(text[j]))) ++j;
    if (j - i >= 20 && (i == 0 || (text[i - 1] != '.' && text[i - 1] != ','))) return i;
    i = j;
  }
  return std::nullopt;
}

// An STL file as assimp 5.2 reads it: after its text reader (a UTF-8 byte order mark dropped; a
// UTF-32 one converted past the end of its buffer), binary where its 32-bit face count makes the
// file's size, else ASCII from "solid".
void check_stl(const std::string& bytes, const std::string& what) {
  if (bytes.size() >= 8 && bytes.rfind(std::string("\xFE\xFF\0\0", 4), 0) == 0)
    throw InputError(what + ": it starts with a UTF-32 byte order mark, which assimp reads past its buffer; "
                     "save it as ASCII or binary STL");
  std::string_view text = bytes;
  if (bytes.size() >= 8 && bytes.rfind("\xEF\xBB\xBF", 0) == 0) text.remove_prefix(3);
  if (text.size() >= 84) {
    std::uint32_t faces = 0;
    std::memcpy(&faces, text.data() + 80, sizeof faces);
    if (std::uint32_t(faces * 50u + 84u) == bytes.size()) return;
  }
  const std::size_t start = text.find_first_not_of(" \t");
  if (start == std::string_view::npos || text.compare(start, 5, "solid") != 0) return;  // assimp's to refuse
  if (const auto at = long_integer(text))
    throw InputError(what + ": its ASCII STL has an integer of 20 digits or more at byte " + std::to_string(*at) +
                     " ('" + std::string(text.substr(*at, 24)) + "...'), which assimp cannot read past; export the "
                     "file again");
}

// line into a 4 KiB buffer. The header and the faces are read here as that reader reads them.
class OffReader {
 public:
  OffReader(std::string text, std::string what) : s_(std::move(text)), what_(std::move(what)) {
    // assimp's text reader drops a UTF-8 byte order mark from a file of 8 bytes or more, and
    // misreads UTF-16 and UTF-32 (it reads past its buffer converting the one, and keeps the bytes
    // it converted the other from).
    if (s_.size() >= 8 && s_.rfind("\xEF\xBB\xBF", 0) == 0) s_.erase(0, 3);
    else if (s_.size() >= 8 && (s_.rfind("\xFE\xFF", 0) == 0 || s_.rfind("\xFF\xFE", 0) == 0 ||
                                s_.rfind(std::string("\0\0\xFE\xFF", 4), 0) == 0))
      fail("it is UTF-16 or UTF-32 text, which assimp's OFF reader misreads (save it as ASCII or UTF-8)");
    // assimp reads the lines as C strings: they end at the first NUL.
    s_.resize(std::min(s_.size(), s_.find('\0')));
  }

  void check() {
    next_token();
    bool has_dimension = false;
    if (starts("ST")) at_ += 2;
    for (char flag : {'C', 'N', '4', 'n'})
      if (at_ + 1 < s_.size() && s_[at_] == flag) {
        has_dimension = flag == 'n';
        ++at_;
      }
    if (starts("OFF")) at_ += 3;
    next_token();
    if (has_dimension) {
      number();
      next_token();
    }
    next_token();
    const unsigned vertices = number();
    next_token();
    const unsigned faces = number();
    next_token();
    number();
    next_token();
    // assimp refuses these too; a header read as nothing here must not let a file through unread.
    if (vertices == 0 || faces == 0)
      fail("its OFF header declares " + std::to_string(vertices) + " vertices and " + std::to_string(faces) +
           " faces (or Kiji cannot read it as assimp does)");
    // Every line but the last takes two bytes at least.
    const std::size_t room = (s_.size() - std::min(at_, s_.size())) / 2 + 1;
    if (std::size_t(vertices) + faces > room)
      fail("its OFF header declares " + std::to_string(vertices) + " vertices and " + std::to_string(faces) +
           " faces, more lines than the file's " + std::to_string(s_.size()) + " bytes can hold");
    // assimp leaves the faces it finds no line for empty, and its triangulation then aborts.
    std::string_view line;
    for (unsigned i = 0; i < vertices; ++i)
      if (!next_line(line))
        fail("its OFF header declares " + std::to_string(vertices) + " vertices, but the file has " + std::to_string(i) +
             " vertex lines and no faces");
    for (unsigned i = 0; i < faces; ++i) {
      if (!next_line(line))
        fail("its OFF header declares " + std::to_string(faces) + " faces, but the file has " + std::to_string(i) +
             " face lines");
      const std::string where = "its OFF face " + std::to_string(i + 1) + " (line " + std::to_string(current_line_) + ", '" +
                                std::string(line.substr(0, 60)) + "')";
      std::size_t c = 0;
      const unsigned corners = number_in(line, c);
      if (corners == 0 || corners > 9)
        fail(where + " has " + std::to_string(corners) + " corners, and an OFF face here has 1 to 9");
      for (unsigned k = 0; k < corners; ++k) {
        const unsigned v = number_in(line, c);
        if (v >= vertices)
          fail(where + " refers to vertex " + std::to_string(v) + ", but the file has " + std::to_string(vertices) +
               " (OFF counts from 0)");
      }
    }
  }

 private:
  [[noreturn]] void fail(const std::string& why) const { throw InputError(what_ + ": " + why + "; repair the file"); }
  static bool line_end(char c) { return c == '\r' || c == '\n' || c == '\0' || c == '\f'; }
  char at(std::size_t i) const { return i < s_.size() ? s_[i] : '\0'; }
  bool starts(const char* word) const { return s_.compare(std::min(at_, s_.size()), std::strlen(word), word) == 0; }

  void skip_spaces_and_line_ends() {
    while (at_ < s_.size() && (s_[at_] == ' ' || s_[at_] == '\t' || s_[at_] == '\r' || s_[at_] == '\n')) {
      if (s_[at_] == '\n') ++line_number_;
      ++at_;
    }
  }
  void next_token() {
    skip_spaces_and_line_ends();
    while (at_ < s_.size() && (s_[at_] == '#' || s_[at_] == '\n' || s_[at_] == '\r')) {
      // A comment ends as assimp's SkipLine ends it: not at a form feed.
      while (at(at_) != '\r' && at(at_) != '\n' && at(at_) != '\0') ++at_;
      skip_spaces_and_line_ends();
    }
  }
  // assimp's strtoul10: decimal digits into an unsigned int, wrapping as it does.
  unsigned number() {
    unsigned value = 0;
    while (at(at_) >= '0' && at(at_) <= '9') value = value * 10 + unsigned(s_[at_++] - '0');
    return value;
  }
  static unsigned number_in(std::string_view line, std::size_t& c) {
    while (c < line.size() && (line[c] == ' ' || line[c] == '\t')) ++c;
    unsigned value = 0;
    while (c < line.size() && line[c] >= '0' && line[c] <= '9') value = value * 10 + unsigned(line[c++] - '0');
    return value;
  }
  // assimp's GetNextLine: a line up to its end, then every line end after it (blank lines vanish).
  bool next_line(std::string_view& line) {
    if (at_ >= s_.size()) return false;
    const std::size_t start = at_;
    while (!line_end(at(at_))) ++at_;
    line = std::string_view(s_).substr(start, at_ - start);
    current_line_ = line_number_;
    while (at_ < s_.size() && line_end(s_[at_])) {
      if (s_[at_] == '\n') ++line_number_;
      ++at_;
    }
    if (line.size() >= kLineBuffer)
      fail("its line " + std::to_string(current_line_) + " is " + std::to_string(line.size()) +
           " characters long, and assimp's OFF reader reads up to " + std::to_string(kLineBuffer - 1));
    return true;
  }

  static constexpr std::size_t kLineBuffer = 4096;
  std::string s_;
  std::string what_;
  std::size_t at_ = 0;
  long long line_number_ = 1;
  long long current_line_ = 1;
};

// assimp takes a file for STL by "solid" or "stl" in its first 200 bytes, whatever its name.
bool stl_magic(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string head(200, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  head = lowercase(head);
  return head.find("solid") != std::string::npos || head.find("stl") != std::string::npos;
}

// assimp takes a file for OFF by "off" in its first three bytes, whatever its name.
bool off_magic(std::string_view head) { return lowercase(std::string(head.substr(0, 3))).find("off") != std::string::npos; }

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
      char* after = nullptr;
      id = std::strtoll(c, &after, 10);
      ok = ok && after != c;
      c = after;
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

// The size of a PLY property type in a binary file, or 0 for a name PLY does not define.
std::size_t ply_type_size(const std::string& type) {
  static const std::map<std::string, std::size_t> sizes = {
      {"char", 1},  {"int8", 1},    {"uchar", 1},  {"uint8", 1},   {"short", 2},   {"int16", 2},  {"ushort", 2},
      {"uint16", 2}, {"int", 4},    {"int32", 4},  {"uint", 4},    {"uint32", 4},  {"float", 4},  {"float32", 4},
      {"double", 8}, {"float64", 8}, {"double64", 8}};
  const auto it = sizes.find(type);
  return it == sizes.end() ? 0 : it->second;
}

// A PLY header's lines as the format defines them, one a line: each element and property line well
// formed and of types PLY defines, one format line before the elements, each element once and with
// properties, and no element count the rest of the file cannot hold. Header lines PLY does not define
// (Blender 2.47 wrote one) are passed over, as assimp passes over them. What assimp then does with
// the file is followed by check_ply_as_assimp_reads.
class PlyChecker {
 public:
  PlyChecker(const std::string& bytes, std::size_t header_end, std::size_t data_start, std::string what)
      : bytes_(bytes), header_end_(header_end), data_(data_start), what_(std::move(what)) {}

  void check() { read_header(); }

 private:
  struct Property {
    std::string type, count_type;  // count_type empty: a single value
    std::string name;
  };
  struct Element {
    std::string name;
    std::uint64_t count = 0;
    std::vector<Property> properties;
  };

  [[noreturn]] void fail(const std::string& why) const { throw InputError(what_ + ": " + why + "; export the file again"); }

  void read_header() {
    std::size_t line_start = bytes_.find('\n') + 1;  // the first line holds "ply" (found before)
    for (int number = 2; line_start < header_end_; ++number) {
      std::size_t line_end = bytes_.find('\n', line_start);
      if (line_end == std::string::npos || line_end > header_end_) line_end = header_end_;
      const std::string line = bytes_.substr(line_start, line_end - line_start);
      line_start = line_end + 1;
      std::istringstream words(line);
      std::vector<std::string> w;
      for (std::string word; words >> word;) w.push_back(word);
      auto bad = [&] {
        std::string shown;
        for (unsigned char c : line.substr(0, 60)) shown += std::isprint(c) ? static_cast<char>(c) : '?';
        fail("its PLY header line " + std::to_string(number) + " ('" + shown + "') is not one PLY defines");
      };
      if (w.empty()) continue;
      if (w[0] == "format") {
        if (w.size() != 3 || (w[1] != "ascii" && w[1] != "binary_little_endian" && w[1] != "binary_big_endian") ||
            w[2] != "1.0" || !format_.empty() || !elements_.empty())
          bad();
        format_ = w[1];
      } else if (w[0] == "element") {
        if (w.size() != 3 || w[2].size() > 10 || w[2].find_first_not_of("0123456789") != std::string::npos) bad();
        // Each element once, and each with its properties: assimp takes the first of a name.
        for (const Element& e : elements_)
          if (e.name == w[1]) bad();
        if (!elements_.empty() && elements_.back().properties.empty())
          fail("its PLY element " + elements_.back().name + " has no properties");
        elements_.push_back({w[1], std::stoull(w[2]), {}});
      } else if (w[0] == "property") {
        if (elements_.empty()) bad();
        if (w.size() == 3 && ply_type_size(w[1]) > 0) elements_.back().properties.push_back({w[1], "", w[2]});
        else if (w.size() == 5 && w[1] == "list" && ply_type_size(w[2]) > 0 && ply_type_size(w[3]) > 0)
          elements_.back().properties.push_back({w[3], w[2], w[4]});
        else bad();
      }
    }
    if (format_.empty()) fail("its PLY header has no format line");
    if (!elements_.empty() && elements_.back().properties.empty())
      fail("its PLY element " + elements_.back().name + " has no properties");
    // An element of no properties takes no bytes; assimp still makes each of its elements.
    const std::uint64_t room = bytes_.size() - data_;
    for (const Element& e : elements_)
      if (e.count > room + 1)
        fail("its PLY header declares " + std::to_string(e.count) + " " + e.name + " elements, more than the " +
             std::to_string(room) + " bytes after its header can hold");
  }

  const std::string& bytes_;
  std::size_t header_end_, data_;
  std::string what_;
  std::string format_;
  std::vector<Element> elements_;
};

// assimp takes a file for Collada by "<collada" in its first 200 bytes, whatever its name.
bool collada_magic(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string head(200, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  return lowercase(head).find("<collada") != std::string::npos;
}

// The value of attribute `name` in the start tag `tag` (its text from '<' to '>'), if it has one.
std::optional<std::string> xml_attribute(std::string_view tag, const std::string& name) {
  auto space = [&](std::size_t i) { return i < tag.size() && std::isspace(static_cast<unsigned char>(tag[i])); };
  for (std::size_t at = tag.find(name); at != std::string_view::npos; at = tag.find(name, at + 1)) {
    if (at == 0 || !space(at - 1)) continue;  // the end of another name
    std::size_t open = at + name.size();
    while (space(open)) ++open;  // XML allows spaces around '='
    if (open >= tag.size() || tag[open] != '=') continue;
    ++open;
    while (space(open)) ++open;
    if (open >= tag.size() || (tag[open] != '"' && tag[open] != '\'')) return std::nullopt;
    const std::size_t close = tag.find(tag[open], open + 1);
    if (close == std::string_view::npos) return std::nullopt;
    return std::string(tag.substr(open + 1, close - open - 1));
  }
  return std::nullopt;
}

// An unsigned attribute as assimp's XML reader (pugixml's as_uint) takes it: spaces, a sign, then
// decimal digits or 0x and hex digits up to the first other character; nothing, or a value below
// zero, is 0, and a value past 32 bits is the largest.
std::uint64_t xml_count(const std::optional<std::string>& value, std::uint64_t absent) {
  if (!value) return absent;
  const std::string& v = *value;
  std::size_t i = 0;
  while (i < v.size() && std::isspace(static_cast<unsigned char>(v[i]))) ++i;
  const bool negative = i < v.size() && v[i] == '-';
  if (i < v.size() && (v[i] == '+' || v[i] == '-')) ++i;
  const bool hex = i + 1 < v.size() && v[i] == '0' && (v[i + 1] | ' ') == 'x';
  if (hex) i += 2;
  std::uint64_t n = 0;
  for (; i < v.size(); ++i) {
    const int c = static_cast<unsigned char>(v[i]);
    int digit = std::isdigit(c) ? c - '0' : hex && std::isxdigit(c) ? (c | ' ') - 'a' + 10 : -1;
    if (digit < 0) break;
    n = std::min<std::uint64_t>(n * (hex ? 16 : 10) + std::uint64_t(digit), 0xffffffffu);
  }
  return negative ? 0 : n;
}

// Every start tag `<name ...>` or `<name>` in the text, as views from '<' to '>'.
std::vector<std::string_view> xml_start_tags(std::string_view text, const std::string& name) {
  std::vector<std::string_view> tags;
  const std::string open = "<" + name;
  std::size_t close = 0;
  for (std::size_t at = text.find(open); at != std::string_view::npos; at = text.find(open, at + 1)) {
    const std::size_t after = at + open.size();
    if (after >= text.size()) break;
    const char c = text[after];
    if (c != '>' && c != '/' && !std::isspace(static_cast<unsigned char>(c))) continue;  // another element
    // The tags come in order: the '>' found for one serves those before it, so no text is searched twice.
    if (close < after) close = text.find('>', after);
    if (close == std::string_view::npos) break;
    tags.push_back(text.substr(at, close - at + 1));
  }
  return tags;
}

// assimp 5.2 reads a Collada index list (<p>, and <h>, <v>, <vcount>) number by number until its
// end, and a character that is neither a digit, a sign nor a space stops it from moving on: it
// appends zeros until memory runs out (a stray letter in a 1 KB file took 12 GB and 36 s).
void check_collada_index_lists(const std::string& text, const std::string& what) {
  for (const char* name : {"p", "h", "v", "vcount"}) {
    std::size_t last = std::string::npos;
    for (std::string_view tag : xml_start_tags(text, name)) {
      if (tag.size() >= 2 && tag[tag.size() - 2] == '/') continue;  // empty: <p/>
      const std::size_t start = static_cast<std::size_t>(tag.data() - text.data()) + tag.size();
      if (start == last) continue;  // tags that share one '>' (not XML) share one list
      last = start;
      for (std::size_t i = start; i < text.size() && text[i] != '<'; ++i) {
        const unsigned char ch = static_cast<unsigned char>(text[i]);
        if (std::isdigit(ch) || ch == ' ' || ch == '\t' || ch == '\r' || ch == '\n' || ch == '+' || ch == '-') continue;
        std::ostringstream shown;
        if (std::isprint(ch)) shown << "'" << text[i] << "'";
        else shown << "the byte 0x" << std::hex << int(ch);
        throw InputError(what + ": its Collada <" + name + "> list holds " + shown.str() + " at byte " + std::to_string(i) +
                         ", where only whole numbers may be (assimp would read it without end); export the file again");
      }
    }
  }
}

// assimp 5.2 reads an accessor's values from its source array without checking that the array
// holds them: an array without a count attribute (assimp then keeps none of its values) crashed it
// on a null pointer. An accessor reads `count` groups of `stride` values from `offset`, each group
// as wide as its <param>s.
void check_collada_accessors(std::string_view text, const std::string& what) {
  std::map<std::string, std::uint64_t> kept;  // array id -> how many values assimp keeps of it
  for (const char* type : {"float_array", "int_array", "bool_array", "Name_array", "IDREF_array", "SIDREF_array", "accessor"})
    for (std::string_view tag : xml_start_tags(text, type))
      if (tag.find('&') != std::string_view::npos)  // a character reference: read by XML, not here
        throw InputError(what + ": its Collada <" + type + "> tag holds a character reference; export the file again");
  std::set<std::string> floats;
  for (const char* type : {"float_array", "int_array", "bool_array", "Name_array", "IDREF_array", "SIDREF_array"})
    for (std::string_view tag : xml_start_tags(text, type))
      if (const auto id = xml_attribute(tag, "id")) {
        if (!kept.emplace(*id, xml_count(xml_attribute(tag, "count"), 0)).second)
          throw InputError(what + ": its Collada arrays share the id '" + id->substr(0, 40) + "'; export the file again");
        if (std::string_view(type) == "float_array") floats.insert(*id);
      }
  std::size_t close = 0;
  const std::vector<std::string_view> accessors = xml_start_tags(text, "accessor");
  for (std::size_t k = 0; k < accessors.size(); ++k) {
    const std::string_view tag = accessors[k];
    const std::optional<std::string> source = xml_attribute(tag, "source");
    if (!source) continue;
    const auto array = kept.find(source->substr(source->rfind('#', 0) == 0 ? 1 : 0));
    if (array == kept.end()) continue;  // assimp refuses a reference it cannot resolve
    // A mesh's values are numbers: assimp reads an accessor of names as one of numbers it lacks.
    if (!floats.count(array->first))
      throw InputError(what + ": its Collada accessor of '" + *source + "' reads an array that is not a <float_array>; export the file again");
    // assimp reads an accessor's count as a signed number into an unsigned one: below zero is huge.
    if (const auto text_count = xml_attribute(tag, "count");
        text_count && text_count->find_first_not_of(" \t\r\n") != std::string::npos &&
        (*text_count)[text_count->find_first_not_of(" \t\r\n")] == '-')
      throw InputError(what + ": its Collada accessor of '" + *source + "' has the count " + text_count->substr(0, 20) +
                       "; export the file again");
    const std::uint64_t count = xml_count(xml_attribute(tag, "count"), 0);
    if (count == 0) continue;
    const std::uint64_t stride = xml_count(xml_attribute(tag, "stride"), 1);
    const std::uint64_t offset = xml_count(xml_attribute(tag, "offset"), 0);
    const std::size_t at = static_cast<std::size_t>(tag.data() - text.data());
    const bool empty = tag.size() >= 2 && tag[tag.size() - 2] == '/';
    // The tags come in order, so the next closing tag is searched for once, not once a tag.
    if (close != std::string_view::npos && close < at) close = text.find("</accessor>", at);
    // Its <param>s lie before its closing tag and the next accessor, so no text is read twice. An
    // accessor never closed is not XML, which assimp refuses.
    const std::size_t next = k + 1 < accessors.size() ? static_cast<std::size_t>(accessors[k + 1].data() - text.data()) : text.size();
    const std::size_t end = empty || close == std::string_view::npos ? at : std::min(close, next);
    const std::string_view inside = text.substr(at, end - at);
    const std::uint64_t params = xml_start_tags(inside, "param").size();
    // In a long double: counts and strides of 32 bits cannot overflow it.
    // assimp reads one value of each group at least, <param>s or not.
    const long double need = static_cast<long double>(offset) + static_cast<long double>(count - 1) * stride +
                             std::max<std::uint64_t>({stride, params, 1});
    if (need > static_cast<long double>(array->second))
      throw InputError(what + ": its Collada accessor of '" + *source + "' reads " + std::to_string(std::uint64_t(std::min(need, 1e19L))) +
                       " values, but the array holds " + std::to_string(array->second) +
                       (array->second == 0 ? " (has it a count attribute, and is that a number?)" : "") + "; export the file again");
  }
}

// Parts of a Collada document a body does not need and assimp 5.2 does not read safely, refused;
// and how deep its elements nest. From a review of its reader: it follows <instance_node>s and a
// morph's target without looking for loops (the stack overflows), writes skin weights through joint
// indices it does not check and loops without end on controllers naming each other, writes animation
// values past its matrices, reads 1.5's <hex> images four times over, reads a <polylist>'s corner
// counts from a <vcount> it may not have, and recurses once a nested element.
void check_collada_structure(std::string_view text, const std::string& what) {
  auto fail = [&](const std::string& why) { throw InputError(what + ": " + why + "; export the file again"); };
  for (const auto& [name, part] : {std::pair<const char*, const char*>{"instance_node", "node instances (<instance_node>)"},
                                   {"controller", "controllers (skins or morphs)"},
                                   {"channel", "animations"},
                                   {"hex", "images as <hex> data"}})
    if (!xml_start_tags(text, name).empty())
      fail(std::string("it holds ") + part + ", which Kiji does not read (export the body as a plain mesh)");
  if (text.find("<![CDATA[") != std::string_view::npos) fail("it holds a CDATA section, which Kiji does not read");
  const std::size_t first = text.find('<');  // the XML declaration, after a byte order mark or spaces
  if (first != std::string_view::npos && text.find("<?", first + 1) != std::string_view::npos)
    fail("it holds a processing instruction past its start");
  for (std::string_view tag : xml_start_tags(text, "polylist")) {
    if (xml_count(xml_attribute(tag, "count"), 0) == 0 || tag.size() < 2 || tag[tag.size() - 2] == '/') continue;
    const std::size_t start = static_cast<std::size_t>(tag.data() - text.data());
    const std::size_t end = std::min(text.find("</polylist>", start), text.size());
    const std::string_view inside = text.substr(start + tag.size(), end - start - std::min(end - start, tag.size()));
    const std::vector<std::string_view> vcounts = xml_start_tags(inside, "vcount"), lists = xml_start_tags(inside, "p");
    if (vcounts.empty() || (!lists.empty() && lists.front().data() < vcounts.front().data()))
      fail("its <polylist> at byte " + std::to_string(start) + " has no <vcount> before its <p>");
  }
  // An effect's <newparam>s name each other (a sampler its surface, a surface its image): assimp
  // follows the names until one is not a param, so a loop of them never ends.
  for (std::string_view effect : xml_start_tags(text, "effect")) {
    const std::size_t start = static_cast<std::size_t>(effect.data() - text.data());
    const std::string_view body = text.substr(start, std::min(text.find("</effect>", start), text.size()) - start);
    std::map<std::string, std::string> refers;
    for (std::string_view param : xml_start_tags(body, "newparam")) {
      const auto sid = xml_attribute(param, "sid");
      const std::size_t from = static_cast<std::size_t>(param.data() - body.data());
      const std::string_view inside = body.substr(from, std::min(body.find("</newparam>", from), body.size()) - from);
      for (const char* holder : {"<init_from>", "<source>"})
        if (const std::size_t at = inside.find(holder); sid && at != std::string_view::npos) {
          const std::size_t value = at + std::strlen(holder);
          std::string name(inside.substr(value, std::min(inside.find('<', value), inside.size()) - value));
          name.erase(0, name.find_first_not_of(" \t\r\n"));
          name.erase(name.find_last_not_of(" \t\r\n") + 1);
          refers[*sid] = name;
        }
    }
    for (const auto& [sid, next] : refers) {
      std::string at = sid;
      for (std::size_t steps = 0; refers.count(at); ++steps) {
        if (steps > refers.size()) fail("its effect's parameters name each other in a loop ('" + sid.substr(0, 40) + "')");
        at = refers[at];
      }
    }
  }
  // Element depth, and <node> depth, as assimp recurses through them.
  int depth = 0, nodes = 0;
  std::vector<bool> is_node;
  for (std::size_t at = text.find('<'); at != std::string_view::npos; at = text.find('<', at + 1)) {
    const std::size_t close = text.find('>', at);
    if (close == std::string_view::npos) break;
    const std::string_view tag = text.substr(at, close - at + 1);
    if (tag.size() > 1 && (tag[1] == '!' || tag[1] == '?')) continue;
    if (tag.size() > 1 && tag[1] == '/') {
      if (!is_node.empty()) {
        nodes -= is_node.back();
        is_node.pop_back();
      }
      --depth;
      continue;
    }
    if (tag.size() >= 2 && tag[tag.size() - 2] == '/') continue;  // empty: <x/>
    const bool node = tag.compare(0, 5, "<node") == 0 && tag.size() > 5 && (tag[5] == '>' || std::isspace(static_cast<unsigned char>(tag[5])));
    is_node.push_back(node);
    nodes += node;
    if (++depth > 1000) fail("its elements nest deeper than 1000 levels");
    if (nodes > 200) fail("its nodes nest deeper than 200 levels");
  }
}

// A Collada document's text checked for what assimp 5.2 would read without end or crash on.
void check_collada(std::string text, const std::string& what) {
  // Comments are not read: blanked, keeping every byte's position.
  for (std::size_t at = text.find("<!--"); at != std::string::npos; at = text.find("<!--", at)) {
    const std::size_t end = text.find("-->", at + 4);
    const std::size_t stop = end == std::string::npos ? text.size() : end + 3;
    std::fill(text.begin() + static_cast<std::ptrdiff_t>(at), text.begin() + static_cast<std::ptrdiff_t>(stop), ' ');
  }
  check_collada_structure(text, what);
  check_collada_index_lists(text, what);
  check_collada_accessors(text, what);
  // A float array is read value by value, `count` times, with assimp's number reader.
  for (std::string_view tag : xml_start_tags(text, "float_array")) {
    const std::size_t start = static_cast<std::size_t>(tag.data() - text.data()) + tag.size();
    const std::size_t end = std::min(text.find('<', start), text.size());
    if (const auto at = long_integer(std::string_view(text).substr(start, end - start)))
      throw InputError(what + ": its Collada <float_array> has an integer of 20 digits or more at byte " +
                       std::to_string(start + *at) + ", which assimp cannot read past; export the file again");
  }
}

// A zipped Collada file (.zae) is any zip holding a .dae, whatever its name: assimp reads the
// document its manifest names, or the first .dae. Every Collada document in it is checked as a
// .dae file is.
void check_zipped_collada(const std::string& path, const std::string& what) {
  const std::unique_ptr<void, int (*)(unzFile)> zip(unzOpen64(path.c_str()), unzClose);
  if (!zip) return;  // assimp's to refuse
  for (int at = unzGoToFirstFile(zip.get()); at == UNZ_OK; at = unzGoToNextFile(zip.get())) {
    unz_file_info64 info{};
    char name[512] = {};
    if (unzGetCurrentFileInfo64(zip.get(), &info, name, sizeof name, nullptr, 0, nullptr, 0) != UNZ_OK ||
        unzOpenCurrentFile(zip.get()) != UNZ_OK)
      return;  // assimp's to refuse
    // Read in pieces: a zip's sizes are its own word. Only Collada documents are read whole (by
    // name, or by "<collada" in their first 200 bytes, as assimp finds them).
    std::string text;
    char piece[1 << 16];
    int got = 0;
    bool collada = lower_extension(name) == ".dae";
    constexpr std::size_t most = std::size_t(512) << 20;
    while ((got = unzReadCurrentFile(zip.get(), piece, sizeof piece)) > 0 && text.size() <= most) {
      text.append(piece, static_cast<std::size_t>(got));
      collada = collada || lowercase(text.substr(0, 200)).find("<collada") != std::string::npos;
      if (!collada && text.size() >= 200) break;
    }
    unzCloseCurrentFile(zip.get());
    if (!collada) continue;
    if (text.size() > most)
      throw InputError(what + ": its " + name + " unpacks to over 512 MiB, more than a body needs; export it again");
    check_collada(std::move(text), what + " (its " + name + ")");
  }
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
    OffReader(std::string(std::istreambuf_iterator<char>(in), {}), what).check();
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
    PlyChecker(bytes, at, data, what).check();
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

 private:
  static std::string mtl_problem(const std::string& bytes) {
    if (bytes.size() >= 4 && (bytes.compare(0, 4, std::string("\xFE\xFF\0\0", 4)) == 0 ||
                              bytes.compare(0, 4, std::string("\0\0\xFE\xFF", 4)) == 0))
      return "is UTF-32 text, which assimp reads past its buffer";
    std::size_t at = 0;
    while (at < bytes.size()) {
      std::size_t end = at;
      while (end < bytes.size() && std::string_view("\n\r\f", 3).find(bytes[end]) == std::string_view::npos && bytes[end] != '\0')
        ++end;
      std::size_t first = at;
      while (first < end && (bytes[first] == ' ' || bytes[first] == '\t')) ++first;
      const std::string line = lowercase(bytes.substr(first, end - first));
      at = end + 1;
      if (line.empty() || line[0] == '#') continue;
      if (line.rfind("newmtl", 0) == 0) return "";
      return "has '" + bytes.substr(first, std::min<std::size_t>(end - first, 40)) +
             "' before its first newmtl, where assimp has no material to write it to";
    }
    return "";
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
