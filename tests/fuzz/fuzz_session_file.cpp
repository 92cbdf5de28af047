// Session files (kiji::load_session, the LCM log a session autosaves to and recovers from): any
// bytes give operations (with a damaged tail reported) or an InputError, and the operations a
// session accepts leave its garments finite.
#include "fuzz_input.h"
#include "fuzz_session.h"
#include "kiji/error.h"
#include "kiji/session_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    kiji::SessionFileReport report;
    const auto operations = kiji::load_session(kiji::fuzz::write_input(data, size, ".kiji"), &report);
    if (report.good_bytes > report.file_bytes || report.file_bytes != size) __builtin_trap();
    kiji::fuzz::perform_and_check(operations);
  } catch (const kiji::InputError&) {
  }
  return 0;
}
