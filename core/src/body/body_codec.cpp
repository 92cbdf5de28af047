// The binary form of a body (kiji/codec.h): its geometry, name and import report.
#include "kiji/codec.h"

#include "base/byte_io.h"

namespace kiji {

using detail::ByteReader;
using detail::ByteWriter;

std::string encode_body(const Body& body) {
  ByteWriter w;
  w.u16(kOperationFormatVersion);
  w.str(body.name());
  const BodyImportReport& rep = body.report();
  w.str(rep.format);
  w.str(rep.up_source);
  w.str(rep.scale_source);
  w.u8(static_cast<std::uint8_t>(rep.up));
  w.f64(rep.scale);
  w.u64(rep.meshes_merged);
  w.u64(rep.vertices_before_weld);
  w.u32(static_cast<std::uint32_t>(body.vertices().size()));
  for (const Vec3& v : body.vertices()) w.vec3(v);
  w.u32(static_cast<std::uint32_t>(body.triangles().size()));
  for (const auto& t : body.triangles())
    for (int k = 0; k < 3; ++k) w.u32(static_cast<std::uint32_t>(t[k]));
  return w.take();
}

Body decode_body(std::string_view bytes, const DecodeLimits& limits) {
  ByteReader r(bytes, "body data");
  detail::check_format_version(r, kOperationFormatVersion, "body");
  std::string name = r.str(limits.max_string, "the body's name");
  BodyImportReport rep;
  rep.format = r.str(limits.max_string, "the body's format");
  rep.up_source = r.str(limits.max_string, "the body's up source");
  rep.scale_source = r.str(limits.max_string, "the body's scale source");
  const std::uint8_t up = r.u8();
  if (up > static_cast<std::uint8_t>(Axis::NegZ)) r.fail("unknown up axis");
  rep.up = static_cast<Axis>(up);
  rep.scale = r.finite("the body's scale");
  rep.meshes_merged = r.u64();
  rep.vertices_before_weld = r.u64();
  const std::size_t nv = r.count(limits.max_vertices, 24, "the number of body vertices");
  std::vector<Vec3> vertices(nv);
  for (Vec3& v : vertices) v = r.vec3("a body vertex");
  const std::size_t nt = r.count(limits.max_faces, 12, "the number of body triangles");
  std::vector<std::array<int, 3>> triangles(nt);
  for (auto& t : triangles)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t c = r.u32();
      if (c >= nv) r.fail("a body triangle uses a vertex that does not exist");
      t[k] = static_cast<int>(c);
    }
  if (!r.at_end()) r.fail(std::to_string(r.left()) + " bytes are left over after the body");
  return Body::from_triangles(std::move(vertices), std::move(triangles), std::move(name), std::move(rep));
}

}  // namespace kiji
