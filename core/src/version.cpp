#include "kiji/version.h"

namespace kiji {

const char* version() { return KIJI_VERSION_STRING; }

}  // namespace kiji
