// Helpers for the tests of what a user is told when the input is bad.
#pragma once

#include "kiji/error.h"

#include <gtest/gtest.h>

#include <string>

namespace kiji::test {

// The message of the InputError that f throws (fails the test if it throws nothing, or another
// exception escapes).
template <typename F>
std::string input_error(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an InputError";
  return {};
}

}  // namespace kiji::test
