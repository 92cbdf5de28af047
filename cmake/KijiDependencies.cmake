# Finds Kiji's dependencies, each as an imported target.
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(CGAL REQUIRED)
find_package(assimp REQUIRED)
find_package(PNG REQUIRED)
find_package(ZLIB REQUIRED)
find_package(Threads REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(PkgConfig REQUIRED)
# Debian's BulletConfig.cmake has relative paths and no targets: use pkg-config, double precision.
pkg_check_modules(BULLET REQUIRED IMPORTED_TARGET bullet-float64)

# LCM (session files and peer messages): PyPI's lcm wheel, which has the CMake config, lcm-gen and the
# Python module (Debian's 1.3.1 has none of them). scripts/setup.sh installs it in .venv and passes
# lcm_DIR; otherwise it is looked for through the Python interpreter CMake finds.
if(NOT lcm_DIR)
  find_package(Python 3.9 QUIET COMPONENTS Interpreter)
  if(Python_EXECUTABLE)
    execute_process(COMMAND ${Python_EXECUTABLE} -c
      "import lcm, os; print(os.path.join(os.path.dirname(os.path.dirname(lcm.__file__)), 'lib', 'lcm', 'cmake'))"
      OUTPUT_VARIABLE _kiji_lcm_dir OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
    if(_kiji_lcm_dir AND EXISTS ${_kiji_lcm_dir}/lcmConfig.cmake)
      set(lcm_DIR ${_kiji_lcm_dir} CACHE PATH "lcm's CMake config folder")
    endif()
  endif()
endif()
pkg_check_modules(GLIB REQUIRED IMPORTED_TARGET glib-2.0)
if(NOT TARGET GLib2::glib)
  add_library(GLib2::glib INTERFACE IMPORTED)
  set_target_properties(GLib2::glib PROPERTIES INTERFACE_LINK_LIBRARIES PkgConfig::GLIB)
endif()
find_package(lcm 1.5 REQUIRED CONFIG)
# libsodium: the peers' message authentication (HMAC-SHA-512-256 with the session's key).
pkg_check_modules(SODIUM REQUIRED IMPORTED_TARGET libsodium)
# minizip (assimp's own zip reader): zipped Collada bodies are checked before assimp reads them.
pkg_check_modules(MINIZIP REQUIRED IMPORTED_TARGET minizip)
