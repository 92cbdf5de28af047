// The shared secret of a session shared by peers (kiji/peer.h): read from a key file, or made in a
// new one that only its owner may read, for the host to give to those who join.
#pragma once

#include <string>

namespace kiji {

// The key in `path` (surrounding white space dropped). When the file does not exist and
// `make_if_missing`, writes a fresh random key there first (mode 0600) and sets *made. Throws
// InputError saying what to do for a missing file, one that cannot be read or written, or a key
// shorter than 16 characters.
std::string read_session_key(const std::string& path, bool make_if_missing, bool* made = nullptr);

}  // namespace kiji
