#include "kiji/plugin_loader.h"

#include "kiji/error.h"
#include "tools/identifier.h"

#include <dlfcn.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
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

// What `entry->create()` made, or why it made nothing. A plugin can return null or throw anything;
// neither may take the host down, and a message must be copied out of an exception the plugin threw
// before its library can be closed (the exception's code lives there).
struct Created {
  Tool* tool = nullptr;
  std::string error;
};

Created create_tool(const ToolPluginEntry& entry) {
  Created c;
  try {
    c.tool = entry.create();
    if (!c.tool) c.error = "its create() returned no tool (a null pointer)";
  } catch (const std::exception& e) {
    c.error = std::string("its create() threw: ") + e.what();
  } catch (...) {
    c.error = "its create() threw something that is not a std::exception";
  }
  return c;
}

// Gives a tool back to the library that made it; a destroy that throws is not the host's problem.
void destroy_tool(const ToolPluginEntry& entry, Tool* tool) noexcept {
  try {
    entry.destroy(tool);
  } catch (...) {
  }
}

}  // namespace

// A plugin's tool as the host holds it: the plugin's own instance, given back to the plugin's
// `destroy` (the library that allocated it frees it), with what the plugin throws that is not a
// std::exception turned into a kiji::Error naming the tool, so that no caller meets an exception it
// cannot catch by type. Its info is the one the loader checked.
class ToolRegistry::PluginTool final : public Tool {
 public:
  PluginTool(std::shared_ptr<const Library> library, const ToolInfo& info) : library_(std::move(library)), info_(info) {
    Created c = create_tool(*library_->entry);
    if (!c.tool) throw Error("tool '" + info_.id + "' from " + library_->path + " cannot be created: " + c.error);
    tool_ = c.tool;
  }
  ~PluginTool() override { destroy_tool(*library_->entry, tool_); }

  ToolInfo info() const override { return info_; }
  Feedback begin(ToolContext& context, const ParamSet& params, const ToolEvent& event) override {
    return guarded("begin", [&] { return tool_->begin(context, params, event); });
  }
  Feedback update(ToolContext& context, const ToolEvent& event) override {
    return guarded("update", [&] { return tool_->update(context, event); });
  }
  void end(ToolContext& context, const ToolEvent& event) override {
    guarded("end", [&] { tool_->end(context, event); });
  }
  void cancel(ToolContext& context) override {
    guarded("cancel", [&] { tool_->cancel(context); });
  }
  Feedback haptic_force(const HapticSnapshot& snapshot, const ToolEvent& event) const override {
    return guarded("haptic_force", [&] { return tool_->haptic_force(snapshot, event); });
  }

 private:
  template <typename F>
  auto guarded(const char* call, F&& f) const -> decltype(f()) {
    try {
      return f();
    } catch (const std::exception&) {
      throw;  // the host catches these by type (kiji::InputError and the rest)
    } catch (...) {
      throw Error("tool '" + info_.id + "' (" + library_->path + ") threw something that is not a "
                  "std::exception from " + call + "(); its author should throw kiji::InputError or another "
                  "std::exception");
    }
  }

  std::shared_ptr<const Library> library_;
  ToolInfo info_;
  Tool* tool_ = nullptr;
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

// The library a metadata file describes: the file it names beside it, or the same stem with .so.
// Only a file name is accepted, so that metadata cannot send the host to load a library elsewhere.
bool library_beside(const fs::path& metadata, const json& j, std::string& path, std::string& error) {
  if (!j.contains("library")) {
    path = fs::path(metadata).replace_extension(".so").string();
    return true;
  }
  if (!j["library"].is_string()) {
    error = "its field 'library' is not a string";
    return false;
  }
  const std::string name = j["library"].get<std::string>();
  if (name.empty() || name == "." || name == ".." || name.find('/') != std::string::npos ||
      name.find('\0') != std::string::npos) {
    error = "its field 'library' is '" + name + "', not the file name of a library beside it";
    return false;
  }
  path = (metadata.parent_path() / name).string();
  return true;
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

// Plugin metadata is a few kilobytes; anything far larger is not metadata.
constexpr std::uintmax_t kMaxMetadataBytes = 1 << 20;

}  // namespace

void check_tool_info(const ToolInfo& info) {
  if (!detail::is_identifier(info.id))
    throw InputError("tool id '" + info.id + "' is not a verb usable as a Python name (letters, digits and _)");
  if (info.label.empty()) throw InputError("tool '" + info.id + "' has no label");
  std::set<std::string> names;
  for (const auto& p : info.parameters) {
    if (!detail::is_identifier(p.name))
      throw InputError("tool '" + info.id + "': parameter name '" + p.name +
                       "' is not an identifier: use letters, digits and _");
    if (!names.insert(p.name).second)
      throw InputError("tool '" + info.id + "': parameter '" + p.name + "' is declared twice");
    try {
      p.check(p.default_value);
    } catch (const Error& e) {
      throw InputError("tool '" + info.id + "': the default of " + e.what());
    }
  }
}

std::string interface_advice(const std::string& plugin_interface) {
  if (plugin_interface == "org.kiji.Tool/1")
    return "the tools of org.kiji.Tool/1 were given the whole kiji::Session; those of " KIJI_TOOL_INTERFACE
           " are given a kiji::ToolContext (kiji/tool_context.h: the garments, the body, the clock, picking and "
           "hands on the solver), and the haptic snapshot and force models are in kiji/haptic_force.h. Change "
           "the tool's begin, update, end and cancel to take a kiji::ToolContext& in place of kiji::Session&, "
           "and rebuild it against this Kiji (docs/plugins.md)";
  return "rebuild it against this version of Kiji";
}

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
    fs::directory_iterator it(folder, ec), end;
    for (; !ec && it != end; it.increment(ec)) files.push_back(it->path());
    if (ec) {
      reports.push_back({folder, "", false, "plugin folder cannot be listed: " + ec.message()});
      continue;
    }
    std::sort(files.begin(), files.end());
    for (const auto& f : files) {
      if (f.extension() == ".json") {
        reports.push_back(load_plugin(f.string()));
      } else if (f.extension() == ".so") {
        fs::path meta = f;
        meta.replace_extension(".json");
        if (!fs::exists(meta, ec))
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
  // Only a regular file of a sensible size is read: a FIFO would block the host, a device never end.
  std::error_code ec;
  if (!fs::is_regular_file(meta, ec))
    return refuse("cannot read the plugin's metadata file " + meta.string() + ": " +
                  (fs::exists(meta, ec) ? "it is not a regular file" : "it does not exist"));
  const std::uintmax_t size = fs::file_size(meta, ec);
  if (ec || size > kMaxMetadataBytes)
    return refuse("the plugin's metadata file " + meta.string() + " is " +
                  (ec ? "unreadable" : std::to_string(size) + " bytes") + ", not metadata (at most " +
                  std::to_string(kMaxMetadataBytes) + " bytes); rebuild the plugin with kiji_add_tool()");
  std::ifstream in(meta, std::ios::binary);
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
                  KIJI_TOOL_INTERFACE + ": " + interface_advice(interface_id));
  const std::string abi = j["abi"].get<std::string>();
  if (abi != abi_tag())
    return refuse("plugin '" + report.id + "' was built for another ABI (" + abi + ") than this Kiji's (" +
                  abi_tag() + "): " + abi_difference(abi, abi_tag()));
  if (tools_.count(report.id))
    return refuse("tool id '" + report.id + "' is already taken by " + tools_.at(report.id).origin +
                  ": remove one of the two plugins or give one another id");
  std::string lib_path, lib_error;
  if (!library_beside(meta, j, lib_path, lib_error)) return refuse("metadata " + meta.string() + ": " + lib_error);
  report.path = lib_path;
  if (!fs::exists(lib_path, ec)) return refuse("library " + lib_path + " named by " + meta.string() + " does not exist");
  if (!fs::is_regular_file(lib_path, ec)) return refuse("library " + lib_path + " is not a regular file");

  dlerror();
  void* handle = dlopen(lib_path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* err = dlerror();
    return refuse(lib_path + " is not a loadable library: " + std::string(err ? err : "unknown error"));
  }
  // Every refusal from here closes the library, after everything its code made is gone.
  auto refuse_loaded = [&](const std::string& why) {
    dlclose(handle);
    return refuse(why);
  };
  using EntryFn = const ToolPluginEntry* (*)();
  auto fn = reinterpret_cast<EntryFn>(dlsym(handle, KIJI_TOOL_PLUGIN_SYMBOL));
  if (!fn)
    return refuse_loaded(lib_path + " has no entry point " KIJI_TOOL_PLUGIN_SYMBOL
                                    ": a tool library must name its tool with KIJI_TOOL_PLUGIN(...)");
  const ToolPluginEntry* entry = fn();
  if (!entry || !entry->interface_id || !entry->abi_tag || !entry->create || !entry->destroy)
    return refuse_loaded(lib_path + " returned an incomplete plugin entry");
  if (std::string(entry->interface_id) != KIJI_TOOL_INTERFACE)
    return refuse_loaded(lib_path + " was built for " + entry->interface_id + ", not for this Kiji's " +
                         KIJI_TOOL_INTERFACE + ", though its metadata says otherwise: " +
                         interface_advice(entry->interface_id));
  if (const std::string diff = abi_difference(entry->abi_tag, abi_tag()); !diff.empty())
    return refuse_loaded(lib_path + " was built for the ABI " + entry->abi_tag + ", not for this Kiji's (" +
                         abi_tag() + "), though its metadata says otherwise: " + diff);

  // One tool made and given back, to read what the library says of itself.
  const Created probe = create_tool(*entry);
  if (!probe.tool) return refuse_loaded(lib_path + " cannot make its tool: " + probe.error);
  ToolInfo info;
  std::string info_error;
  try {
    info = probe.tool->info();
  } catch (const std::exception& e) {
    info_error = std::string("its tool's info() threw: ") + e.what();
  } catch (...) {
    info_error = "its tool's info() threw something that is not a std::exception";
  }
  destroy_tool(*entry, probe.tool);
  if (!info_error.empty()) return refuse_loaded(lib_path + " cannot describe its tool: " + info_error);
  if (info.id != report.id)
    return refuse_loaded(lib_path + " makes a tool with id '" + info.id + "' but its metadata says '" + report.id + "'");
  try {
    check_tool_info(info);
  } catch (const Error& e) {
    return refuse_loaded(lib_path + ": " + e.what());
  }
  auto library = std::make_shared<Library>();
  library->path = lib_path;
  library->handle = handle;
  library->entry = entry;
  libraries_.push_back(library);
  Entry e;
  e.info = info;
  e.origin = lib_path;
  e.factory = [library, info = std::move(info)]() -> std::unique_ptr<Tool> {
    return std::make_unique<PluginTool>(library, info);
  };
  tools_.emplace(report.id, std::move(e));
  report.loaded = true;
  return report;
}

void ToolRegistry::add(const std::string& id, ToolFactory factory, std::string origin) {
  if (tools_.count(id)) throw InputError("tool id '" + id + "' is already taken by " + tools_.at(id).origin);
  const std::unique_ptr<Tool> probe = factory ? factory() : nullptr;
  if (!probe) throw InputError("tool '" + id + "' registered with a factory that makes no tool");
  Entry e;
  e.info = probe->info();
  if (e.info.id != id) throw InputError("tool registered as '" + id + "' says its id is '" + e.info.id + "'");
  check_tool_info(e.info);
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
  std::unique_ptr<Tool> tool = it->second.factory();
  if (!tool) throw Error("tool '" + id + "' (" + it->second.origin + ") made no tool");
  return tool;
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
