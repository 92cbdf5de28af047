// Tool plugin metadata (kiji::ToolRegistry::load_plugin on a NAME.json): any bytes give a report,
// never an exception or a crash. The library it may name is not there, so nothing is loaded.
#include "fuzz_input.h"
#include "kiji/plugin_loader.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  kiji::ToolRegistry registry;
  const kiji::PluginReport report = registry.load_plugin(kiji::fuzz::write_input(data, size, ".json"));
  if (report.loaded || report.message.empty()) __builtin_trap();
  return 0;
}
