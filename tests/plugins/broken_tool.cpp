// "broken": a tool whose plugin misbehaves in the ways a host must survive. One compile definition
// picks the defect of each build (see CMakeLists.txt):
//   KIJI_TEST_CREATE_NULL        create() returns a null pointer
//   KIJI_TEST_CREATE_NULL_LATER  create() makes one tool, then returns null
//   KIJI_TEST_CREATE_THROWS_INT  create() throws an int
//   KIJI_TEST_CREATE_THROWS_OWN  create() throws an exception class defined in this library
//   KIJI_TEST_INFO_THROWS        info() throws a struct that is not a std::exception
//   KIJI_TEST_BEGIN_THROWS_INT   begin() throws an int: the plugin loads, its strokes fail
#include "kiji/session.h"
#include "kiji/tool.h"

#include <exception>

namespace {

// Its code (what() and the destructor) lives in this library only.
struct PluginOwnError : std::exception {
  const char* what() const noexcept override { return "the plugin's own exception, thrown by create()"; }
};

struct NotAnException {
  int code = 7;
};

class BrokenTool : public kiji::Tool {
 public:
  kiji::ToolInfo info() const override {
#ifdef KIJI_TEST_INFO_THROWS
    throw NotAnException{};
#endif
    return {"broken", "Broken", "A tool whose plugin misbehaves; for the plugin loader's tests.", {}};
  }
  kiji::Feedback begin(kiji::Session&, const kiji::ParamSet&, const kiji::ToolEvent&) override {
#ifdef KIJI_TEST_BEGIN_THROWS_INT
    throw 42;
#endif
    return {};
  }
  kiji::Feedback update(kiji::Session&, const kiji::ToolEvent&) override { return {}; }
  void end(kiji::Session&, const kiji::ToolEvent&) override {}
  void cancel(kiji::Session&) override {}
};

kiji::Tool* create() {
#if defined(KIJI_TEST_CREATE_NULL)
  return nullptr;
#elif defined(KIJI_TEST_CREATE_NULL_LATER)
  static int made = 0;
  return made++ == 0 ? new BrokenTool() : nullptr;
#elif defined(KIJI_TEST_CREATE_THROWS_INT)
  throw 42;
#elif defined(KIJI_TEST_CREATE_THROWS_OWN)
  throw PluginOwnError();
#else
  return new BrokenTool();
#endif
}

void destroy(kiji::Tool* tool) { delete tool; }

}  // namespace

// KIJI_TOOL_PLUGIN's entry, with this file's create().
extern "C" __attribute__((visibility("default"))) const kiji::ToolPluginEntry* kiji_tool_plugin_v1() {
  static char abi[kiji::detail::kAbiTagCapacity];
  static const kiji::ToolPluginEntry entry{KIJI_TOOL_INTERFACE, kiji::detail::write_abi_tag(abi, sizeof abi, KIJI_ABI_TAG),
                                           create, destroy};
  return &entry;
}
