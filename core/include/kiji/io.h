// Garment files: glTF binary (.glb, with uv and the painted texture) and OBJ (+MTL, +PNG).
#pragma once

#include "kiji/garment.h"
#include "kiji/import_limits.h"

#include <string>

namespace kiji {

// Writes the garment; the format follows the extension (.glb or .obj). A garment with a texture
// embeds it in the .glb, or writes NAME.png beside the .obj (referenced from NAME.mtl). Throws
// InputError for an unknown extension or a path that cannot be written.
void export_garment(const Garment& garment, const std::string& path);

// Reads a garment back (.glb, .gltf or .obj, through assimp): corners that share a position are
// welded into one vertex, uv is kept per corner, rest lengths are the lengths in the file. Throws
// InputError for a missing, unreadable or empty file, and for one on which the reading process (a
// child process, under `limits`) crashed or passed its limits; this process is unharmed.
Garment import_garment(const std::string& path, const Material& material = {}, const ImportLimits& limits = {});

}  // namespace kiji
