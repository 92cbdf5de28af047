// "pool": a tool whose plugin makes its tools in a pool of its own, not with the host's new, so
// that only the plugin's own destroy can free one (the host's delete would free memory that no
// allocator gave out). It counts what it made and what it was given back.
#include "kiji/session.h"
#include "kiji/tool.h"

#include <atomic>
#include <new>

namespace {

class PoolTool : public kiji::Tool {
 public:
  kiji::ToolInfo info() const override {
    return {"pool", "Pool", "A tool made in its plugin's own pool; for the plugin loader's tests.", {}};
  }
  kiji::Feedback begin(kiji::Session&, const kiji::ParamSet&, const kiji::ToolEvent&) override { return {}; }
  kiji::Feedback update(kiji::Session&, const kiji::ToolEvent&) override { return {}; }
  void end(kiji::Session&, const kiji::ToolEvent&) override {}
  void cancel(kiji::Session&) override {}
};

constexpr int kSlots = 64;
alignas(PoolTool) unsigned char pool[kSlots][sizeof(PoolTool)];
std::atomic<int> made{0}, destroyed{0};

kiji::Tool* create() {
  const int slot = made.fetch_add(1);
  if (slot >= kSlots) return nullptr;
  return new (pool[slot]) PoolTool();
}

void destroy(kiji::Tool* tool) {
  tool->~Tool();
  destroyed.fetch_add(1);
}

}  // namespace

extern "C" __attribute__((visibility("default"))) const kiji::ToolPluginEntry* kiji_tool_plugin_v1() {
  static char abi[kiji::detail::kAbiTagCapacity];
  static const kiji::ToolPluginEntry entry{KIJI_TOOL_INTERFACE, kiji::detail::write_abi_tag(abi, sizeof abi, KIJI_ABI_TAG),
                                           create, destroy};
  return &entry;
}

// For the tests: how many tools the plugin made, and how many it was given back.
extern "C" __attribute__((visibility("default"))) int kiji_test_pool_made() { return made.load(); }
extern "C" __attribute__((visibility("default"))) int kiji_test_pool_destroyed() { return destroyed.load(); }
