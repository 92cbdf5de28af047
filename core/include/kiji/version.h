// Kiji's version, and the ABI tag that plugins are checked against at load time.
#pragma once

#include <CGAL/version_macros.h>
#include <Eigen/Core>

#include <string>

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
#define KIJI_STDLIB_TAG "libc++" KIJI_STR(_LIBCPP_ABI_VERSION)
#else
#define KIJI_STDLIB_TAG "stdlib"
#endif

// The standard library's debug mode changes the layout of every container.
#if defined(_GLIBCXX_DEBUG)
#define KIJI_STL_DEBUG_TAG "1"
#else
#define KIJI_STL_DEBUG_TAG "0"
#endif

// What a plugin's binary layout depends on, as name=value fields: Kiji's version, the compiler and
// standard library, CGAL, Eigen, the scalar type, and what decides the layout of Eigen members
// (the alignment of fixed-size objects and of heap blocks, which vectorisation flags such as -mavx
// raise from 16 to 32 bytes, the index type and the default storage order). KIJI_TOOL_PLUGIN adds
// a `layout` field: the sizes and alignments of the types a tool receives, as the plugin's own
// compiler laid them out (see kiji/tool.h). A plugin whose tag differs from the host's is refused.
#define KIJI_ABI_TAG                                                                               \
  "kiji=" KIJI_STR(KIJI_VERSION_MAJOR) "." KIJI_STR(KIJI_VERSION_MINOR) ";compiler=" KIJI_COMPILER_TAG \
  ";stdlib=" KIJI_STDLIB_TAG ";stl_debug=" KIJI_STL_DEBUG_TAG ";cgal=" CGAL_VERSION_STR                \
  ";eigen=" KIJI_STR(EIGEN_WORLD_VERSION) "." KIJI_STR(EIGEN_MAJOR_VERSION) "." KIJI_STR(            \
      EIGEN_MINOR_VERSION) ";eigen_align=" KIJI_STR(EIGEN_MAX_STATIC_ALIGN_BYTES) "/" KIJI_STR(     \
      EIGEN_MAX_ALIGN_BYTES) ";eigen_index=" KIJI_STR(EIGEN_DEFAULT_DENSE_INDEX_TYPE)               \
  ";eigen_order=" KIJI_STR(EIGEN_DEFAULT_MATRIX_STORAGE_ORDER_OPTION) ";scalar=double"

namespace kiji {

const char* version();
// The ABI tag libkiji was built with: KIJI_ABI_TAG and the layout field.
const char* abi_tag();

// What differs between a plugin's ABI tag and the host's, field by field, each with what it means
// and what to do ("" when they are the same).
std::string abi_difference(const std::string& plugin_tag, const std::string& host_tag);

}  // namespace kiji
