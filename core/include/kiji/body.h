// A body (an avatar) that garments are draped on: imported with assimp, in metres, +Y up.
#pragma once

#include "kiji/import_limits.h"
#include "kiji/types.h"

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace kiji {

enum class Axis { PosX, NegX, PosY, NegY, PosZ, NegZ };
// "x", "-x", "+y", ... ; throws InputError listing the accepted names.
Axis parse_axis(const std::string& name);
std::string axis_name(Axis axis);

struct BodyImportOptions {
  // The file's up axis; when unset, the file's metadata (or +Y if it says nothing).
  std::optional<Axis> up;
  // The way the body faces, as an axis of the file (not its up axis). The body is turned about its
  // up axis to face +Z: towards the camera of a picture, and the side a drape calls the front.
  std::optional<Axis> front;
  // When `front` is unset: find it from what the file says (FBX's front axis; +Z for glTF, whose
  // specification says so), else from the way the body's feet point; else leave the body as the
  // file has it. Off by default, so that a file is read as it is; `kiji drape` and Python's
  // Body.load turn it on.
  bool find_front = false;
  // Metres per file unit; when unset, the file's metadata (or 1 if it says nothing).
  std::optional<double> scale;
  // Scale the body uniformly to this height in metres (overrides `scale`).
  std::optional<double> height;
  // Round a low-poly body: Loop subdivision until its median edge is at most 1 % of its height (a
  // game character's 7 cm triangles become 1 cm ones), for bodies of 100 triangles or more (a model,
  // not a test solid). Cloth falls on its pointed crown or shoulder as on a rounded one instead of
  // hanging on the point. Off by default; `kiji drape` and Python's Body.load turn it on.
  bool smooth = false;
  // Put the feet on y = 0 and centre the body over the origin in x and z.
  bool recenter = true;
  // The memory and time the reading process may take (assimp reads the file in a child process).
  ImportLimits limits;
};

// How the import read the file, for the user to check.
struct BodyImportReport {
  std::string format;            // assimp's name for the importer
  std::string up_source;         // "file metadata", "option", "default (+Y)"
  std::string scale_source;      // "file metadata", "option", "height option", "default (metres)"
  std::string front_source;      // "option", "file metadata", "glTF convention", "feet", "as the file has it"
  Axis up = Axis::PosY;
  Axis front = Axis::PosZ;       // the file's axis the body faced
  double scale = 1.0;            // metres per file unit applied
  int smoothing = 0;             // Loop subdivisions applied (0: none)
  std::size_t meshes_merged = 0;
  std::size_t vertices_before_weld = 0;
};

class Body {
 public:
  // Imports every mesh of the file, welds vertices, normalises to metres and +Y up.
  // Throws InputError for a missing or unreadable file, a format assimp cannot read, a file with no
  // triangles, or non-finite coordinates, and for a file on which the reading process crashed or
  // passed options.limits; the message names the file and the problem. This process is unharmed.
  static Body load(const std::string& path, const BodyImportOptions& options = {});
  static constexpr double kLargestBody = 1000.0;  // metres
  // A body from triangles already in metres, +Y up (checked like a file, and at most
  // kLargestBody across); `report` says where they came from.
  static Body from_triangles(std::vector<Vec3> vertices, std::vector<std::array<int, 3>> triangles,
                             std::string name = "body", BodyImportReport report = {});
  // The default body: human.zae from Debian's assimp-testmodels.
  static std::string default_path();

  const std::string& name() const { return name_; }
  const std::vector<Vec3>& vertices() const { return vertices_; }
  const std::vector<std::array<int, 3>>& triangles() const { return triangles_; }
  const BodyImportReport& report() const { return report_; }
  const Box3& bounds() const { return bounds_; }
  double height() const { return bounds().sizes().y(); }
  // Outward unit normal of triangle t.
  Vec3 triangle_normal(std::size_t t) const;
  // A number naming this body's geometry: a copy of a body has its number, any other body its own.
  // A body does not change, so what was drawn or built of one body holds for every copy of it.
  std::uint64_t geometry_id() const { return geometry_id_; }

 private:
  std::string name_;
  std::vector<Vec3> vertices_;
  std::vector<std::array<int, 3>> triangles_;
  BodyImportReport report_;
  Box3 bounds_;  // kept: a body does not change, and a point's test against it asks for them
  std::uint64_t geometry_id_ = 0;  // 0: the empty body
};

}  // namespace kiji
