// hash_bytes (kiji/codec.h): FNV-1a, which names payloads and states.
#include "kiji/codec.h"

namespace kiji {

std::uint64_t hash_bytes(std::string_view bytes, std::uint64_t seed) {
  std::uint64_t h = seed;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 0x100000001b3ull;
  }
  return h;
}

}  // namespace kiji
