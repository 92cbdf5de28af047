// Kiji's version, and the ABI tag that plugins are checked against at load time.
#pragma once

#include <CGAL/version_macros.h>
#include <Eigen/Core>

#define KIJI_VERSION_MAJOR 0
#define KIJI_VERSION_MINOR 2

#define KIJI_STR2(x) #x
#define KIJI_STR(x) KIJI_STR2(x)

#if defined(__clang__)
#define KIJI_COMPILER_TAG "clang" KIJI_STR(__clang_major__)
#elif defined(__GNUC__)
#define KIJI_COMPILER_TAG "gcc" KIJI_STR(__GNUC__)
#else
#define KIJI_COMPILER_TAG "cc"
#endif

#if defined(_GLIBCXX_USE_CXX11_ABI)
#define KIJI_STDLIB_TAG "libstdc++" KIJI_STR(_GLIBCXX_USE_CXX11_ABI)
#elif defined(_LIBCPP_VERSION)
#define KIJI_STDLIB_TAG "libc++"
#else
#define KIJI_STDLIB_TAG "stdlib"
#endif

// Everything a plugin's binary layout depends on: Kiji's version, compiler, standard library, CGAL,
// Eigen and the scalar type. A plugin whose tag differs from the host's is refused, never loaded.
#define KIJI_ABI_TAG                                                                              \
  "kiji" KIJI_STR(KIJI_VERSION_MAJOR) "." KIJI_STR(KIJI_VERSION_MINOR) ";" KIJI_COMPILER_TAG ";" \
  KIJI_STDLIB_TAG ";cgal" CGAL_VERSION_STR ";eigen" KIJI_STR(EIGEN_WORLD_VERSION) "."     \
  KIJI_STR(EIGEN_MAJOR_VERSION) ";double"

namespace kiji {

const char* version();
// The ABI tag libkiji was built with.
const char* abi_tag();

}  // namespace kiji
