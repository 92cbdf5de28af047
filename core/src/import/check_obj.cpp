// An OBJ file and the material files it opens, checked as assimp 5.2 reads them: see import_checks.h.
#include "import/import_checks.h"

#include "kiji/error.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>
#include <string>
#include <string_view>

namespace kiji::detail {

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

// A material file's bytes as assimp's MTL reader takes them: a statement before the first newmtl
// (which it writes through a null material) or UTF-32 text (which it reads past its buffer) named.
std::string mtl_problem(const std::string& bytes) {
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

}  // namespace kiji::detail
