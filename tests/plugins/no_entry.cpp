// A library that is not a tool: it exports something, but no KIJI_TOOL_PLUGIN entry point.
extern "C" __attribute__((visibility("default"))) int kiji_test_not_a_tool() { return 1; }
