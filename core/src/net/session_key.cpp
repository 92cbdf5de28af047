#include "kiji/session_key.h"

#include "kiji/error.h"

#include <sodium.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace kiji {

std::string read_session_key(const std::string& path, bool make_if_missing, bool* made) {
  namespace fs = std::filesystem;
  if (made) *made = false;
  if (path.empty()) throw InputError("a shared session needs a key file: give its path");
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    if (!make_if_missing)
      throw InputError("the key file '" + path + "' does not exist: the host of the session makes it (kiji peer "
                       "--host --key-file FILE, or Host session in Kiji Studio); copy it here");
    if (sodium_init() < 0) throw InputError("libsodium could not start");
    unsigned char raw[32];
    randombytes_buf(raw, sizeof raw);
    char hex[65];
    sodium_bin2hex(hex, sizeof hex, raw, sizeof raw);
    {
      // Created empty and made private before the key is written, so that it is never readable by others.
      std::ofstream create(path);
      if (!create) throw InputError("cannot write the key file '" + path + "': check the folder exists and is writable");
    }
    fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write, ec);
    std::ofstream out(path, std::ios::trunc);
    out << hex << "\n";
    out.close();
    if (!out || ec) throw InputError("cannot write the key file '" + path + "'");
    if (made) *made = true;
  }
  std::ifstream in(path);
  if (!in) throw InputError("cannot read the key file '" + path + "'");
  std::stringstream text;
  text << in.rdbuf();
  std::string key = text.str();
  while (!key.empty() && (key.back() == '\n' || key.back() == '\r' || key.back() == ' ' || key.back() == '\t'))
    key.pop_back();
  std::size_t start = 0;
  while (start < key.size() && (key[start] == ' ' || key[start] == '\t')) ++start;
  key.erase(0, start);
  if (key.size() < 16) throw InputError("the key in '" + path + "' is shorter than 16 characters: use the host's key file");
  return key;
}

}  // namespace kiji
