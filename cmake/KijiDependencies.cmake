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
