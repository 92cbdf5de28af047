// The binary forms of operations, garments and bodies (kiji/operation.h): what session files carry
// and peers send. The first byte picks the decoder; any bytes give a value or an InputError, a
// decoded garment is a valid mesh, and a decoded operation that a session accepts leaves its
// garments finite.
#include "fuzz_session.h"
#include "kiji/error.h"
#include "kiji/operation.h"

#include <cstddef>
#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::string_view bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    switch (data[0] % 3) {
      case 0: {
        const kiji::Operation op = kiji::decode_operation(bytes);
        // What was decoded encodes back to bytes that decode to the same encoding.
        const std::string again = kiji::encode_operation(op);
        if (kiji::encode_operation(kiji::decode_operation(again)) != again) __builtin_trap();
        kiji::fuzz::perform_and_check({op});
        break;
      }
      case 1:
        if (!kiji::decode_garment(bytes).is_valid()) __builtin_trap();
        break;
      default:
        kiji::decode_body(bytes);
        break;
    }
  } catch (const kiji::InputError&) {
  }
  return 0;
}
