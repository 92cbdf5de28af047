// A thread ended by pthread_exit (as Python ends one that wants the GIL while the interpreter
// finalises) unwinds with a special exception that must be rethrown: a catch (...) that swallows it
// aborts the process. Put KIJI_RETHROW_FORCED_UNWIND before each catch (...) on such a thread.
#pragma once

#if defined(__GLIBCXX__)
#include <cxxabi.h>
#define KIJI_RETHROW_FORCED_UNWIND \
  catch (abi::__forced_unwind&) {  \
    throw;                         \
  }
#else
#define KIJI_RETHROW_FORCED_UNWIND
#endif
