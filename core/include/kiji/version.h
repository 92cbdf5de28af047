// Kiji's version, and the ABI tag plugins are checked against.
#pragma once

namespace kiji {

const char* version();

}  // namespace kiji
