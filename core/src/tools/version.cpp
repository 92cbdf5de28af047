#include "kiji/version.h"

#include "kiji/tool.h"

#include <map>
#include <sstream>
#include <utility>
#include <vector>

namespace kiji {

const char* version() { return KIJI_STR(KIJI_VERSION_MAJOR) "." KIJI_STR(KIJI_VERSION_MINOR) ".0"; }

const char* abi_tag() {
  static char tag[detail::kAbiTagCapacity];
  static const char* const written = detail::write_abi_tag(tag, sizeof tag, KIJI_ABI_TAG);
  return written;
}

namespace {

// The fields of a tag in order; a tag of an older format (no name=value fields) has none.
std::vector<std::pair<std::string, std::string>> fields_of(const std::string& tag) {
  std::vector<std::pair<std::string, std::string>> out;
  std::stringstream ss(tag);
  std::string item;
  while (std::getline(ss, item, ';')) {
    const auto eq = item.find('=');
    if (eq == std::string::npos) return {};
    out.emplace_back(item.substr(0, eq), item.substr(eq + 1));
  }
  return out;
}

// What a differing field means and what the plugin's author does about it.
std::string advice_for(const std::string& field) {
  static const std::map<std::string, std::string> advice = {
      {"kiji", "it was built against another version of Kiji's headers: rebuild it against this Kiji"},
      {"compiler", "it was built with another compiler: build it with the compiler Kiji was built with"},
      {"stdlib", "it uses another C++ standard library or _GLIBCXX_USE_CXX11_ABI: build it with Kiji's"},
      {"stl_debug", "_GLIBCXX_DEBUG changes the layout of every standard container: define it for both "
                    "or for neither"},
      {"cgal", "it was built against another CGAL: build it against the CGAL Kiji was built with"},
      {"eigen", "it was built against another Eigen: build it against the Eigen Kiji was built with"},
      {"eigen_align",
       "Eigen aligns fixed-size members (EIGEN_MAX_STATIC_ALIGN_BYTES / EIGEN_MAX_ALIGN_BYTES) otherwise, "
       "which moves members such as ToolEvent::orientation: it was built with other vectorisation flags "
       "(-mavx, -march=native, ...) or Eigen alignment macros; build it with Kiji's compile flags "
       "(kiji_add_tool() adds none of its own) and add no -m or EIGEN_ flags Kiji was not built with"},
      {"eigen_index", "EIGEN_DEFAULT_DENSE_INDEX_TYPE differs: leave it at Kiji's"},
      {"eigen_order", "EIGEN_DEFAULT_TO_ROW_MAJOR differs: leave it at Kiji's"},
      {"scalar", "it was built for another scalar type"},
      {"layout",
       "the types a tool receives have other sizes or alignments (size/alignment in bytes): it was built "
       "with flags or pragmas that change the layout of structs (-mavx, -fpack-struct, #pragma pack "
       "around Kiji's headers, ...); build it with Kiji's flags"},
  };
  auto it = advice.find(field);
  return it != advice.end() ? it->second : "an ABI field this Kiji does not know: rebuild the plugin against this Kiji";
}

}  // namespace

std::string abi_difference(const std::string& plugin_tag, const std::string& host_tag) {
  if (plugin_tag == host_tag) return {};
  const auto plugin = fields_of(plugin_tag), host = fields_of(host_tag);
  if (plugin.empty() || host.empty())
    return "its ABI tag '" + plugin_tag + "' is not in this Kiji's format ('" + host_tag +
           "'): it was built against an older Kiji; rebuild it against this one";
  std::map<std::string, std::string> plugin_map(plugin.begin(), plugin.end());
  std::string out;
  auto add = [&](const std::string& text) { out += (out.empty() ? "" : "; ") + text; };
  for (const auto& [name, value] : host) {
    auto it = plugin_map.find(name);
    const std::string theirs = it == plugin_map.end() ? "(none)" : it->second;
    if (theirs != value)
      add(name + " differs (plugin " + theirs + ", this Kiji " + value + "): " + advice_for(name));
    if (it != plugin_map.end()) plugin_map.erase(it);
  }
  for (const auto& [name, value] : plugin_map)
    add(name + " differs (plugin " + value + ", this Kiji (none)): " + advice_for(name));
  if (out.empty())  // the same fields, repeated or in another order: not a tag this Kiji wrote
    out = "its ABI tag '" + plugin_tag + "' is not one this Kiji writes ('" + host_tag + "'): rebuild the plugin";
  return out;
}

}  // namespace kiji
