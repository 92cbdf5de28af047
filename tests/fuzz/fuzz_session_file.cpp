// Session files (kiji::load_session, the LCM log a session autosaves to and recovers from): any
// bytes give operations (with a damaged tail reported) or an InputError.
#include "fuzz_input.h"
#include "kiji/error.h"
#include "kiji/session_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    kiji::SessionFileReport report;
    kiji::load_session(kiji::fuzz::write_input(data, size, ".kiji"), &report);
    if (report.good_bytes > report.file_bytes || report.file_bytes != size) __builtin_trap();
  } catch (const kiji::InputError&) {
  }
  return 0;
}
