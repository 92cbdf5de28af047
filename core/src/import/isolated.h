// Runs a piece of work (reading an outside file with assimp) in a forked child process under memory
// and time limits, and brings its result back as bytes. Private to libkiji.
#pragma once

#include "kiji/import_limits.h"

#include <functional>
#include <string>

namespace kiji::detail {

// Calls work() in a child process and returns what it returned. An InputError thrown there is thrown
// here with its message. A child that crashes, takes more than the limits allow, or stops without a
// result gives an InputError that begins with `what` ("cannot load body 'x.fbx'") and says which.
// The calling process's state is untouched whatever the child does. Throws Error when no process can
// be started. With limits.isolate false, work() runs here, unlimited.
std::string run_isolated(const std::function<std::string()>& work, const ImportLimits& limits,
                         const std::string& what);

}  // namespace kiji::detail
