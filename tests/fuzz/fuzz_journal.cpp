// Journal files (kiji::load_journal): any bytes give strokes or an InputError.
#include "fuzz_input.h"
#include "kiji/error.h"
#include "kiji/journal_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    kiji::load_journal(kiji::fuzz::write_input(data, size, ".json"));
  } catch (const kiji::InputError&) {
  }
  return 0;
}
