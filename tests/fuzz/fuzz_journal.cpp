// Journal files (kiji::read_journal_file): any bytes give strokes and operations or an InputError,
// and the operations a session accepts leave its garments finite.
#include "fuzz_input.h"
#include "fuzz_session.h"
#include "kiji/error.h"
#include "kiji/journal_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const kiji::JournalFile file = kiji::read_journal_file(kiji::fuzz::write_input(data, size, ".json"));
    kiji::fuzz::perform_and_check(file.operations);
  } catch (const kiji::InputError&) {
  }
  return 0;
}
