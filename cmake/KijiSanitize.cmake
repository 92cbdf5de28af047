# Sanitizer and fuzzing builds (scripts/sanitize.sh and scripts/fuzz.sh configure them).
#
#   -DKIJI_SANITIZE=address,undefined   AddressSanitizer + UndefinedBehaviorSanitizer
#   -DKIJI_SANITIZE=thread              ThreadSanitizer
#   -DKIJI_BUILD_FUZZERS=ON             the libFuzzer targets of tests/fuzz (clang, with address,undefined)
#
# Everything the build compiles is instrumented, libkiji, the tools and the tests alike. Any report
# ends the process with an error (-fno-sanitize-recover), so a finding fails its test. With clang the
# ASan/UBSan runtime is the shared one (-shared-libsan): the tool plugins link with --no-undefined,
# and a Python interpreter can preload the same runtime the module uses. ThreadSanitizer keeps its
# static runtime: the shared one initialises after glib's constructors, whose first malloc crashes it.
include_guard(GLOBAL)

set(KIJI_SANITIZE "" CACHE STRING "Sanitizers to build with: address,undefined or thread (empty: none)")
option(KIJI_BUILD_FUZZERS "Build the libFuzzer targets of tests/fuzz (clang, KIJI_SANITIZE=address,undefined)" OFF)

if(KIJI_BUILD_FUZZERS)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "KIJI_BUILD_FUZZERS needs clang (libFuzzer): configure with -DCMAKE_CXX_COMPILER=clang++-14 "
                        "-DCMAKE_C_COMPILER=clang-14, or run scripts/fuzz.sh, which does")
  endif()
  if(NOT KIJI_SANITIZE MATCHES "address")
    message(FATAL_ERROR "KIJI_BUILD_FUZZERS needs -DKIJI_SANITIZE=address,undefined: a fuzzer finds what the "
                        "sanitizers report")
  endif()
endif()

if(KIJI_SANITIZE)
  if(NOT KIJI_SANITIZE MATCHES "^(address,undefined|address|undefined|thread)$")
    message(FATAL_ERROR "KIJI_SANITIZE=${KIJI_SANITIZE}: use address,undefined or thread")
  endif()
  set(kiji_sanitize_flags -fsanitize=${KIJI_SANITIZE} -fno-sanitize-recover=all -fno-omit-frame-pointer)
  add_compile_options(${kiji_sanitize_flags} -gline-tables-only)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    # UBSan's checks make Eigen's small functions too large for clang's inliner: every 3-vector sum
    # became a call (to the program's copy, through the PLT), and the solver's tests ran 5.6 times
    # slower under ASan + UBSan than with them inlined, which keeps every check.
    add_compile_definitions("EIGEN_STRONG_INLINE=inline __attribute__((always_inline))")
  endif()
  add_link_options(${kiji_sanitize_flags})
  if(CMAKE_CXX_COMPILER_ID STREQUAL "Clang" AND NOT KIJI_SANITIZE STREQUAL "thread")
    add_link_options(-shared-libsan)
    # The shared runtime lives in clang's own folder, which the loader does not search.
    execute_process(COMMAND ${CMAKE_CXX_COMPILER} -print-runtime-dir OUTPUT_VARIABLE kiji_sanitizer_runtime_dir
                    OUTPUT_STRIP_TRAILING_WHITESPACE)
    add_link_options(-Wl,-rpath,${kiji_sanitizer_runtime_dir})
    set(KIJI_SANITIZER_RUNTIME_DIR ${kiji_sanitizer_runtime_dir} CACHE INTERNAL "")
  endif()
  if(KIJI_BUILD_FUZZERS)
    # Coverage for libFuzzer in everything (only the fuzz targets link libFuzzer itself): the edge
    # counters, without -fsanitize=fuzzer-no-link's tracing of every comparison, which made the
    # test suite, run from the same build, several times slower. libFuzzer still learns the bytes
    # a parser compares through the sanitizer's memcmp and strcmp hooks.
    add_compile_options(-fsanitize-coverage=inline-8bit-counters,pc-table)
  endif()
endif()
