// STL and OFF files checked as assimp 5.2 reads them: see import_checks.h.
#include "import/import_checks.h"

#include "kiji/error.h"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

namespace kiji::detail {

namespace {

// assimp 5.2's OFF reader does not move on to the next face when it drops one of 0 or over 9
// corners, but still counts it off the mesh's faces: enough of them wrap that count and it reads
// past its arrays. It also allocates what the header declares before reading a line, and copies a
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

}  // namespace

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

void check_off(std::string text, const std::string& what) { OffReader(std::move(text), what).check(); }

}  // namespace kiji::detail
