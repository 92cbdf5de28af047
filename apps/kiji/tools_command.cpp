// kiji tools: the tool plugins this Kiji finds, with their parameters; refused plugins and why.
#include "args.h"
#include "commands.h"
#include "kiji/plugin_loader.h"

#include <cstdio>
#include <sstream>

namespace kiji::cli {


int tools_command(const std::vector<std::string>& argv) {
  const Args args(argv, {"--path"}, {"--help", "-h"});
  if (args.has("--help") || args.has("-h")) {
    std::puts("usage: kiji tools [--path DIR[:DIR...]]\n\nLists the tool plugins found (in KIJI_PLUGIN_PATH, the build tree "
              "and the install tree,\nor in --path), each with its parameters, and the plugins refused, with the reason.");
    return 0;
  }
  std::vector<std::string> folders;
  if (args.has("--path")) {
    std::stringstream ss(args.get("--path", ""));
    std::string item;
    while (std::getline(ss, item, ':'))
      if (!item.empty()) folders.push_back(item);
  }
  ToolRegistry registry;
  const auto reports = registry.load_plugins(folders);
  const auto ids = registry.ids();
  std::printf("%zu tools\n", ids.size());
  for (const auto& id : ids) {
    const ToolInfo info = registry.info(id);
    std::printf("\n%s — %s\n  %s\n  from %s\n", id.c_str(), info.label.c_str(), info.description.c_str(),
                registry.origin(id).c_str());
    for (const auto& p : info.parameters) {
      std::printf("  %-16s %-6s default %s", p.name.c_str(), param_type_name(p.type), param_value_text(p.default_value).c_str());
      if ((p.type == ParamType::Float || p.type == ParamType::Int) && p.min != p.max)
        std::printf(", %g to %g", p.min, p.max);
      if (!p.unit.empty()) std::printf(" %s", p.unit.c_str());
      if (p.type == ParamType::Choice) {
        std::printf(", one of");
        for (const auto& c : p.choices) std::printf(" '%s'", c.c_str());
      }
      std::printf("\n  %-16s %s\n", "", p.help.c_str());
    }
  }
  bool refused = false;
  for (const auto& r : reports)
    if (!r.loaded) {
      if (!refused) std::printf("\nrefused:\n");
      refused = true;
      std::printf("  %s: %s\n", r.path.c_str(), r.message.c_str());
    }
  return 0;
}

}  // namespace kiji::cli
