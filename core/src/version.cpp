#include "kiji/version.h"

namespace kiji {

const char* version() { return KIJI_STR(KIJI_VERSION_MAJOR) "." KIJI_STR(KIJI_VERSION_MINOR) ".0"; }

const char* abi_tag() { return KIJI_ABI_TAG; }

}  // namespace kiji
