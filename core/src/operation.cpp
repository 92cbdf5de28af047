#include "kiji/operation.h"

#include "byte_io.h"
#include "garment_soup.h"
#include "overloaded.h"
#include "sleep_record_io.h"

#include <algorithm>

namespace kiji {

using detail::ByteReader;
using detail::ByteWriter;

namespace {

using detail::Overloaded;

// Kinds in the binary form; the numbers are the format's, never reused.
enum Kind : std::uint8_t {
  kToolInput = 1,
  kAddGarment = 2,
  kRemoveGarment = 3,
  kSetGarment = 4,
  kSetBody = 5,
  kSetSolverParams = 6,
  kSetFrameRate = 7,
  kSetSimulating = 8,
  kSetPickRadius = 9,
  kUndo = 10,
  kRedo = 11,
  kAdvance = 12,
  kCheckpoint = 13,
};

enum ValueTag : std::uint8_t { kBool = 0, kInt = 1, kFloat = 2, kString = 3, kColor = 4 };

void check_version(ByteReader& r, const char* what) {
  const std::uint16_t v = r.u16();
  if (v == 0 || v > kOperationFormatVersion)
    r.fail(std::string(what) + " format version " + std::to_string(v) + "; this Kiji reads versions 1 to " +
           std::to_string(kOperationFormatVersion) + ": use a newer Kiji");
}

void write_value(ByteWriter& w, const ParamValue& value) {
  std::visit(Overloaded{[&](bool b) { w.u8(kBool), w.u8(b); }, [&](long long i) { w.u8(kInt), w.i64(i); },
                        [&](double d) { w.u8(kFloat), w.f64(d); },
                        [&](const std::string& s) { w.u8(kString), w.str(s); },
                        [&](const Vec3& c) { w.u8(kColor), w.vec3(c); }},
             value);
}

ParamValue read_value(ByteReader& r, const DecodeLimits& limits) {
  switch (r.u8()) {
    case kBool: return r.boolean("a boolean parameter");
    case kInt: return static_cast<long long>(r.i64());
    case kFloat: return r.finite("a number parameter");
    case kString: return r.str(limits.max_string, "a text parameter");
    case kColor: return r.vec3("a colour parameter");
    default: r.fail("a parameter has an unknown type");
  }
}

void write_event(ByteWriter& w, const ToolEvent& e) {
  w.u8(static_cast<std::uint8_t>(e.phase));
  w.f64(e.time);
  w.vec3(e.position);
  w.f64(e.orientation.w());
  w.f64(e.orientation.x());
  w.f64(e.orientation.y());
  w.f64(e.orientation.z());
  w.u32(e.buttons);
  w.f64(e.pressure);
  w.vec3(e.ray);
}

ToolEvent read_event(ByteReader& r) {
  ToolEvent e;
  const std::uint8_t phase = r.u8();
  if (phase > static_cast<std::uint8_t>(Phase::Cancel)) r.fail("the event's phase is not begin, move, end or cancel");
  e.phase = static_cast<Phase>(phase);
  e.time = r.finite("the event's time");
  e.position = r.vec3("the event's position");
  const double qw = r.finite("the event's orientation"), qx = r.finite("the event's orientation"),
               qy = r.finite("the event's orientation"), qz = r.finite("the event's orientation");
  e.orientation = Eigen::Quaterniond(qw, qx, qy, qz);
  e.buttons = r.u32();
  e.pressure = r.finite("the event's pressure");
  e.ray = r.vec3("the event's ray");
  return e;
}

void write_params(ByteWriter& w, const SolverParams& p) {
  w.u8(static_cast<std::uint8_t>(p.model));
  w.vec3(p.gravity);
  w.i32(p.substeps);
  w.i32(p.iterations);
  w.u8(p.body_collision);
  w.u8(p.self_collision);
  w.f64(p.strain_limit);
  w.f64(p.spring_k);
  w.f64(p.spring_damping);
  w.f64(p.local_radius);
  w.vec3(p.local_center);
  w.f64(p.sleep_after);
  w.f64(p.sleep_distance);
}

SolverParams read_params(ByteReader& r) {
  SolverParams p;
  const std::uint8_t model = r.u8();
  if (model > static_cast<std::uint8_t>(SolverModel::MassSpring)) r.fail("unknown solver model");
  p.model = static_cast<SolverModel>(model);
  p.gravity = r.vec3("gravity");
  p.substeps = r.i32();
  p.iterations = r.i32();
  p.body_collision = r.boolean("body_collision");
  p.self_collision = r.boolean("self_collision");
  p.strain_limit = r.f64();
  p.spring_k = r.f64();
  p.spring_damping = r.f64();
  p.local_radius = r.f64();
  p.local_center = r.vec3("local_center");
  p.sleep_after = r.f64();
  p.sleep_distance = r.f64();
  try {
    p.validate();
  } catch (const InputError& e) {
    r.fail(std::string("the solver parameters are out of range: ") + e.what());
  }
  return p;
}

std::shared_ptr<const std::string> payload(ByteReader& r, const char* what) {
  return std::make_shared<const std::string>(r.bytes(r.left(), what));
}

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

const char* operation_kind(const OperationData& data) {
  return std::visit(Overloaded{[](const op::ToolInput&) { return "tool"; },
                               [](const op::AddGarment&) { return "add_garment"; },
                               [](const op::RemoveGarment&) { return "remove_garment"; },
                               [](const op::SetGarment&) { return "set_garment"; },
                               [](const op::SetBody&) { return "set_body"; },
                               [](const op::SetSolverParams&) { return "set_solver_params"; },
                               [](const op::SetFrameRate&) { return "set_frame_rate"; },
                               [](const op::SetSimulating&) { return "set_simulating"; },
                               [](const op::SetPickRadius&) { return "set_pick_radius"; },
                               [](const op::Undo&) { return "undo"; }, [](const op::Redo&) { return "redo"; },
                               [](const op::Advance&) { return "advance"; },
                               [](const op::Checkpoint&) { return "checkpoint"; }},
                    data);
}

bool changes_garments(const OperationData& data) {
  return std::holds_alternative<op::ToolInput>(data) || std::holds_alternative<op::AddGarment>(data) ||
         std::holds_alternative<op::RemoveGarment>(data) || std::holds_alternative<op::SetGarment>(data) ||
         std::holds_alternative<op::Checkpoint>(data);
}

std::string encode_operation(const Operation& op) {
  ByteWriter w;
  w.u16(kOperationFormatVersion);
  w.u64(op.step);
  w.u32(op.user);
  std::visit(Overloaded{[&](const op::ToolInput& t) {
                          w.u8(kToolInput);
                          w.str(t.tool);
                          w.u32(static_cast<std::uint32_t>(t.params.size()));
                          for (const auto& [name, value] : t.params) {
                            w.str(name);
                            write_value(w, value);
                          }
                          write_event(w, t.event);
                        },
                        [&](const op::AddGarment& a) {
                          w.u8(kAddGarment);
                          w.bytes(a.garment ? *a.garment : std::string());
                        },
                        [&](const op::RemoveGarment& a) {
                          w.u8(kRemoveGarment);
                          w.u32(a.index);
                        },
                        [&](const op::SetGarment& a) {
                          w.u8(kSetGarment);
                          w.u32(a.index);
                          w.bytes(a.garment ? *a.garment : std::string());
                        },
                        [&](const op::SetBody& a) {
                          w.u8(kSetBody);
                          w.u8(a.body != nullptr);
                          if (a.body) w.bytes(*a.body);
                        },
                        [&](const op::SetSolverParams& a) {
                          w.u8(kSetSolverParams);
                          write_params(w, a.params);
                        },
                        [&](const op::SetFrameRate& a) {
                          w.u8(kSetFrameRate);
                          w.f64(a.steps_per_second);
                        },
                        [&](const op::SetSimulating& a) {
                          w.u8(kSetSimulating);
                          w.u8(a.simulating);
                        },
                        [&](const op::SetPickRadius& a) {
                          w.u8(kSetPickRadius);
                          w.f64(a.radius);
                        },
                        [&](const op::Undo&) { w.u8(kUndo); }, [&](const op::Redo&) { w.u8(kRedo); },
                        [&](const op::Advance&) { w.u8(kAdvance); },
                        [&](const op::Checkpoint& a) {
                          w.u8(kCheckpoint);
                          w.u8(a.state != nullptr);
                          if (a.state) w.bytes(*a.state);
                        }},
             op.data);
  return w.take();
}

Operation decode_operation(std::string_view bytes, const DecodeLimits& limits) {
  ByteReader r(bytes, "operation");
  check_version(r, "operation");
  Operation op;
  op.step = r.u64();
  op.user = r.u32();
  switch (r.u8()) {
    case kToolInput: {
      op::ToolInput t;
      t.tool = r.str(limits.max_string, "the tool id");
      const std::size_t n = r.count(limits.max_params, 6, "the number of parameters");
      for (std::size_t i = 0; i < n; ++i) {
        std::string name = r.str(limits.max_string, "a parameter name");
        t.params[std::move(name)] = read_value(r, limits);
      }
      t.event = read_event(r);
      op.data = std::move(t);
      break;
    }
    case kAddGarment: op.data = op::AddGarment{payload(r, "the garment")}; break;
    case kRemoveGarment: op.data = op::RemoveGarment{r.u32()}; break;
    case kSetGarment: {
      const std::uint32_t index = r.u32();
      op.data = op::SetGarment{index, payload(r, "the garment")};
      break;
    }
    case kSetBody: {
      op::SetBody b;
      if (r.boolean("whether there is a body")) b.body = payload(r, "the body");
      op.data = std::move(b);
      break;
    }
    case kSetSolverParams: op.data = op::SetSolverParams{read_params(r)}; break;
    case kSetFrameRate: op.data = op::SetFrameRate{r.finite("the frame rate")}; break;
    case kSetSimulating: op.data = op::SetSimulating{r.boolean("simulating")}; break;
    case kSetPickRadius: op.data = op::SetPickRadius{r.finite("the pick radius")}; break;
    case kUndo: op.data = op::Undo{}; break;
    case kRedo: op.data = op::Redo{}; break;
    case kAdvance: op.data = op::Advance{}; break;
    case kCheckpoint: {
      op::Checkpoint cp;
      if (r.boolean("whether there is a state")) cp.state = payload(r, "the state");
      op.data = std::move(cp);
      break;
    }
    default: r.fail("unknown operation kind");
  }
  if (!r.at_end()) r.fail(std::to_string(r.left()) + " bytes are left over after the operation");
  return op;
}

// --- garments ---

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

// --- bodies ---

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
  check_version(r, "body");
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

std::uint64_t hash_bytes(std::string_view bytes, std::uint64_t seed) {
  std::uint64_t h = seed;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 0x100000001b3ull;
  }
  return h;
}

}  // namespace kiji
