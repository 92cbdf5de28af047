// Collada files, plain (.dae) and zipped (.zae), checked before assimp 5.2 reads them: see import_checks.h.
#include "import/import_checks.h"

#include "kiji/error.h"

#include <unzip.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace kiji::detail {

namespace {

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

}  // namespace

// assimp takes a file for Collada by "<collada" in its first 200 bytes, whatever its name.
bool collada_magic(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string head(200, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  return lowercase(head).find("<collada") != std::string::npos;
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

}  // namespace kiji::detail
