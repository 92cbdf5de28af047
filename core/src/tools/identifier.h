// A name a script or a plugin can use for a tool or a parameter.
#pragma once

#include <cctype>
#include <string>

namespace kiji::detail {

// Letters, digits and _, not starting with a digit.
inline bool is_identifier(const std::string& s) {
  if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) return false;
  return true;
}

}  // namespace kiji::detail
