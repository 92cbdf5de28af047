// Finds and loads tool plugins, in the manner of Qt's plugin loader: it reads each plugin's JSON
// metadata without loading the library, refuses what would not work (with the file and the reason),
// and only then opens the library. A broken plugin is reported, never fatal.
#pragma once

#include "kiji/tool.h"

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace kiji {

// What happened to one candidate plugin.
struct PluginReport {
  std::string path;     // the metadata file or library
  std::string id;       // the tool id, when known
  bool loaded = false;
  std::string message;  // why it was refused (empty when loaded)
};

using ToolFactory = std::function<std::unique_ptr<Tool>()>;

// Tools known to a host: loaded plugins, and tools registered in code.
class ToolRegistry {
 public:
  ToolRegistry();
  ~ToolRegistry();
  ToolRegistry(const ToolRegistry&) = delete;
  ToolRegistry& operator=(const ToolRegistry&) = delete;

  // The folders searched, in order: $KIJI_PLUGIN_PATH (':'-separated), the build tree's plugins
  // folder, and the install tree's lib/kiji/plugins, found from where libkiji itself lives.
  static std::vector<std::string> default_search_path();

  // Loads every plugin found in the folders (default_search_path() if empty). Returns a report for
  // each candidate; refused ones say why. A tool id already registered is refused.
  std::vector<PluginReport> load_plugins(const std::vector<std::string>& folders = {});
  // Loads one plugin from its metadata file (NAME.json) or its library (the .json beside it).
  // Whatever the files hold (a library that is not one, that returns no tool, that throws anything
  // while making or describing it), the answer is a report, never a crash or an exception.
  PluginReport load_plugin(const std::string& path);
  // Registers a tool built into the host (tests, the app, a tool written in Python); `origin` is
  // what origin() says of it. Throws InputError if the id is taken.
  void add(const std::string& id, ToolFactory factory, std::string origin = "built in");

  // Forgets a tool (one a script registers again after changing it). Sessions keep the instances
  // they already made. False if there was no tool of that id.
  bool remove(const std::string& id);

  bool has(const std::string& id) const;
  std::vector<std::string> ids() const;  // sorted
  ToolInfo info(const std::string& id) const;
  // A new instance of a tool; throws InputError naming the known tools if the id is unknown, and
  // kiji::Error if the plugin cannot make one. A plugin's tool is given back to the plugin's own
  // destroy, and what it throws that is not a std::exception reaches the caller as a kiji::Error.
  std::unique_ptr<Tool> create(const std::string& id) const;
  // Where a tool came from ("built in" or the library's path).
  std::string origin(const std::string& id) const;

 private:
  struct Library;
  class PluginTool;
  struct Entry {
    ToolFactory factory;
    ToolInfo info;
    std::string origin;
  };
  std::vector<std::shared_ptr<Library>> libraries_;
  std::map<std::string, Entry> tools_;
};

// Throws InputError if a tool's description would not work in every host: an id or a parameter
// name that is not a Python identifier, no label, a parameter declared twice, a default out of range.
void check_tool_info(const ToolInfo& info);

// What to do about a plugin built for another tool interface than KIJI_TOOL_INTERFACE: what changed
// since the plugin's version, and to rebuild it against this Kiji.
std::string interface_advice(const std::string& plugin_interface);

// Metadata of a plugin library as JSON (what `kiji_add_tool` writes beside each library).
std::string tool_metadata_json(const ToolInfo& info, const std::string& library_file);

}  // namespace kiji
