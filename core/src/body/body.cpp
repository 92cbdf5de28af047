#include "kiji/body.h"

#include "kiji/error.h"

#include <atomic>
#include <sstream>

namespace kiji {

Axis parse_axis(const std::string& name) {
  if (name == "x" || name == "+x") return Axis::PosX;
  if (name == "-x") return Axis::NegX;
  if (name == "y" || name == "+y") return Axis::PosY;
  if (name == "-y") return Axis::NegY;
  if (name == "z" || name == "+z") return Axis::PosZ;
  if (name == "-z") return Axis::NegZ;
  throw InputError("unknown axis '" + name + "': use one of x, y, z, -x, -y, -z");
}

std::string axis_name(Axis axis) {
  switch (axis) {
    case Axis::PosX: return "+x";
    case Axis::NegX: return "-x";
    case Axis::PosY: return "+y";
    case Axis::NegY: return "-y";
    case Axis::PosZ: return "+z";
    case Axis::NegZ: return "-z";
  }
  return "?";
}

Body Body::from_triangles(std::vector<Vec3> vertices, std::vector<std::array<int, 3>> triangles,
                          std::string name, BodyImportReport report) {
  if (triangles.empty())
    throw InputError("body '" + name + "' has no triangles: a body needs a surface to drape on");
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    if (!all_finite(vertices[i])) {
      std::ostringstream msg;
      msg << "body '" << name << "' has a non-finite coordinate at vertex " << i
          << ": repair the mesh or export it again";
      throw InputError(msg.str());
    }
  }
  const int n = static_cast<int>(vertices.size());
  for (std::size_t t = 0; t < triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      if (triangles[t][k] < 0 || triangles[t][k] >= n)
        throw InputError("body '" + name + "' triangle " + std::to_string(t) +
                         " refers to a vertex that does not exist");
  Body b;
  for (const auto& v : vertices) b.bounds_.extend(v);
  // Bodies are in metres; one kilometres across is a file in other units or a damaged one, and
  // the distance field (sim/collide) could not make cells fine enough to hold cloth on it.
  if (const double across = b.bounds_.sizes().maxCoeff(); !(across <= kLargestBody)) {
    std::ostringstream msg;
    msg << "body '" << name << "' is " << across << " m across, more than " << kLargestBody
        << " m: its coordinates are read as metres (a figure is about 1.7 m); give its height or scale when importing it";
    throw InputError(msg.str());
  }
  b.name_ = std::move(name);
  b.vertices_ = std::move(vertices);
  b.triangles_ = std::move(triangles);
  b.report_ = std::move(report);
  static std::atomic<std::uint64_t> last_id{0};
  b.geometry_id_ = ++last_id;
  return b;
}

Vec3 Body::triangle_normal(std::size_t t) const {
  const auto& tri = triangles_[t];
  const Vec3 n = (vertices_[tri[1]] - vertices_[tri[0]]).cross(vertices_[tri[2]] - vertices_[tri[0]]);
  const double len = n.norm();
  return len > 0 ? Vec3(n / len) : Vec3(0, 1, 0);
}

}  // namespace kiji
