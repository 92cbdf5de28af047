// The binary form of a garment (kiji/codec.h): its mesh with every property, material, texture,
// tacks and sleep record, exactly.
#include "kiji/codec.h"

#include "base/byte_io.h"
#include "cloth/garment_soup.h"
#include "cloth/sleep_record_io.h"
#include "kiji/error.h"

#include <algorithm>

namespace kiji {

using detail::ByteReader;
using detail::ByteWriter;

namespace {

void check_version(ByteReader& r, const char* what) { detail::check_format_version(r, kOperationFormatVersion, what); }

void write_material(ByteWriter& w, const Material& m) {
  w.str(m.name);
  for (double v : {m.density, m.stretch_stiffness, m.bending_stiffness, m.damping, m.friction, m.thickness, m.tear_ratio})
    w.f64(v);
}

Material read_material(ByteReader& r, const DecodeLimits& limits) {
  Material m;
  m.name = r.str(limits.max_string, "the material's name");
  for (double* v : {&m.density, &m.stretch_stiffness, &m.bending_stiffness, &m.damping, &m.friction, &m.thickness,
                    &m.tear_ratio})
    *v = r.f64();
  try {
    m.validate();
  } catch (const InputError& e) {
    r.fail(std::string("the material is out of range: ") + e.what());
  }
  return m;
}

}  // namespace

std::string encode_garment(const Garment& g) {
  const detail::Soup s = detail::to_soup(g);
  ByteWriter w;
  w.u16(kOperationFormatVersion);
  w.str(g.name);
  write_material(w, g.material());
  w.vec3(g.color);
  w.f64(g.pattern_scale());
  const Texture& t = g.texture();
  w.u32(static_cast<std::uint32_t>(t.width));
  w.u32(static_cast<std::uint32_t>(t.height));
  w.raw(t.rgba.data(), t.rgba.size());
  w.u32(static_cast<std::uint32_t>(s.vertices.size()));
  for (const detail::VertexData& v : s.vertices) {
    w.u8(v.alive);
    w.vec3(v.position);
    w.vec3(v.velocity);
    w.f64(v.inverse_mass);
  }
  w.u32(static_cast<std::uint32_t>(s.faces.size()));
  for (std::size_t f = 0; f < s.faces.size(); ++f) {
    for (int k = 0; k < 3; ++k) w.u32(s.faces[f][k]);
    for (int k = 0; k < 3; ++k) w.vec2(s.uvs[f][k]);
    w.i32(s.panels[f]);
  }
  // Edges in key order, so that equal garments give equal bytes.
  std::vector<std::pair<std::uint64_t, detail::EdgeData>> edges(s.edges.begin(), s.edges.end());
  std::sort(edges.begin(), edges.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  w.u32(static_cast<std::uint32_t>(edges.size()));
  for (const auto& [key, e] : edges) {
    w.u64(key);
    w.f64(e.rest);
    w.f64(e.threshold);
  }
  w.u32(static_cast<std::uint32_t>(s.tacks.size()));
  for (const auto& [a, b] : s.tacks) {
    w.u32(a);
    w.u32(b);
  }
  // Where it sleeps (garments written before this part end here, and wake whole).
  const detail::SleepingVertices asleep = detail::sleeping_vertices(g);
  w.u32(static_cast<std::uint32_t>(asleep.vertices.size()));
  if (!asleep.vertices.empty()) {
    for (double d : asleep.physics) w.f64(d);
    for (std::uint32_t v : asleep.vertices) w.u32(v);
  }
  return w.take();
}

Garment decode_garment(std::string_view bytes, const DecodeLimits& limits) {
  ByteReader r(bytes, "garment data");
  check_version(r, "garment");
  Garment g;
  g.name = r.str(limits.max_string, "the garment's name");
  g.set_material(read_material(r, limits));
  g.color = r.vec3("the colour");
  const double scale = r.finite("the pattern scale");
  if (!(scale > 0)) r.fail("the pattern scale is not positive");
  g.set_pattern_scale(scale);
  Texture& t = g.texture();
  const std::uint32_t tw = r.u32(), th = r.u32();
  if (tw > limits.max_texture_side || th > limits.max_texture_side || (tw == 0) != (th == 0))
    r.fail("the texture is " + std::to_string(tw) + "x" + std::to_string(th) + "; at most " +
           std::to_string(limits.max_texture_side) + " texels a side");
  const std::string_view texels = r.take(std::size_t(tw) * th * 4);
  t.width = static_cast<int>(tw);
  t.height = static_cast<int>(th);
  t.rgba.assign(texels.begin(), texels.end());

  detail::Soup s;
  const std::size_t nv = r.count(limits.max_vertices, 57, "the number of vertices");
  s.vertices.resize(nv);
  for (detail::VertexData& v : s.vertices) {
    v.alive = r.boolean("a vertex's alive flag");
    v.position = r.vec3("a vertex position");
    v.velocity = r.vec3("a vertex velocity");
    v.inverse_mass = r.finite("a vertex's inverse mass");
    if (v.inverse_mass < 0) r.fail("a vertex has a negative inverse mass");
  }
  const std::size_t nf = r.count(limits.max_faces, 64, "the number of faces");
  s.faces.resize(nf);
  s.uvs.resize(nf);
  s.panels.resize(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t c = r.u32();
      if (c >= nv || !s.vertices[c].alive) r.fail("face " + std::to_string(f) + " uses a vertex that does not exist");
      s.faces[f][k] = c;
    }
    for (int k = 0; k < 3; ++k) s.uvs[f][k] = r.vec2("a uv");
    s.panels[f] = r.i32();
  }
  const std::size_t ne = r.count(3 * limits.max_faces + 3, 24, "the number of edges");
  s.edges.reserve(ne);
  for (std::size_t i = 0; i < ne; ++i) {
    const std::uint64_t key = r.u64();
    detail::EdgeData e;
    e.rest = r.finite("an edge's rest length");
    e.threshold = r.finite("an edge's tear threshold");
    if ((key >> 32) >= nv || (key & 0xffffffffu) >= nv) r.fail("an edge names a vertex that does not exist");
    if (!(e.rest > 0) || !(e.threshold > 0)) r.fail("an edge's rest length or tear threshold is not positive");
    s.edges[key] = e;
  }
  const std::size_t nt = r.count(limits.max_vertices, 8, "the number of tacks");
  for (std::size_t i = 0; i < nt; ++i) {
    const std::uint32_t a = r.u32(), b = r.u32();
    if (a >= nv || b >= nv) r.fail("a tack names a vertex that does not exist");
    s.tacks.emplace_back(a, b);
  }
  detail::SleepingVertices asleep;
  if (!r.at_end()) {
    const std::size_t count = r.count(limits.max_vertices, 4, "the number of sleeping vertices");
    if (count > 0) {
      for (double& d : asleep.physics) d = r.finite("the sleeping cloth's physics");
      asleep.vertices.resize(count);
      for (std::size_t k = 0; k < count; ++k) {
        const std::uint32_t v = r.u32();
        if (v >= nv || !s.vertices[v].alive) r.fail("a sleeping vertex does not exist");
        if (k > 0 && v <= asleep.vertices[k - 1]) r.fail("the sleeping vertices are not in ascending order");
        asleep.vertices[k] = v;
      }
    }
  }
  if (!r.at_end()) r.fail(std::to_string(r.left()) + " bytes are left over after the garment");
  if (nf == 0) throw InputError("garment data has no faces: a garment needs at least one triangle");
  try {
    detail::check_manifold(s, "garment data");
    detail::commit(g, s, "garment data");
  } catch (const TopologyError& e) {
    throw InputError(std::string("garment data does not describe a valid mesh: ") + e.what());
  }
  // The masses as they were, not as commit() recomputes them, so that the state is kept exactly.
  auto& m = g.mesh();
  auto inverse_mass = m.property_map<Vertex, double>("v:inverse_mass").first;
  for (Vertex v : m.vertices()) inverse_mass[v] = s.vertices[v.idx()].inverse_mass;
  detail::restore_sleep_record(g, asleep);
  return g;
}

}  // namespace kiji
