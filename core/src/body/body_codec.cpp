// The binary form of a body (kiji/codec.h): its geometry, name and import report.
#include "kiji/codec.h"

#include "base/archive.h"

namespace kiji {

using detail::Field;

namespace {

// More Loop subdivisions than any import makes (each one quadruples the triangles).
constexpr std::uint32_t kMaxBodySmoothing = 16;

// The body's fields, in the order they are in the binary form: encode_body and decode_body are
// these and nothing else.
template <class A>
void fields(A& a, Field<A, std::string>& name, Field<A, BodyImportReport>& rep, Field<A, std::vector<Vec3>>& vertices,
            Field<A, std::vector<std::array<int, 3>>>& triangles, const DecodeLimits& limits) {
  a.version(kOperationFormatVersion, "body");
  a.str(name, limits.max_string, "the body's name");
  a.str(rep.format, limits.max_string, "the body's format");
  a.str(rep.up_source, limits.max_string, "the body's up source");
  a.str(rep.scale_source, limits.max_string, "the body's scale source");
  a.enumeration(rep.up, Axis::NegZ, "unknown up axis");
  a.finite(rep.scale, "the body's scale");
  a.u64(rep.meshes_merged);
  a.u64(rep.vertices_before_weld);
  a.list(vertices, limits.max_vertices, 24, "the number of body vertices", [&](auto& v) { a.vec3(v, "a body vertex"); });
  a.list(triangles, limits.max_faces, 12, "the number of body triangles", [&](auto& t) {
    for (auto& corner : t) a.index(corner, vertices.size(), "a body triangle uses a vertex that does not exist");
  });
  // The rounding of a low-poly body, which the solver's collision reads (the rounded body's points):
  // a body decoded without it would drape otherwise than the one encoded. Written only for a rounded
  // body, so that any other body's form is as it was; bodies written before this part end here.
  if constexpr (A::reading) {
    if (a.more()) {
      std::uint32_t rounds = 0;
      a.u32(rounds);
      a.require(rounds >= 1 && rounds <= kMaxBodySmoothing, "the body's rounding is not 1 to 16 subdivisions");
      rep.smoothing = static_cast<int>(rounds);
    }
  } else if (rep.smoothing > 0) {
    a.u32(static_cast<std::uint32_t>(rep.smoothing));
  }
  a.end(" after the body");
}

}  // namespace

std::string encode_body(const Body& body) {
  detail::WriteArchive a;
  fields(a, body.name(), body.report(), body.vertices(), body.triangles(), DecodeLimits{});
  return a.take();
}

Body decode_body(std::string_view bytes, const DecodeLimits& limits) {
  detail::ReadArchive a(bytes, "body data");
  std::string name;
  BodyImportReport rep;
  std::vector<Vec3> vertices;
  std::vector<std::array<int, 3>> triangles;
  fields(a, name, rep, vertices, triangles, limits);
  return Body::from_triangles(std::move(vertices), std::move(triangles), std::move(name), std::move(rep));
}

}  // namespace kiji
