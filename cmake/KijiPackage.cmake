# Installs the CMake package, so that a tool built outside this tree needs only
#   find_package(Kiji REQUIRED)
#   kiji_add_tool(mytool SOURCES mytool.cpp)
include(CMakePackageConfigHelpers)
set(KIJI_CMAKE_INSTALL_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/Kiji)

install(EXPORT KijiTargets NAMESPACE Kiji:: DESTINATION ${KIJI_CMAKE_INSTALL_DIR})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/KijiConfig.cmake.in
  ${PROJECT_BINARY_DIR}/KijiConfig.cmake
  INSTALL_DESTINATION ${KIJI_CMAKE_INSTALL_DIR})
# The ABI tag holds major.minor, so a plugin needs the same minor version of Kiji.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/KijiConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES
  ${PROJECT_BINARY_DIR}/KijiConfig.cmake
  ${PROJECT_BINARY_DIR}/KijiConfigVersion.cmake
  ${CMAKE_CURRENT_LIST_DIR}/KijiTool.cmake
  DESTINATION ${KIJI_CMAKE_INSTALL_DIR})
# Where installed tools go (and where libkiji looks for them), even while there are none.
install(DIRECTORY DESTINATION ${CMAKE_INSTALL_LIBDIR}/kiji/plugins)
