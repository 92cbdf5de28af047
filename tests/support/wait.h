// Waiting in tests that run threads or devices in real time: for what is expected, with a bound
// generous for a loaded machine or a sanitizer build, never a fixed sleep (docs/testing.md).
#pragma once

#include <chrono>
#include <thread>

namespace kiji::test {

// Whether done() became true within `ms` milliseconds (checked every millisecond).
template <typename P>
bool wait_until(P done, int ms = 5000) {
  for (int i = 0; i < ms && !done(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  return done();
}

}  // namespace kiji::test
