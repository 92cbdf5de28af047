#include "kiji/plugin_loader.h"

#include "kiji/error.h"

#include <dlfcn.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace kiji {

namespace fs = std::filesystem;
using json = nlohmann::json;

// An opened plugin library. Libraries stay loaded for the life of the process: a tool's code
// must outlive every instance of it, and unloading buys nothing here.
struct ToolRegistry::Library {
  std::string path;
  void* handle = nullptr;
  const ToolPluginEntry* entry = nullptr;
};

namespace {

json param_json(const ParamSpec& p) {
  json j;
  j["name"] = p.name;
  j["type"] = param_type_name(p.type);
  std::visit(
      [&](const auto& v) {
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, Vec3>) j["default"] = {v.x(), v.y(), v.z()};
        else j["default"] = v;
      },
      p.default_value);
  if (p.type == ParamType::Int || p.type == ParamType::Float) {
    j["min"] = p.min;
    j["max"] = p.max;
  }
  j["unit"] = p.unit;
  j["label"] = p.label;
  j["help"] = p.help;
  if (p.type == ParamType::Choice) j["choices"] = p.choices;
  return j;
}

std::string library_beside(const fs::path& metadata, const json& j) {
  if (j.contains("library") && j["library"].is_string()) return (metadata.parent_path() / j["library"].get<std::string>()).string();
  fs::path lib = metadata;
  return lib.replace_extension(".so").string();
}

std::vector<std::string> split_path(const char* text) {
  std::vector<std::string> out;
  if (!text) return out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ':'))
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace

ToolRegistry::ToolRegistry() = default;
ToolRegistry::~ToolRegistry() = default;

std::vector<std::string> ToolRegistry::default_search_path() {
  std::vector<std::string> path = split_path(std::getenv("KIJI_PLUGIN_PATH"));
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&ToolRegistry::default_search_path), &info) && info.dli_fname) {
    const fs::path libdir = fs::absolute(fs::path(info.dli_fname)).parent_path();
    for (const fs::path& candidate : {libdir.parent_path() / "plugins", libdir / "kiji" / "plugins"}) {
      std::error_code ec;
      if (fs::is_directory(candidate, ec)) path.push_back(fs::weakly_canonical(candidate, ec).string());
    }
  }
  std::vector<std::string> unique;
  for (const auto& p : path)
    if (std::find(unique.begin(), unique.end(), p) == unique.end()) unique.push_back(p);
  return unique;
}

std::vector<PluginReport> ToolRegistry::load_plugins(const std::vector<std::string>& folders_in) {
  const std::vector<std::string> folders = folders_in.empty() ? default_search_path() : folders_in;
  std::vector<PluginReport> reports;
  for (const auto& folder : folders) {
    std::error_code ec;
    if (!fs::is_directory(folder, ec)) {
      reports.push_back({folder, "", false, "plugin folder does not exist or is not a folder"});
      continue;
    }
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(folder, ec)) files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (const auto& f : files) {
      if (f.extension() == ".json") {
        reports.push_back(load_plugin(f.string()));
      } else if (f.extension() == ".so") {
        fs::path meta = f;
        meta.replace_extension(".json");
        if (!fs::exists(meta))
          reports.push_back({f.string(), "", false,
                             "no metadata file " + meta.filename().string() +
                                 " beside it: build the plugin with kiji_add_tool() so the host can "
                                 "check it before loading"});
      }
    }
  }
  return reports;
}

PluginReport ToolRegistry::load_plugin(const std::string& path) {
  PluginReport report;
  report.path = path;
  auto refuse = [&](const std::string& why) {
    report.loaded = false;
    report.message = why;
    return report;
  };
  fs::path meta = path;
  if (meta.extension() != ".json") meta.replace_extension(".json");
  std::ifstream in(meta);
  if (!in) return refuse("cannot read the plugin's metadata file " + meta.string());
  json j;
  try {
    j = json::parse(in);
  } catch (const std::exception& e) {
    return refuse("metadata " + meta.string() + " is not valid JSON: " + e.what());
  }
  if (!j.is_object() || !j.contains("interface") || !j["interface"].is_string() || !j.contains("id") ||
      !j["id"].is_string() || !j.contains("abi") || !j["abi"].is_string())
    return refuse("metadata " + meta.string() + " lacks the fields interface, id and abi");
  report.id = j["id"].get<std::string>();
  const std::string interface_id = j["interface"].get<std::string>();
  if (interface_id != KIJI_TOOL_INTERFACE)
    return refuse("plugin '" + report.id + "' implements " + interface_id + " but this Kiji loads " +
                  KIJI_TOOL_INTERFACE + ": rebuild it against this version of Kiji");
  const std::string abi = j["abi"].get<std::string>();
  if (abi != abi_tag())
    return refuse("plugin '" + report.id + "' was built for another ABI (" + abi + ") than this Kiji's (" +
                  abi_tag() + "): rebuild it against this Kiji's headers with the same compiler");
  if (tools_.count(report.id))
    return refuse("tool id '" + report.id + "' is already taken by " + tools_.at(report.id).origin +
                  ": remove one of the two plugins or give one another id");
  const std::string lib_path = library_beside(meta, j);
  report.path = lib_path;
  if (!fs::exists(lib_path)) return refuse("library " + lib_path + " named by " + meta.string() + " does not exist");

  dlerror();
  void* handle = dlopen(lib_path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* err = dlerror();
    return refuse(lib_path + " is not a loadable library: " + std::string(err ? err : "unknown error"));
  }
  using EntryFn = const ToolPluginEntry* (*)();
  auto fn = reinterpret_cast<EntryFn>(dlsym(handle, KIJI_TOOL_PLUGIN_SYMBOL));
  if (!fn) {
    dlclose(handle);
    return refuse(lib_path + " has no entry point " KIJI_TOOL_PLUGIN_SYMBOL
                             ": a tool library must name its tool with KIJI_TOOL_PLUGIN(...)");
  }
  const ToolPluginEntry* entry = fn();
  if (!entry || !entry->interface_id || !entry->abi_tag || !entry->create || !entry->destroy) {
    dlclose(handle);
    return refuse(lib_path + " returned an incomplete plugin entry");
  }
  if (std::string(entry->interface_id) != KIJI_TOOL_INTERFACE || std::string(entry->abi_tag) != abi_tag()) {
    const std::string built = std::string(entry->interface_id) + ", " + entry->abi_tag;
    dlclose(handle);
    return refuse(lib_path + " was built for " + built + ", not for this Kiji (" KIJI_TOOL_INTERFACE ", " +
                  abi_tag() + "), though its metadata says otherwise: rebuild the plugin");
  }
  ToolInfo info;
  try {
    Tool* probe = entry->create();
    info = probe->info();
    entry->destroy(probe);
  } catch (const std::exception& e) {
    dlclose(handle);
    return refuse(lib_path + " failed to create its tool: " + e.what());
  }
  if (info.id != report.id) {
    dlclose(handle);
    return refuse(lib_path + " makes a tool with id '" + info.id + "' but its metadata says '" + report.id + "'");
  }
  auto library = std::make_shared<Library>();
  library->path = lib_path;
  library->handle = handle;
  library->entry = entry;
  libraries_.push_back(library);
  Entry e;
  e.info = std::move(info);
  e.origin = lib_path;
  e.factory = [library]() { return std::unique_ptr<Tool>(library->entry->create()); };
  tools_.emplace(report.id, std::move(e));
  report.loaded = true;
  return report;
}

void ToolRegistry::add(const std::string& id, ToolFactory factory, std::string origin) {
  if (tools_.count(id)) throw InputError("tool id '" + id + "' is already taken by " + tools_.at(id).origin);
  Entry e;
  e.info = factory()->info();
  if (e.info.id != id) throw InputError("tool registered as '" + id + "' says its id is '" + e.info.id + "'");
  e.origin = std::move(origin);
  e.factory = std::move(factory);
  tools_.emplace(id, std::move(e));
}

bool ToolRegistry::remove(const std::string& id) { return tools_.erase(id) > 0; }

bool ToolRegistry::has(const std::string& id) const { return tools_.count(id) > 0; }

std::vector<std::string> ToolRegistry::ids() const {
  std::vector<std::string> out;
  for (const auto& [id, e] : tools_) out.push_back(id);
  return out;
}

namespace {
std::string unknown_tool(const std::string& id, const std::vector<std::string>& known) {
  std::string list;
  for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
  return "unknown tool '" + id + "'" + (list.empty() ? ": no tools are loaded (check KIJI_PLUGIN_PATH)" : "; known: " + list);
}
}  // namespace

ToolInfo ToolRegistry::info(const std::string& id) const {
  auto it = tools_.find(id);
  if (it == tools_.end()) throw InputError(unknown_tool(id, ids()));
  return it->second.info;
}

std::unique_ptr<Tool> ToolRegistry::create(const std::string& id) const {
  auto it = tools_.find(id);
  if (it == tools_.end()) throw InputError(unknown_tool(id, ids()));
  return it->second.factory();
}

std::string ToolRegistry::origin(const std::string& id) const {
  auto it = tools_.find(id);
  if (it == tools_.end()) throw InputError(unknown_tool(id, ids()));
  return it->second.origin;
}

std::string tool_metadata_json(const ToolInfo& info, const std::string& library_file) {
  json j;
  j["interface"] = KIJI_TOOL_INTERFACE;
  j["abi"] = abi_tag();
  j["id"] = info.id;
  j["label"] = info.label;
  j["description"] = info.description;
  j["library"] = library_file;
  j["parameters"] = json::array();
  for (const auto& p : info.parameters) j["parameters"].push_back(param_json(p));
  return j.dump(2) + "\n";
}

}  // namespace kiji
