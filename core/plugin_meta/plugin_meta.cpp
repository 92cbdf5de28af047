// kiji-plugin-meta: writes a tool plugin's JSON metadata from the plugin itself.
//
//   kiji-plugin-meta [--id ID] <library> <output.json>
//
// kiji_add_tool() runs it after every link, so a tool's parameters are declared once, in C++, and
// the host still reads them (and the ABI tag) without loading the library. It refuses, with a
// non-zero exit and no output file, a library the host would refuse: no entry point, another
// interface or ABI, another id than ID, or parameters that are not well declared.
#include "kiji/error.h"
#include "kiji/params.h"
#include "kiji/plugin_loader.h"
#include "kiji/tool.h"
#include "kiji/version.h"

#include <dlfcn.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>

namespace fs = std::filesystem;

namespace {

struct Failure {
  std::string message;
};

// Loads the library and returns its tool's info, checked as the host would check it.
kiji::ToolInfo read_info(const std::string& library, const std::string& expected_id) {
  dlerror();
  // The library stays open until the process exits: its code made the strings we hold.
  void* handle = dlopen(fs::absolute(library).c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* err = dlerror();
    throw Failure{"not a loadable library: " + std::string(err ? err : "unknown error")};
  }
  using EntryFn = const kiji::ToolPluginEntry* (*)();
  auto fn = reinterpret_cast<EntryFn>(dlsym(handle, KIJI_TOOL_PLUGIN_SYMBOL));
  if (!fn)
    throw Failure{"no entry point " KIJI_TOOL_PLUGIN_SYMBOL ": name the tool class with KIJI_TOOL_PLUGIN(...)"};
  const kiji::ToolPluginEntry* entry = fn();
  if (!entry || !entry->interface_id || !entry->abi_tag || !entry->create || !entry->destroy)
    throw Failure{"its plugin entry is incomplete"};
  if (std::string(entry->interface_id) != KIJI_TOOL_INTERFACE)
    throw Failure{std::string("built for interface ") + entry->interface_id + ", but this Kiji loads " +
                  KIJI_TOOL_INTERFACE + ": " + kiji::interface_advice(entry->interface_id)};
  if (const std::string diff = kiji::abi_difference(entry->abi_tag, kiji::abi_tag()); !diff.empty())
    throw Failure{std::string("built for ABI ") + entry->abi_tag + ", but this Kiji's is " + kiji::abi_tag() + ": " +
                  diff};

  // Made and described as the host will (kiji::ToolRegistry::load_plugin): a null tool or anything
  // thrown is a refusal, and the tool goes back to the library's own destroy.
  kiji::ToolInfo info;
  kiji::Tool* tool = nullptr;
  try {
    tool = entry->create();
    if (!tool) throw Failure{"its create() returned no tool (a null pointer)"};
    info = tool->info();
  } catch (const Failure&) {
    throw;
  } catch (const std::exception& e) {
    if (tool) entry->destroy(tool);
    throw Failure{std::string("making or describing its tool threw: ") + e.what()};
  } catch (...) {
    if (tool) entry->destroy(tool);
    throw Failure{"making or describing its tool threw something that is not a std::exception"};
  }
  entry->destroy(tool);

  if (!expected_id.empty() && info.id != expected_id)
    throw Failure{"its tool says its id is '" + info.id + "' but it is built as '" + expected_id +
                  "': make info().id and kiji_add_tool()'s id the same"};
  try {
    kiji::check_tool_info(info);
  } catch (const kiji::Error& e) {
    throw Failure{e.what()};
  }
  return info;
}

}  // namespace

int main(int argc, char** argv) {
  std::string expected_id, library, output;
  int i = 1;
  if (i + 1 < argc && std::string(argv[i]) == "--id") {
    expected_id = argv[i + 1];
    i += 2;
  }
  if (argc - i != 2) {
    std::cerr << "usage: kiji-plugin-meta [--id ID] <library> <output.json>\n";
    return 2;
  }
  library = argv[i];
  output = argv[i + 1];

  // A stale file would let the host trust a library that no longer matches it.
  std::error_code ec;
  fs::remove(output, ec);
  try {
    const kiji::ToolInfo info = read_info(library, expected_id);
    const std::string text = kiji::tool_metadata_json(info, fs::path(library).filename().string());
    const std::string partial = output + ".partial";
    {
      std::ofstream out(partial, std::ios::binary);
      out << text;
      if (!out.flush()) throw Failure{"cannot write " + partial};
    }
    fs::rename(partial, output, ec);
    if (ec) throw Failure{"cannot write " + output + ": " + ec.message()};
  } catch (const Failure& f) {
    std::cerr << "kiji-plugin-meta: " << library << ": " << f.message << "\n";
    return 1;
  }
  return 0;
}
