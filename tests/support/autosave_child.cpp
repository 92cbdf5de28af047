// A design session with autosave on that runs until it is killed: the child of the kill -9 test
// (tests/core/session/test_session_file.cpp). After each call returns it prints how many operations the session
// has applied, so the test knows what must survive the kill.
//   autosave_child SESSION_FILE PLUGIN_DIR
#include "support/design_calls.h"
#include "kiji/pattern.h"
#include "kiji/session.h"
#include "kiji/session_file.h"

#include <cstdio>

using namespace kiji;

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: autosave_child SESSION_FILE PLUGIN_DIR\n");
    return 2;
  }
  auto registry = std::make_shared<ToolRegistry>();
  registry->load_plugins({argv[2]});
  Session s(registry);
  Autosave save(s, argv[1]);
  std::printf("%zu\n", s.journal().operations().size());  // the file exists: the test may kill from now on
  std::fflush(stdout);
  s.add_garment(make_rectangle(0.6, 0.4, 13, 9));
  for (int k = 0;; ++k) {
    test::design_call(s, k);
    std::printf("%zu\n", s.journal().operations().size());
    std::fflush(stdout);
  }
}
