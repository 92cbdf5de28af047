// Checks made on a model file before assimp reads it, for what assimp (5.2) would crash on, hang on
// or leak on; garment and body import share them. Private to libkiji.
#pragma once

#include <string>

namespace kiji::detail {

// Throws InputError, starting with `what` ("cannot import garment 'x.glb'"), for: an OBJ face, line
// or point naming a vertex, texture coordinate or normal the file lacks (assimp leaks the meshes it
// built when it finds one); a glTF (.gltf, or binary by its magic) whose JSON is not JSON or whose
// image names a MIME type glTF does not allow (assimp reads freed memory on one); a PLY whose header
// never ends (assimp looks for its end for ever). Any other file is left to assimp.
void check_before_assimp(const std::string& path, const std::string& what);

}  // namespace kiji::detail
