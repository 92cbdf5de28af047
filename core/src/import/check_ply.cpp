// A PLY file's header checked as the format defines it, then the file read the way assimp 5.2's
// PLY reader reads it, before assimp does: see import_checks.h.
#include "import/import_checks.h"

#include "kiji/error.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

namespace kiji::detail {

namespace {

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

// A std::vector<char> as assimp's PLY reader uses its line buffer: erased from the front, resized
// at the back (new bytes zero), and never cleared, so bytes of longer lines before stay behind a
// shorter one. Kept as an offset into storage so that erasing the front costs nothing.
class LineBuffer {
 public:
  std::size_t size() const { return size_; }
  char operator[](std::size_t i) const { return bytes_[start_ + i]; }
  void set(std::size_t i, char c) { bytes_[start_ + i] = c; }
  void erase_front(std::size_t n) {
    start_ += n;
    size_ -= n;
    if (start_ > 4096 && start_ > bytes_.size() / 2) {
      bytes_.erase(bytes_.begin(), bytes_.begin() + static_cast<std::ptrdiff_t>(start_));
      start_ = 0;
    }
  }
  void resize(std::size_t n) {
    if (n > size_) {
      if (bytes_.size() < start_ + n) bytes_.resize(start_ + n);
      std::fill(bytes_.begin() + static_cast<std::ptrdiff_t>(start_ + size_),
                bytes_.begin() + static_cast<std::ptrdiff_t>(start_ + n), '\0');
    }
    size_ = n;
  }

 private:
  std::vector<char> bytes_;
  std::size_t start_ = 0, size_ = 0;
};

bool line_end(char c) { return c == '\r' || c == '\n' || c == '\0' || c == '\f'; }
bool space(char c) { return c == ' ' || c == '\t'; }
bool digit(char c) { return c >= '0' && c <= '9'; }

// assimp 5.2.4's PLY reader (PlyLoader.cpp, PlyParser.cpp, IOStreamBuffer.h), followed step by
// step over the file's bytes. Its header parser reads a line on from its end into what longer lines
// before left in the buffer, takes "\r", "\f" and NUL for line ends, and parses what it finds there:
// so the elements it makes, their counts and its list lengths are known only by doing as it does.
// Refused, before assimp allocates or reads them: an element count the rest of the file cannot hold,
// a list longer than the values after it, data that ends before its elements do, a read past the
// reader's own buffer, and a value it cannot parse.
class PlyReading {
 public:
  PlyReading(const std::string& file, std::string what)
      : file_(file), what_(std::move(what)), cache_(kBlock, '\n'), cache_size_(std::min(kBlock, file.size())) {}

  void check() {
    if (file_.empty()) return;
    LineBuffer magic;
    next_line(magic);
    if (magic.size() < 3) return;
    for (std::size_t i = 0; i < 3; ++i)
      if ((at(magic, i) | 0x20) != "ply"[i]) return;  // assimp refuses it as no PLY file at once
    LineBuffer format;
    next_line(format);
    std::size_t k = 0;
    skip_spaces_and_line_end(format, k);
    if (!token(format, k, "format")) fail("its second line is not its format line");
    bool binary = false;
    if (!token(format, k, "ascii")) {
      static const std::string prefix = "binary_";
      for (std::size_t i = 0; i < prefix.size(); ++i)
        if (at(format, k + i) != prefix[i]) fail("its format is neither ascii nor binary");
      binary = true;
      big_endian_ = (at(format, k + prefix.size()) | 0x20) == 'b';
    }
    LineBuffer b;
    if (next_line(b) != Line::whole) fail("its PLY header has no end_header line");
    read_header(b, binary);
    if (block_start_ != 0) fail("its PLY header is over 1 MiB long");
    std::size_t data = block_start_ + cache_pos_;
    // The binary reader drops a newline first in its data (the end of a header's "\r\n").
    if (binary && cache_at(cache_pos_) == '\n') ++data;
    const std::uint64_t room = file_.size() > data ? file_.size() - data : 0;
    for (const Element& e : elements_) {
      if (e.count > room + 1)
        fail("its PLY header declares " + std::to_string(e.count) + " " + e.name + " elements, more than the " +
             std::to_string(room) + " bytes after its header can hold");
      // Each value takes a byte at least: assimp keeps one of 56 bytes for each, read or not.
      if (std::uint64_t(e.count) * e.properties.size() > room + 1)
        fail("its PLY header declares " + std::to_string(e.count) + " " + e.name + " elements of " +
             std::to_string(e.properties.size()) + " values, more than the " + std::to_string(room) +
             " bytes after its header can hold");
      // assimp makes a material of some kilobytes for each, and Kiji keeps none.
      if (e.kind == Kind::material && e.count > 256)
        fail("its PLY header declares " + std::to_string(e.count) + " materials, and Kiji reads 256 at most");
    }
    if (binary) read_binary(data);
    else read_ascii(b);
  }

 private:
  static constexpr std::size_t kBlock = std::size_t(1) << 20;  // assimp's PLY cache
  enum class Type { invalid, i8, u8, i16, u16, i32, u32, f32, f64 };
  enum class Kind { other, vertex, face, tristrips, edge, material, texture_file };
  enum class Line { whole, partial, none };
  struct Property {
    bool list = false;
    Type count = Type::invalid, type = Type::invalid;
    std::string name, semantic;  // semantic: the name assimp knows it by, or empty
  };
  struct Element {
    Kind kind = Kind::other;
    std::string name;
    std::uint32_t count = 0;
    std::vector<Property> properties;
  };

  [[noreturn]] void fail(const std::string& why) const { throw InputError(what_ + ": " + why + "; export the file again"); }

  char at(const LineBuffer& b, std::size_t i) const {
    if (i >= b.size()) fail("its PLY file is laid out so that assimp would read past the end of its line buffer");
    return b[i];
  }
  char cache_at(std::size_t i) const {
    if (i >= cache_.size()) fail("its PLY file has a line end with no newline after it for over 1 MiB");
    return cache_[i];
  }

  // IOStreamBuffer: blocks of 1 MiB (the whole file if smaller) into a cache first filled with '\n'.
  bool read_block() {
    const std::size_t n = std::min(cache_size_, file_.size() - file_pos_);
    if (n == 0) return false;
    file_.copy(cache_.data(), n, file_pos_);
    cache_size_ = n;
    block_start_ = file_pos_;
    file_pos_ += n;
    cache_pos_ = 0;
    return true;
  }

  Line next_line(LineBuffer& b) {
    b.resize(cache_size_);
    if ((cache_pos_ == cache_size_ || file_pos_ == 0) && !read_block()) return Line::none;
    if (line_end(cache_at(cache_pos_))) {
      while (cache_at(cache_pos_) != '\n') ++cache_pos_;
      ++cache_pos_;
      if (cache_pos_ == cache_size_ && !read_block()) return Line::none;
    }
    std::size_t i = 0;
    while (!line_end(cache_at(cache_pos_))) {
      b.set(i, cache_[cache_pos_]);
      ++cache_pos_;
      if (++i == b.size()) b.resize(b.size() * 2);
      if (cache_pos_ >= cache_size_ && !read_block()) return Line::partial;
    }
    b.set(i, '\n');
    ++cache_pos_;
    return Line::whole;
  }

  // ParsingUtils and fast_atof, at index k of a buffer.
  bool skip_spaces(const LineBuffer& b, std::size_t& k) const {
    while (space(at(b, k))) ++k;
    return !line_end(at(b, k));
  }
  void skip_line(const LineBuffer& b, std::size_t& k) const {
    while (at(b, k) != '\r' && at(b, k) != '\n' && at(b, k) != '\0') ++k;
    while (at(b, k) == '\r' || at(b, k) == '\n') ++k;
  }
  void skip_spaces_and_line_end(const LineBuffer& b, std::size_t& k) const {
    while (space(at(b, k)) || at(b, k) == '\r' || at(b, k) == '\n') ++k;
  }
  bool token(const LineBuffer& b, std::size_t& k, const std::string& t) const {
    for (std::size_t i = 0; i < t.size(); ++i)
      if (at(b, k + i) != t[i]) return false;
    const char after = at(b, k + t.size());
    if (!space(after) && !line_end(after)) return false;
    k += after == '\0' ? t.size() : t.size() + 1;
    return true;
  }
  std::uint32_t strtoul10(const LineBuffer& b, std::size_t& k) const {
    std::uint32_t value = 0;
    for (; digit(at(b, k)); ++k) value = value * 10u + std::uint32_t(at(b, k) - '0');
    return value;
  }
  // Where a value is, for a message: the property of an element's instance.
  struct Where {
    const Element& element;
    const Property& property;
    std::uint32_t index;
    std::string text() const {
      return "the " + property.name + " of its " + element.name + " element " + std::to_string(index);
    }
  };
  // Up to 20 characters of the buffer from k, as a message shows them.
  static std::string shown(const LineBuffer& b, std::size_t k) {
    std::string text;
    for (std::size_t i = k; i < b.size() && i < k + 20 && !line_end(b[i]) && !space(b[i]); ++i)
      text += std::isprint(static_cast<unsigned char>(b[i])) ? b[i] : '?';
    return text;
  }
  [[noreturn]] void not_a_number(const LineBuffer& b, std::size_t k, const Where& where) const {
    fail("its PLY data has '" + shown(b, k) + "' where " + where.text() + " needs a number");
  }
  // strtoul10_64: digits into 64 bits. It throws where there is no digit (assimp's import ends),
  // and where the value wraps it returns without moving on: both refused here. With `most`, it
  // keeps that many digits and passes over the rest, saying in `most` how many it kept.
  std::uint64_t digits64(const LineBuffer& b, std::size_t& k, std::size_t from, const Where& where,
                         unsigned* most = nullptr) const {
    if (!digit(at(b, k))) not_a_number(b, from, where);
    std::uint64_t value = 0;
    unsigned kept = 0;
    while (digit(at(b, k))) {
      const std::uint64_t next = value * 10 + std::uint64_t(at(b, k) - '0');
      if (next < value) not_a_number(b, from, where);
      value = next;
      ++k;
      if (most && *most == ++kept) {
        while (digit(at(b, k))) ++k;
        return value;
      }
    }
    if (most) *most = kept;
    return value;
  }
  // fast_atoreal_move, in its own arithmetic (Real is float for PLY's float, double for double):
  // what it consumes, and the value it makes, to the bit.
  template <typename Real>
  Real real(const LineBuffer& b, std::size_t& k, const Where& where) const {
    static constexpr double kTenths[16] = {0.0,     0.1,     0.01,     0.001,     0.0001,     0.00001,     0.000001,    0.0000001,
                                           1e-8,    1e-9,    1e-10,    1e-11,     1e-12,      1e-13,       1e-14,       1e-15};
    const std::size_t from = k;
    const bool minus = at(b, k) == '-';
    if (minus || at(b, k) == '+') ++k;
    auto word = [&](const char* w) {
      for (std::size_t i = 0; w[i]; ++i)
        if ((at(b, k + i) | 0x20) != w[i]) return false;
      return true;
    };
    if ((at(b, k) | 0x20) == 'n' && word("nan")) {
      k += 3;
      return std::numeric_limits<Real>::quiet_NaN();
    }
    if ((at(b, k) | 0x20) == 'i' && word("inf")) {
      k += 3;
      if ((at(b, k) | 0x20) == 'i' && word("inity")) k += 5;
      return minus ? -std::numeric_limits<Real>::infinity() : std::numeric_limits<Real>::infinity();
    }
    const bool point = at(b, k) == '.' || at(b, k) == ',';
    if (!digit(at(b, k)) && !(point && digit(at(b, k + 1)))) not_a_number(b, from, where);
    Real f = 0;
    if (!point) f = static_cast<Real>(digits64(b, k, from, where));
    if ((at(b, k) == '.' || at(b, k) == ',') && digit(at(b, k + 1))) {
      ++k;
      unsigned most = 15;
      double fraction = static_cast<double>(digits64(b, k, from, where, &most));
      fraction *= kTenths[most];
      f += static_cast<Real>(fraction);
    } else if (at(b, k) == '.') {
      ++k;
    }
    if (at(b, k) == 'e' || at(b, k) == 'E') {
      ++k;
      const bool down = at(b, k) == '-';
      if (down || at(b, k) == '+') ++k;
      Real exponent = static_cast<Real>(digits64(b, k, from, where));
      if (down) exponent = -exponent;
      f *= std::pow(static_cast<Real>(10.0), exponent);
    }
    return minus ? -f : f;
  }
  // PropertyInstance::ParseValue, then ConvertTo<unsigned int> where it is a list's length.
  double value(const LineBuffer& b, std::size_t& k, Type type, const Where& where) const {
    switch (type) {
      case Type::u8:
      case Type::u16:
      case Type::u32:
        return strtoul10(b, k);
      case Type::i8:
      case Type::i16:
      case Type::i32: {
        const bool minus = at(b, k) == '-';
        if (minus || at(b, k) == '+') ++k;
        const std::uint32_t v = strtoul10(b, k);
        return static_cast<std::int32_t>(minus ? 0u - v : v);
      }
      case Type::f32:
        return real<float>(b, k, where);
      default:
        return real<double>(b, k, where);
    }
  }
  std::uint32_t length(double v, const Where& where) const {
    // assimp converts a value below zero, or past 32 bits, to some huge length
    if (!(v >= 0 && v < 4294967296.0))
      fail("its PLY data has " + std::to_string(v) + " for the length of the list " + where.text());
    return static_cast<std::uint32_t>(v);
  }

  // PLY::DOM's helpers: the same on the buffer's start, erasing what they pass.
  bool dom_skip_spaces(LineBuffer& b) const {
    if (b.size() == 0) return false;
    std::size_t k = 0;
    const bool more = skip_spaces(b, k);
    b.erase_front(k);
    return more;
  }
  void dom_skip_line(LineBuffer& b) const {
    if (b.size() == 0) return;
    std::size_t k = 0;
    skip_line(b, k);
    b.erase_front(k);
  }
  void dom_skip_spaces_and_line_end(LineBuffer& b) const {
    if (b.size() == 0) return;
    std::size_t k = 0;
    skip_spaces_and_line_end(b, k);
    b.erase_front(k);
  }
  bool dom_token(LineBuffer& b, const std::string& t) const {
    if (b.size() == 0) return false;
    std::size_t k = 0;
    if (!token(b, k, t)) return false;
    b.erase_front(k);
    return true;
  }
  // DOM::SkipComments works on a copy and keeps it only when it passed a comment.
  void dom_skip_comments(LineBuffer& b) const {
    if (b.size() == 0) return;
    std::size_t k = 0;
    if (!skip_spaces(b, k) || k >= b.size() || !token(b, k, "comment")) return;
    const bool more = k < b.size() && skip_spaces(b, k);
    if (!more && k < b.size()) skip_line(b, k);
    if (k < b.size() && token(b, k, "TextureFile")) return;
    if (k < b.size()) skip_line(b, k);
    b.erase_front(k);
  }

  Type data_type(LineBuffer& b) const {
    static const std::vector<std::pair<const char*, Type>> names = {
        {"char", Type::i8},    {"int8", Type::i8},    {"uchar", Type::u8},    {"uint8", Type::u8},
        {"short", Type::i16},  {"int16", Type::i16},  {"ushort", Type::u16},  {"uint16", Type::u16},
        {"int32", Type::i32},  {"int", Type::i32},    {"uint32", Type::u32},  {"uint", Type::u32},
        {"float", Type::f32},  {"float32", Type::f32}, {"double64", Type::f64}, {"double", Type::f64},
        {"float64", Type::f64}};
    for (const auto& [name, type] : names)
      if (dom_token(b, name)) return type;
    return Type::invalid;
  }

  bool read_property(LineBuffer& b, Property& p) const {
    if (!dom_skip_spaces(b) || !dom_token(b, "property") || !dom_skip_spaces(b)) return false;
    if (dom_token(b, "list")) {
      p.list = true;
      if ((p.count = data_type(b)) == Type::invalid) {
        dom_skip_line(b);
        return false;
      }
      if (!dom_skip_spaces(b)) return false;
    }
    if ((p.type = data_type(b)) == Type::invalid) {
      dom_skip_line(b);
      return false;
    }
    if (!dom_skip_spaces(b)) return false;
    p.name = shown(b, 0);
    static const char* const semantics[] = {
        "red",          "green",          "blue",          "alpha",          "vertex_index", "vertex_indices",
        "texcoord",     "material_index", "ambient_red",   "ambient_green",  "ambient_blue", "ambient_alpha",
        "diffuse_red",  "diffuse_green",  "diffuse_blue",  "diffuse_alpha",  "specular_red", "specular_green",
        "specular_blue", "specular_alpha", "opacity",      "specular_power", "r",            "g",
        "b",            "u",              "s",             "tx",             "texture_u",    "v",
        "t",            "ty",             "texture_v",     "x",              "y",            "z",
        "nx",           "ny",             "nz"};
    for (const char* s : semantics)
      if (dom_token(b, s)) {
        p.semantic = s;
        break;
      }
    if (p.semantic.empty()) dom_skip_line(b);
    dom_skip_spaces_and_line_end(b);
    return true;
  }

  bool read_element(LineBuffer& b, Element& e) {
    if (!dom_skip_spaces(b)) return false;
    if (!dom_token(b, "element") && !dom_token(b, "comment")) return false;
    if (!dom_skip_spaces(b)) return false;
    static const std::vector<std::pair<const char*, Kind>> kinds = {
        {"vertex", Kind::vertex}, {"face", Kind::face},         {"tristrips", Kind::tristrips},
        {"edge", Kind::edge},     {"material", Kind::material}, {"TextureFile", Kind::texture_file}};
    for (const auto& [name, kind] : kinds)
      if (dom_token(b, name)) {
        e.kind = kind;
        e.name = name;
        break;
      }
    if (e.kind == Kind::other) {
      e.name = shown(b, 0);
      for (std::size_t i = 0; at(b, i) != '\0';) ++i;  // assimp names it by all up to the first NUL
    }
    if (!dom_skip_spaces(b)) return false;
    if (e.kind == Kind::texture_file) {
      for (std::size_t i = 0; at(b, i) != '\0';) ++i;
      dom_skip_spaces_and_line_end(b);
      return true;
    }
    std::size_t k = 0;
    e.count = strtoul10(b, k);
    dom_skip_spaces_and_line_end(b);
    for (;;) {
      if (next_line(b) != Line::whole) fail("its PLY header has no end_header line");
      dom_skip_comments(b);
      Property p;
      if (!read_property(b, p)) break;
      e.properties.push_back(p);
    }
    return true;
  }

  void read_header(LineBuffer& b, bool binary) {
    while (b.size() != 0) {
      dom_skip_comments(b);
      Element e;
      if (read_element(b, e)) {
        if (e.kind != Kind::texture_file) {
          if (e.properties.empty()) fail("its PLY element " + e.name + " has no properties");
          for (const Element& before : elements_)
            if (before.kind == e.kind && before.name == e.name) fail("its PLY header declares its " + e.name + " elements twice");
        }
        for (const Element& before : elements_)
          if ((before.kind == Kind::face && e.kind == Kind::tristrips) ||
              (before.kind == Kind::tristrips && e.kind == Kind::face))
            fail("its PLY header declares both faces and triangle strips (assimp writes both into one array "
                 "sized for the first)");
        elements_.push_back(std::move(e));
      } else if (dom_token(b, "end_header")) {
        break;
      } else if (next_line(b) != Line::whole) {
        fail("its PLY header has no end_header line");
      }
    }
    if (!binary) dom_skip_spaces_and_line_end(b);
  }

  [[noreturn]] void cut(const Element& e, std::uint64_t i) const {
    fail("its PLY data ends inside " + e.name + " element " + std::to_string(i) + " of the " + std::to_string(e.count) +
         " its header declares: the file is cut short or its header is wrong");
  }

  // PLYImporter::LoadFace: a face's list of six to eight texture coordinates is written through its
  // vertex list, two coordinates a corner, without looking at that list's length (or whether the
  // face has one). `sizes` holds how many values each property of the instance has.
  void check_face(const Element& e, std::uint32_t i, const std::vector<std::uint32_t>& sizes) const {
    if (e.kind != Kind::face) return;
    std::optional<std::size_t> corners, coords;
    for (std::size_t a = 0; a < e.properties.size(); ++a) {
      const Property& p = e.properties[a];
      if (!p.list) continue;
      if (p.semantic == "vertex_index" || p.semantic == "vertex_indices") corners = a;
      if (p.semantic == "texcoord") coords = a;
    }
    if (!coords || sizes[*coords] / 3 != 2) return;
    const std::uint32_t needed = (sizes[*coords] + 1) / 2;
    const std::uint32_t have = corners ? sizes[*corners] : 0;
    if (have < needed)
      fail("its PLY face element " + std::to_string(i) + " has " + std::to_string(sizes[*coords]) +
           " texture coordinates for a face of " + std::to_string(have) + " corners (assimp would read past them)");
  }

  // ParseElementInstanceLists: one line an element; a list's values end at the line's end.
  void read_ascii(LineBuffer& b) {
    Line line = next_line(b);
    for (const Element& e : elements_) {
      const bool skipped = e.kind == Kind::other || e.properties.empty();
      for (std::uint32_t i = 0; i < e.count; ++i) {
        if (line == Line::none) cut(e, i);
        if (skipped) {
          dom_skip_comments(b);
          dom_skip_line(b);
        } else {
          std::size_t k = 0;
          std::vector<std::uint32_t> sizes;
          for (const Property& p : e.properties) {
            const Where where{e, p, i};
            sizes.push_back(1);  // a property the line lacks gets one default value
            if (!skip_spaces(b, k)) continue;
            if (!p.list) {
              value(b, k, p.type, where);
            } else {
              const std::uint32_t n = length(value(b, k, p.count, where), where);
              std::uint32_t found = 0;
              for (; found < n && skip_spaces(b, k); ++found) {
                const std::size_t before = k;
                value(b, k, p.type, where);
                if (k == before) not_a_number(b, k, where);  // assimp would read it n times over
              }
              if (found < n)
                fail("its PLY " + e.name + " element " + std::to_string(i) + " has " + std::to_string(n) +
                     " for the length of its list " + p.name + ", but its line holds " + std::to_string(found) +
                     " values after it");
              sizes.back() = n;
            }
            skip_spaces_and_line_end(b, k);
          }
          check_face(e, i, sizes);
        }
        line = next_line(b);
      }
    }
  }

  // ParseElementInstanceListsBinary: the file from the header's end, read value by value.
  void read_binary(std::size_t at_byte) const {
    auto size_of = [](Type t) -> std::size_t {
      switch (t) {
        case Type::i8:
        case Type::u8:
          return 1;
        case Type::i16:
        case Type::u16:
          return 2;
        case Type::f64:
          return 8;
        default:
          return 4;
      }
    };
    std::uint64_t pos = at_byte;
    std::vector<std::uint32_t> sizes;
    for (const Element& e : elements_)
      for (std::uint32_t i = 0; i < e.count; ++i) {
        sizes.clear();
        for (const Property& p : e.properties) {
          std::uint64_t n = 1;
          if (p.list) {
            const std::size_t w = size_of(p.count);
            if (pos + w > file_.size()) cut(e, i);
            std::uint64_t raw = 0;
            for (std::size_t j = 0; j < w; ++j)
              raw |= std::uint64_t(static_cast<unsigned char>(file_[pos + (big_endian_ ? w - 1 - j : j)])) << (8 * j);
            pos += w;
            double v = 0;
            switch (p.count) {
              case Type::i8: v = static_cast<std::int8_t>(raw); break;
              case Type::i16: v = static_cast<std::int16_t>(raw); break;
              case Type::i32: v = static_cast<std::int32_t>(raw); break;
              case Type::f32: {
                const auto bits = static_cast<std::uint32_t>(raw);
                float f;
                std::memcpy(&f, &bits, sizeof f);
                v = f;
                break;
              }
              case Type::f64: std::memcpy(&v, &raw, sizeof v); break;
              default: v = static_cast<double>(raw);
            }
            n = length(v, Where{e, p, i});
          }
          if (pos > file_.size() || n * size_of(p.type) > file_.size() - pos) cut(e, i);
          pos += n * size_of(p.type);
          sizes.push_back(static_cast<std::uint32_t>(n));
        }
        check_face(e, i, sizes);
      }
  }

  const std::string& file_;
  std::string what_;
  std::string cache_;
  std::size_t cache_size_, cache_pos_ = 0, file_pos_ = 0, block_start_ = 0;
  bool big_endian_ = false;
  std::vector<Element> elements_;
};

}  // namespace

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

void check_ply_header(const std::string& bytes, std::size_t header_end, std::size_t data_start, const std::string& what) {
  PlyChecker(bytes, header_end, data_start, what).check();
}

void check_ply_as_assimp_reads(const std::string& bytes, const std::string& what) { PlyReading(bytes, what).check(); }

}  // namespace kiji::detail
