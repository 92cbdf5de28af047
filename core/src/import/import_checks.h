// Checks made on a model file around assimp's reading of it, for what assimp (5.2) would crash on,
// hang on or leak on; garment and body import share them. Private to libkiji.
#pragma once

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

namespace Assimp {
class Importer;
}

namespace kiji::detail {

// Readies an importer for `path`, before importer.ReadFile(path, 0). Throws InputError, starting
// with `what` ("cannot import garment 'x.glb'"), for a file assimp (5.2) would crash on, hang on or
// leak on: an OBJ face, line or point naming a vertex, texture coordinate or normal the file lacks
// (assimp leaks the meshes it built when it finds one); a glTF (.gltf, or binary by its magic) whose
// JSON is not JSON, whose image names a MIME type glTF does not allow (assimp reads freed memory on
// one), whose mesh primitive has no POSITION or names an accessor that is missing or of a type or
// component type glTF does not define (assimp dereferences a null array), or a glb chunk longer than
// the file (assimp allocates and fills it first); a Collada file (.dae, or by its first bytes) whose
// <p>, <h>, <v> or <vcount> list holds a character other than digits, signs and spaces (assimp
// appends zeros until memory runs out); a PLY whose header never ends (assimp looks for its end for ever),
// or that assimp's PLY reader, followed step by step, would allocate past or read past (below); an OFF file
// whose header declares more or fewer lines than it has, or whose face has 0 or over 9 corners or
// names a vertex it lacks, or whose line is over 4 KiB (assimp allocates all the header declares
// first, reads past its arrays after such faces, and copies a line into a 4 KiB buffer); a text FBX
// whose connections make a model its own ancestor (assimp recurses until the stack overflows); and a
// file whose extension several importers share (.glb, .gltf, .xml) and none of them recognises,
// where assimp would try every format on it. OpenGEX is taken out of the importer (assimp's OpenDDL
// parser reads past the end of a broken file, and a file of an unknown extension may be tried as
// OpenGEX). Any other file is left to assimp.
void prepare_importer(Assimp::Importer& importer, const std::string& path, const std::string& what);

// Checks a glTF document (its JSON text; `bin` a glb's binary chunk; `folder` where its files lie)
// against what assimp 5.2's glTF 2 importer reads safely, and throws InputError, starting with
// `what`, for anything else: see check_gltf.cpp.
void check_gltf_document(const std::string& text, const std::string& what, const std::optional<std::string>& bin,
                         const std::filesystem::path& folder);

// Walks a binary FBX file as assimp 5.2's tokenizer walks it, and throws InputError, starting with
// `what`, for what its reader does not survive: see check_fbx.cpp.
void check_fbx_binary(const std::string& bytes, const std::string& what);

// Follows assimp 5.2's PLY reader over a PLY file's bytes and throws InputError, starting with
// `what`, before it would allocate what the file cannot hold (an element count or a list length
// past the data), read past its own buffer, or run out of data.
void check_ply_as_assimp_reads(const std::string& bytes, const std::string& what);

// The checks of each format, made by check_before_assimp (import_checks.cpp) on a file assimp may
// read as that format; those named check_ throw InputError, starting with `what`.

// `text` in lower case (ASCII), as assimp compares names and magic words.
std::string lowercase(std::string text);
// The extension of `path` in lower case, with its dot (".obj"), as assimp picks an importer by it.
std::string lower_extension(const std::string& path);

// check_obj.cpp: an OBJ's lines, split as assimp splits them, refused where a face names what the file lacks.
void check_obj_indices(const std::string& path, const std::string& what);
// check_obj.cpp: what in a material file assimp's MTL reader would crash on, or "" if nothing.
std::string mtl_problem(const std::string& bytes);

// check_stl.cpp: where `text` holds an integer of 20 digits or more, which assimp's number reader cannot pass.
std::optional<std::size_t> long_integer(std::string_view text);
// check_stl.cpp: an STL file's bytes, refused for a UTF-32 mark or an ASCII integer assimp cannot read past.
void check_stl(const std::string& bytes, const std::string& what);
// check_stl.cpp: whether assimp takes the file at `path` for STL by its first 200 bytes.
bool stl_magic(const std::string& path);
// check_stl.cpp: whether assimp takes a file starting with `head` for OFF.
bool off_magic(std::string_view head);
// check_stl.cpp: an OFF file's header and faces, read as assimp's OFF reader reads them.
void check_off(std::string text, const std::string& what);

// check_fbx.cpp: a text FBX's connections, refused where a model is its own ancestor or has two parents.
void check_fbx_text_connections(const std::string& path, const std::string& what);

// check_ply.cpp: whether assimp takes a file starting with `head` for PLY ("ply" ending a line near its start).
bool ply_magic(std::string_view head);
// check_ply.cpp: a PLY header's lines (up to `header_end`; its data from `data_start`) as the format defines them.
void check_ply_header(const std::string& bytes, std::size_t header_end, std::size_t data_start,
                      const std::string& what);

// check_collada.cpp: whether assimp takes the file at `path` for Collada by its first 200 bytes.
bool collada_magic(const std::string& path);
// check_collada.cpp: a Collada document's text, refused for what assimp would read without end or crash on.
void check_collada(std::string text, const std::string& what);
// check_collada.cpp: every Collada document in a zip (.zae), checked as check_collada checks a .dae.
void check_zipped_collada(const std::string& path, const std::string& what);

// After importer.ReadFile(path, 0) gave a scene: refuses a face of no corners or one naming a vertex
// its mesh lacks, sets each mesh's primitive types from its faces (an importer can claim polygons it
// did not keep, and assimp's triangulation then aborts the process), and applies `post_processing`.
// Throws InputError starting with `what`.
void post_process(Assimp::Importer& importer, unsigned post_processing, const std::string& what);

}  // namespace kiji::detail
