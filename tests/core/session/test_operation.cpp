// Operations and the binary forms of garments and bodies: what goes in comes out exactly, and bytes
// that are not a whole, valid operation are refused with a message, never read past their end.
#include "kiji/error.h"
#include "kiji/operation.h"
#include "kiji/pattern.h"
#include "kiji/topology.h"
#include "support/wire_samples.h"

#include <gtest/gtest.h>

#include <array>
#include <cstring>
#include <functional>
#include <random>
#include <set>

using namespace kiji;

namespace {

// A garment with everything a garment can hold: a hole left by a torn-out vertex, a cut, a pin,
// a tack, custom rest lengths and thresholds, a painted texture, a material of its own.
Garment rich_garment() {
  Garment g = make_rectangle(0.6, 0.4, 7, 5, Material::silk());
  g.name = "rich";
  g.color = Vec3(0.1, 0.5, 0.9);
  std::vector<Edge> around_corner;  // tearing them all out leaves vertex 0 a hole in the indices
  for (Halfedge h : CGAL::halfedges_around_target(g.mesh().halfedge(Vertex(0)), g.mesh()))
    around_corner.push_back(g.mesh().edge(h));
  remove_edges(g, around_corner);
  std::vector<Vertex> path = edge_path(g, Vertex(15), Vertex(19));
  cut_along(g, path);
  for (Vertex v : g.mesh().vertices()) {
    g.velocity(v) = Vec3(0.001 * v.idx(), -0.25, 1.0 / 3.0);
    if (v.idx() == 30) g.set_pinned(v, true);
  }
  Edge e = *g.mesh().edges().begin();
  g.set_rest_length(e, g.rest_length(e) * 1.1);
  g.set_tear_threshold(e, 0.123456789);
  g.tacks.emplace_back(Vertex(8), Vertex(27));
  g.texture() = Texture::filled(8, 4, 10, 20, 30, 255);
  g.texture().texel(3, 2)[0] = 200;
  g.set_pattern_scale(0.61);
  return g;
}

void expect_same(const Garment& a, const Garment& b) {
  ASSERT_EQ(a.vertex_capacity(), b.vertex_capacity());
  ASSERT_EQ(a.mesh().number_of_faces(), b.mesh().number_of_faces());
  ASSERT_EQ(a.mesh().number_of_edges(), b.mesh().number_of_edges());
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.color, b.color);
  EXPECT_EQ(a.material().name, b.material().name);
  EXPECT_EQ(a.material().stretch_stiffness, b.material().stretch_stiffness);
  EXPECT_EQ(a.pattern_scale(), b.pattern_scale());
  for (std::size_t i = 0; i < a.vertex_capacity(); ++i) {
    const Vertex v(static_cast<std::uint32_t>(i));
    ASSERT_EQ(a.mesh().is_removed(v), b.mesh().is_removed(v)) << "vertex " << i;
    if (a.mesh().is_removed(v)) continue;
    EXPECT_EQ(a.position(v), b.position(v));  // bit for bit
    EXPECT_EQ(a.velocity(v), b.velocity(v));
    EXPECT_EQ(a.inverse_mass(v), b.inverse_mass(v));
  }
  // The same faces by the same vertex indices, with the same uvs and panels.
  auto faces = [](const Garment& g) {
    std::vector<std::array<double, 10>> out;
    for (Face f : g.mesh().faces()) {
      std::array<double, 10> row{};
      int k = 0;
      for (Halfedge h : CGAL::halfedges_around_face(g.mesh().halfedge(f), g.mesh())) {
        row[k] = g.mesh().target(h).idx();
        row[3 + 2 * k] = g.uv(h).x();
        row[4 + 2 * k] = g.uv(h).y();
        ++k;
      }
      row[9] = g.panel(f);
      out.push_back(row);
    }
    return out;
  };
  EXPECT_EQ(faces(a), faces(b));
  auto edges = [](const Garment& g) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::pair<double, double>> out;
    for (Edge e : g.mesh().edges()) {
      const Halfedge h = g.mesh().halfedge(e);
      // std::minmax returns references: to named values, not to temporaries.
      const std::uint32_t a = g.mesh().source(h).idx(), b = g.mesh().target(h).idx();
      out[{std::min(a, b), std::max(a, b)}] = {g.rest_length(e), g.tear_threshold(e)};
    }
    return out;
  };
  EXPECT_EQ(edges(a), edges(b));
  EXPECT_EQ(a.tacks, b.tacks);
  EXPECT_EQ(a.texture().width, b.texture().width);
  EXPECT_EQ(a.texture().rgba, b.texture().rgba);
}

Body small_body() {
  return Body::from_triangles({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{{0, 2, 1}}, {{0, 1, 3}}, {{0, 3, 2}}, {{1, 2, 3}}},
                              "tetra");
}

std::vector<Operation> one_of_each() {
  std::vector<Operation> ops;
  op::ToolInput t;
  t.tool = "cut";
  t.params = {{"mode", std::string("stroke")}, {"depth", 0.25}, {"count", 3LL}, {"on", true},
              {"color", Vec3(0.1, 0.2, 0.3)}};
  t.event.phase = Phase::Begin;
  t.event.time = 1.0 / 3.0;
  t.event.position = Vec3(0.1, -0.2, 0.3);
  t.event.orientation = Eigen::Quaterniond(0.5, 0.5, -0.5, 0.5);
  t.event.buttons = 3;
  t.event.pressure = 0.7;
  t.event.ray = Vec3(0, 0, -1);
  ops.push_back({7, 2, t});
  ops.push_back({8, 0, op::AddGarment{std::make_shared<const std::string>(encode_garment(rich_garment()))}});
  ops.push_back({9, 0, op::RemoveGarment{4}});
  ops.push_back({9, 1, op::SetGarment{1, std::make_shared<const std::string>(encode_garment(rich_garment()))}});
  ops.push_back({10, 0, op::SetBody{std::make_shared<const std::string>(encode_body(small_body()))}});
  ops.push_back({10, 0, op::SetBody{nullptr}});
  SolverParams p;
  p.substeps = 17;
  p.gravity = Vec3(0, -1.5, 0);
  ops.push_back({11, 0, op::SetSolverParams{p}});
  ops.push_back({12, 0, op::SetFrameRate{120}});
  ops.push_back({12, 0, op::SetSimulating{false}});
  ops.push_back({12, 0, op::SetPickRadius{0.02}});
  ops.push_back({13, 5, op::Undo{}});
  ops.push_back({14, 5, op::Redo{}});
  return ops;
}

}  // namespace

TEST(GarmentCodec, AGarmentComesBackExactlyWithItsHolesAndEveryProperty) {
  const Garment g = rich_garment();
  ASSERT_TRUE(g.mesh().has_garbage()) << "the test garment should have removed vertices";
  const std::string bytes = encode_garment(g);
  const Garment back = decode_garment(bytes);
  expect_same(g, back);
  EXPECT_EQ(encode_garment(back), bytes) << "a decoded garment encodes to the same bytes";
  EXPECT_TRUE(back.is_valid());
}

TEST(GarmentCodec, BytesThatAreNotAGarmentAreRefusedSayingWhere) {
  const std::string bytes = encode_garment(rich_garment());
  // Every cut-off prefix is refused (never read past its end).
  for (std::size_t n = 0; n < bytes.size(); n += 1 + n / 50)
    EXPECT_THROW(decode_garment(std::string_view(bytes).substr(0, n)), InputError) << "prefix of " << n;
  // A vertex count far larger than the bytes could hold is refused before anything is allocated.
  Garment small = make_rectangle(0.1, 0.1, 2, 2);
  small.name = "garment";
  std::string huge = encode_garment(small);
  const std::size_t texture_end = 2 + 4 + 7 + 4 + 6 + 7 * 8 + 24 + 8 + 8;
  for (int k = 0; k < 4; ++k) huge[texture_end + k] = char(0xff);
  try {
    decode_garment(huge);
    ADD_FAILURE() << "a garment claiming 4 billion vertices was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("number of vertices"), std::string::npos) << e.what();
  }
}

TEST(GarmentCodec, AFaceNamingAVertexThatDoesNotExistIsRefused) {
  Garment g = make_rectangle(0.1, 0.1, 2, 2);
  g.name = "garment";
  std::string bytes = encode_garment(g);
  // The first face's first corner, after the header, the empty texture and the four vertices.
  const std::size_t first_face = 2 + 4 + 7 + 4 + 6 + 7 * 8 + 24 + 8 + 8 + 4 + 4 * 57 + 4;
  bytes[first_face] = 9;
  EXPECT_THROW(decode_garment(bytes), InputError);
}

TEST(BodyCodec, ABodyComesBackExactlyWithItsImportReport) {
  BodyImportReport rep;
  rep.format = "Collada";
  rep.up_source = "option";
  rep.up = Axis::PosZ;
  rep.scale = 0.01;
  rep.meshes_merged = 3;
  rep.smoothing = 2;  // rounded at import: the solver collides such a body's points, so it must come back
  const Body a = Body::from_triangles(small_body().vertices(), small_body().triangles(), "tetra", rep);
  const Body b = decode_body(encode_body(a));
  EXPECT_EQ(b.name(), "tetra");
  EXPECT_EQ(b.vertices(), a.vertices());
  EXPECT_EQ(b.triangles(), a.triangles());
  EXPECT_EQ(b.report().format, "Collada");
  EXPECT_EQ(b.report().up, Axis::PosZ);
  EXPECT_EQ(b.report().meshes_merged, 3u);
  EXPECT_EQ(b.report().smoothing, 2);
  const std::string bytes = encode_body(a);
  // Cut just before the rounding, it is a body as an earlier build wrote it: not rounded.
  BodyImportReport flat = rep;
  flat.smoothing = 0;
  const std::size_t unrounded =
      encode_body(Body::from_triangles(small_body().vertices(), small_body().triangles(), "tetra", flat)).size();
  EXPECT_EQ(bytes.size(), unrounded + 4);
  EXPECT_EQ(decode_body(bytes.substr(0, unrounded)).report().smoothing, 0);
  for (std::size_t n = 0; n < bytes.size(); ++n)
    if (n != unrounded) EXPECT_THROW(decode_body(bytes.substr(0, n)), InputError) << "cut at " << n;
}

TEST(Operation, EveryKindComesBackExactly) {
  for (const Operation& op : one_of_each()) {
    const std::string bytes = encode_operation(op);
    const Operation back = decode_operation(bytes);
    EXPECT_EQ(back.step, op.step);
    EXPECT_EQ(back.user, op.user);
    EXPECT_STREQ(operation_kind(back.data), operation_kind(op.data));
    EXPECT_EQ(encode_operation(back), bytes) << operation_kind(op.data);
  }
  const Operation decoded = decode_operation(encode_operation(one_of_each()[0]));
  const auto& t = std::get<op::ToolInput>(decoded.data);
  EXPECT_EQ(t.event.time, 1.0 / 3.0);
  EXPECT_EQ(t.event.buttons, 3u);
  EXPECT_EQ(std::get<long long>(t.params.at("count")), 3);
  EXPECT_EQ(std::get<Vec3>(t.params.at("color")), Vec3(0.1, 0.2, 0.3));
}

TEST(Operation, DamagedBytesAreRefusedOrReadAsAValidOperationNeverPastTheirEnd) {
  std::mt19937 rng(7);
  for (const Operation& op : one_of_each()) {
    const std::string bytes = encode_operation(op);
    for (std::size_t n = 0; n < bytes.size(); n += 1 + n / 40)
      EXPECT_THROW(decode_operation(std::string_view(bytes).substr(0, n)), InputError);
    for (int trial = 0; trial < 200; ++trial) {
      std::string bad = bytes;
      bad[rng() % bad.size()] ^= static_cast<char>(1 + rng() % 255);
      try {
        // Read as an operation, it is a whole one: it writes and reads back the same.
        const std::string again = encode_operation(decode_operation(bad));
        EXPECT_EQ(encode_operation(decode_operation(again)), again);
      } catch (const InputError&) {
      }
    }
  }
  std::string later = encode_operation(one_of_each()[2]);
  later[0] = 9;
  try {
    decode_operation(later);
    ADD_FAILURE() << "a later format version was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("version 9"), std::string::npos) << e.what();
  }
}

namespace {

// The message an InputError says (or a failure if there was none).
std::string refusal(const std::function<void()>& decode) {
  try {
    decode();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

}  // namespace

// Operations of every kind as an earlier build wrote them (tests/fixtures/saved/operations.txt):
// they decode, encode again to the same bytes, and this build writes them the same.
TEST(Operation, OperationsSavedByAnEarlierBuildDecodeAndEncodeToTheSameBytes) {
  const auto saved = test::read_samples("operations.txt");
  const auto now = test::operation_samples();
  ASSERT_EQ(saved.size(), 18u);
  ASSERT_EQ(now.size(), saved.size());
  // The saved tool events turn the pen by (0.9, 0.1, -0.3, 0.2), of length 0.975: no rotation. That
  // build took it; this one refuses it, and takes the same bytes with the pen turned by a rotation.
  const Eigen::Quaterniond saved_turn(0.9, 0.1, -0.3, 0.2), unit_turn = saved_turn.normalized();
  const auto with_unit_turn = [&](std::string bytes) {
    char was[32], unit[32];
    for (int k = 0; k < 4; ++k) {
      const double a = std::array<double, 4>{saved_turn.w(), saved_turn.x(), saved_turn.y(), saved_turn.z()}[k];
      const double b = std::array<double, 4>{unit_turn.w(), unit_turn.x(), unit_turn.y(), unit_turn.z()}[k];
      std::memcpy(was + 8 * k, &a, 8);
      std::memcpy(unit + 8 * k, &b, 8);
    }
    const std::size_t at = bytes.find(std::string(was, 32));
    if (at == std::string::npos) throw std::logic_error("no saved orientation in the bytes");
    return bytes.replace(at, 32, std::string(unit, 32));
  };
  std::set<std::string> kinds;
  for (std::size_t i = 0; i < saved.size(); ++i) {
    EXPECT_EQ(now[i].name, saved[i].name);
    EXPECT_EQ(now[i].bytes, saved[i].bytes) << saved[i].name;
    std::string bytes = saved[i].bytes;
    if (saved[i].name.rfind("tool_", 0) == 0) {
      EXPECT_EQ(refusal([&] { decode_operation(bytes); }),
                "operation: the event's orientation (0.9, 0.1, -0.3, 0.2) is not a unit quaternion (its length is "
                "0.974679): give (w, x, y, z) of length 1")
          << saved[i].name;
      bytes = with_unit_turn(bytes);
    }
    const Operation op = decode_operation(bytes);
    kinds.insert(operation_kind(op.data));
    EXPECT_EQ(encode_operation(op), bytes) << saved[i].name;
  }
  EXPECT_EQ(kinds.size(), std::variant_size_v<OperationData>) << "every kind of operation is saved";
  const Operation first = decode_operation(with_unit_turn(saved[0].bytes));
  const auto& begin = std::get<op::ToolInput>(first.data);
  EXPECT_EQ(begin.params.size(), 5u);
  EXPECT_EQ(begin.event.orientation.coeffs(), unit_turn.coeffs());
  for (const auto& s : saved) {
    for (std::size_t n = 0; n < s.bytes.size(); n += 1 + n / 40)
      EXPECT_THROW(decode_operation(std::string_view(s.bytes).substr(0, n)), InputError) << s.name << " cut at " << n;
    EXPECT_THROW(decode_operation(s.bytes + '\0'), InputError) << s.name << " and a byte more";
  }
}

TEST(Operation, TheFloorIsWrittenInVersionTwoAndOffInVersionOne) {
  // Parameters with the floor off are the bytes a build before the floor wrote (version 1), and
  // those read as off, so that a session saved then replays as it ran; on, version 2.
  SolverParams on, off;
  on.held_substeps = off.held_substeps = 0;  // as before the held substeps (version 3, below)
  off.floor = false;
  const std::string with = encode_operation({1, 0, op::SetSolverParams{on}});
  const std::string without = encode_operation({1, 0, op::SetSolverParams{off}});
  EXPECT_EQ(with[0], 2);
  EXPECT_EQ(without[0], 1);
  EXPECT_EQ(with.size(), without.size() + 1);
  EXPECT_EQ(with.substr(1, without.size() - 1), without.substr(1));
  EXPECT_TRUE(std::get<op::SetSolverParams>(decode_operation(with).data).params.floor);
  EXPECT_FALSE(std::get<op::SetSolverParams>(decode_operation(without).data).params.floor);
  EXPECT_EQ(encode_operation(decode_operation(with)), with);
  EXPECT_THROW(decode_operation(with.substr(0, with.size() - 1)), InputError) << "version 2 without its floor";
  std::string v1_with_floor = with;
  v1_with_floor[0] = 1;
  EXPECT_THROW(decode_operation(v1_with_floor), InputError) << "a byte left over in version 1";
}

TEST(Operation, HeldSubstepsAreWrittenInVersionThreeAndOffBeforeIt) {
  // Parameters with held substeps (the default) are version 3; without them, the bytes a build
  // before them wrote (version 2 with the floor on), which read as none, so that a session saved
  // then replays as it ran.
  SolverParams held, none;
  none.held_substeps = 0;
  const std::string with = encode_operation({1, 0, op::SetSolverParams{held}});
  const std::string without = encode_operation({1, 0, op::SetSolverParams{none}});
  EXPECT_EQ(with[0], 3);
  EXPECT_EQ(without[0], 2);
  EXPECT_EQ(with.size(), without.size() + 4);
  EXPECT_EQ(std::get<op::SetSolverParams>(decode_operation(with).data).params.held_substeps, held.held_substeps);
  EXPECT_EQ(std::get<op::SetSolverParams>(decode_operation(without).data).params.held_substeps, 0);
  EXPECT_EQ(encode_operation(decode_operation(with)), with);
  EXPECT_THROW(decode_operation(with.substr(0, with.size() - 1)), InputError) << "version 3 cut short";
  // They are the operation's last four bytes (little-endian): 5,000 is out of range.
  std::string out_of_range = with;
  out_of_range.replace(out_of_range.size() - 4, 4, std::string("\x88\x13\0\0", 4));
  EXPECT_NE(refusal([&] { decode_operation(out_of_range); }).find("held_substeps"), std::string::npos);
}

TEST(Operation, ValuesOutOfRangeAreRefusedSayingWhat) {
  const auto saved = test::read_samples("operations.txt");
  auto named = [&](const std::string& name) {
    for (const auto& s : saved)
      if (s.name == name) return s.bytes;
    throw std::logic_error("no saved operation " + name);
  };
  // The header: version (2), step (8), user (4), kind (1).
  std::string kind = named("undo");
  kind[14] = 14;
  EXPECT_EQ(refusal([&] { decode_operation(kind); }), "operation is malformed at byte 15: unknown operation kind");
  std::string version = named("undo");
  version[0] = 0;
  EXPECT_EQ(refusal([&] { decode_operation(version); }),
            "operation is malformed at byte 2: operation format version 0; this Kiji reads versions 1 to 3: no Kiji "
            "writes version 0, so the bytes are damaged or not Kiji's");
  version[0] = 4;
  EXPECT_EQ(refusal([&] { decode_operation(version); }),
            "operation is malformed at byte 2: operation format version 4; this Kiji reads versions 1 to 3: use a newer Kiji");
  EXPECT_EQ(refusal([&] { decode_operation(named("undo") + "zz"); }),
            "operation is malformed at byte 15: 2 bytes are left over after the operation");

  // A tool event: the tool id "pinch" (4 + 5), no parameters (4), then the phase.
  std::string phase = named("tool_move");
  phase[15 + 9 + 4] = 4;
  EXPECT_EQ(refusal([&] { decode_operation(phase); }),
            "operation is malformed at byte 29: the event's phase is not begin, move, end or cancel");
  Operation nan_time{1, 0, op::ToolInput{"pinch", {}, ToolEvent{}}};
  std::get<op::ToolInput>(nan_time.data).event.time = NAN;
  EXPECT_EQ(refusal([&] { decode_operation(encode_operation(nan_time)); }),
            "operation is malformed at byte 37: the event's time is not a finite number");
  Operation turned = nan_time;
  std::get<op::ToolInput>(turned.data).event.time = 0;
  std::get<op::ToolInput>(turned.data).event.orientation = Eigen::Quaterniond(1, 0, 0, INFINITY);
  EXPECT_EQ(refusal([&] { decode_operation(encode_operation(turned)); }),
            "operation is malformed at byte 93: the event's orientation is not a finite number");
  // What a damaged disk or a peer could hand over, each refused with the reason.
  const auto event_with = [&](const std::function<void(ToolEvent&)>& edit) {
    Operation op{1, 0, op::ToolInput{"pinch", {}, ToolEvent{}}};
    edit(std::get<op::ToolInput>(op.data).event);
    return refusal([&] { decode_operation(encode_operation(op)); });
  };
  EXPECT_EQ(event_with([](ToolEvent& e) { e.orientation = Eigen::Quaterniond(0, 0, 0, 0); }),
            "operation: the event's orientation (0, 0, 0, 0) is not a unit quaternion (its length is 0): give (w, x, "
            "y, z) of length 1");
  EXPECT_EQ(event_with([](ToolEvent& e) { e.orientation = Eigen::Quaterniond(1.01, 0, 0, 0); }),
            "operation: the event's orientation (1.01, 0, 0, 0) is not a unit quaternion (its length is 1.01): give "
            "(w, x, y, z) of length 1");
  EXPECT_EQ(event_with([](ToolEvent& e) { e.position = Vec3(0.5, 1e308, 0); }),
            "operation: the event's position (0.5, 1e+308, 0) is outside the world's bounds (1000 m from the origin "
            "on each axis)");
  EXPECT_EQ(event_with([](ToolEvent& e) { e.ray = Vec3(0, 0, -2000); }),
            "operation: the event's ray (0, 0, -2000) is outside the world's bounds (1000 m from the origin on each "
            "axis)");
  EXPECT_EQ(event_with([](ToolEvent& e) { e.pressure = 1.5; }),
            "operation: the event's pressure is 1.5: it must be from 0 to 1");
  EXPECT_EQ(event_with([](ToolEvent& e) { e.pressure = -0.25; }),
            "operation: the event's pressure is -0.25: it must be from 0 to 1");
  // Within the tolerance, and at the bounds: taken as they are.
  Operation near{1, 0, op::ToolInput{"pinch", {}, ToolEvent{}}};
  auto& near_event = std::get<op::ToolInput>(near.data).event;
  near_event.orientation = Eigen::Quaterniond(1.0002, 0, 0, 0);
  near_event.position = Vec3(-1000, 1000, 0);
  near_event.pressure = 0;
  EXPECT_EQ(encode_operation(decode_operation(encode_operation(near))), encode_operation(near));
  DecodeLimits small_world;
  small_world.world_extent = 10;
  EXPECT_THROW(decode_operation(encode_operation(near), small_world), InputError) << "the bounds are a setting";
  EXPECT_EQ(refusal([&] { decode_operation(encode_operation({1, 0, op::SetFrameRate{0.5}})); }),
            "operation: the frame rate is 0.5: use 1 to 10000 steps a second");
  EXPECT_EQ(refusal([&] { decode_operation(encode_operation({1, 0, op::SetPickRadius{0}})); }),
            "operation: the pick radius is 0 m: use more than 0 and at most 10 m");
  EXPECT_EQ(refusal([&] { decode_operation(encode_operation({1, 0, op::SetPickRadius{11}})); }),
            "operation: the pick radius is 11 m: use more than 0 and at most 10 m");
  SolverParams far;
  far.local_center = Vec3(0, -5000, 0);
  EXPECT_EQ(refusal([&] { decode_operation(encode_operation({1, 0, op::SetSolverParams{far}})); }),
            "operation: the solver's local_center (0, -5000, 0) is outside the world's bounds (1000 m from the origin "
            "on each axis)");
  SolverParams heavy;
  heavy.gravity = Vec3(0, -1e6, 0);
  EXPECT_EQ(refusal([&] { decode_operation(encode_operation({1, 0, op::SetSolverParams{heavy}})); }),
            "operation: the solver's gravity (0, -1e+06, 0) is over 1000 m/s^2 (100 g)");

  Operation param{1, 0, op::ToolInput{"pinch", {{"p", 1.0}}, ToolEvent{}}};
  std::string tag = encode_operation(param);
  tag[15 + 9 + 4 + 5] = 5;  // the value's type, after the name "p"
  EXPECT_EQ(refusal([&] { decode_operation(tag); }), "operation is malformed at byte 34: a parameter has an unknown type");
  std::get<op::ToolInput>(param.data).params = {{"p", NAN}};
  EXPECT_EQ(refusal([&] { decode_operation(encode_operation(param)); }),
            "operation is malformed at byte 42: a number parameter is not a finite number");
  std::get<op::ToolInput>(param.data).params = {{"p", std::string(5000, 'x')}};
  EXPECT_EQ(refusal([&] { decode_operation(encode_operation(param)); }),
            "operation is malformed at byte 38: a text parameter is 5000 bytes long, over the limit of 4096");
  op::ToolInput many{"pinch", {}, ToolEvent{}};
  for (int i = 0; i < 257; ++i) many.params["p" + std::to_string(i)] = 1LL;
  EXPECT_EQ(refusal([&] { decode_operation(encode_operation({1, 0, many})); }),
            "operation is malformed at byte 28: the number of parameters is 257, over the limit of 256");

  // Settings.
  SolverParams p;
  p.substeps = 0;
  EXPECT_EQ(refusal([&] { decode_operation(encode_operation({1, 0, op::SetSolverParams{p}})); }).rfind(
                "operation is malformed at byte 127: the solver parameters are out of range: ", 0),
            0u);
  std::string model = encode_operation({1, 0, op::SetSolverParams{SolverParams{}}});
  model[15] = 2;
  EXPECT_EQ(refusal([&] { decode_operation(model); }), "operation is malformed at byte 16: unknown solver model");
  EXPECT_EQ(refusal([&] { decode_operation(encode_operation({1, 0, op::SetFrameRate{INFINITY}})); }),
            "operation is malformed at byte 23: the frame rate is not a finite number");
  std::string simulating = named("set_simulating");
  simulating[15] = 2;
  EXPECT_EQ(refusal([&] { decode_operation(simulating); }), "operation is malformed at byte 16: simulating is not 0 or 1");
  std::string body = named("set_body");
  body[15] = 3;
  EXPECT_EQ(refusal([&] { decode_operation(body); }),
            "operation is malformed at byte 16: whether there is a body is not 0 or 1");
  std::string garment = named("add_garment");
  garment[15] = char(0xff);
  EXPECT_EQ(refusal([&] { decode_operation(garment); }).rfind("operation is malformed at byte 23: the garment says ", 0), 0u);
}

TEST(GarmentCodec, ValuesOutOfRangeAreRefusedSayingWhatAndWhere) {
  Garment small = make_rectangle(0.1, 0.1, 2, 2);
  small.name = "garment";
  const std::string bytes = encode_garment(small);
  auto patched = [&](std::size_t at, auto value) {
    std::string b = bytes;
    std::memcpy(&b[at], &value, sizeof value);
    return b;
  };
  // version (2), name (4 + 7), material: name (4 + 6) and 7 numbers, colour (24), pattern scale (8),
  // texture width and height (8), the number of vertices (4), then 4 vertices of 57 bytes.
  const std::size_t material = 2 + 11 + 10, scale = material + 56 + 24, texture = scale + 8, vertices = texture + 12;
  EXPECT_EQ(refusal([&] { decode_garment(patched(0, std::uint16_t(2))); }),
            "garment data is malformed at byte 2: garment format version 2; this Kiji reads versions 1 to 1: use a newer "
            "Kiji");
  EXPECT_EQ(refusal([&] { decode_garment(patched(material, -1.0)); })
                .rfind("garment data is malformed at byte 79: the material is out of range: ", 0),
            0u);
  EXPECT_EQ(refusal([&] { decode_garment(patched(scale, 0.0)); }),
            "garment data is malformed at byte 111: the pattern scale is not positive");
  EXPECT_EQ(refusal([&] { decode_garment(patched(texture, std::uint64_t(20000) | std::uint64_t(1) << 32)); }),
            "garment data is malformed at byte 119: the texture is 20000x1; at most 16384 texels a side");
  EXPECT_EQ(refusal([&] { decode_garment(patched(vertices + 49, -1.0)); }),
            "garment data is malformed at byte 180: a vertex has a negative inverse mass");
  EXPECT_EQ(refusal([&] { decode_garment(patched(vertices + 1, std::nan(""))); }),
            "garment data is malformed at byte 132: a vertex position is not a finite number");
  const std::size_t faces = vertices + 4 * 57;
  EXPECT_EQ(refusal([&] { decode_garment(patched(faces + 4 + 4, std::uint32_t(9))); }),
            "garment data is malformed at byte 363: face 0 uses a vertex that does not exist");
  // After the sleeping vertices, a step record where the garment was stepped: bytes there are read as
  // one, and bytes after one are left over.
  EXPECT_EQ(refusal([&] { decode_garment(bytes + "z"); }),
            "garment data is malformed at byte " + std::to_string(bytes.size()) + ": ends early (8 bytes wanted, 1 left)");
  Solver solver;
  solver.step(small, 1.0 / 60);
  const std::string stepped = encode_garment(small);
  ASSERT_GT(stepped.size(), bytes.size()) << "a stepped garment carries its step record";
  EXPECT_EQ(refusal([&] { decode_garment(stepped + "z"); }),
            "garment data is malformed at byte " + std::to_string(stepped.size()) +
                ": 1 bytes are left over after the garment");
  EXPECT_EQ(refusal([&] { decode_garment(stepped.substr(0, bytes.size() + 8) + std::string(4, '\xff')); }),
            "garment data is malformed at byte " + std::to_string(bytes.size() + 12) +
                ": the number of the step record's vertices is 4294967295, over the limit of " +
                std::to_string(DecodeLimits{}.max_vertices));
  const std::string no_faces = bytes.substr(0, faces) + std::string(16, '\0');
  EXPECT_EQ(refusal([&] { decode_garment(no_faces); }), "garment data has no faces: a garment needs at least one triangle");
}

TEST(BodyCodec, ValuesOutOfRangeAreRefusedSayingWhatAndWhere) {
  const std::string bytes = encode_body(small_body());
  // version (2), name "tetra" (4 + 5), three empty texts (12), the up axis.
  std::string up = bytes;
  up[23] = 6;
  EXPECT_EQ(refusal([&] { decode_body(up); }), "body data is malformed at byte 24: unknown up axis");
  // ... scale (8), two counts (16), the number of vertices and 4 of 24 bytes, the number of triangles.
  std::string corner = bytes;
  corner[24 + 8 + 16 + 4 + 96 + 4] = 7;
  EXPECT_EQ(refusal([&] { decode_body(corner); }),
            "body data is malformed at byte 156: a body triangle uses a vertex that does not exist");
  // After the triangles, the rounding of a rounded body (a u32), then nothing.
  EXPECT_EQ(refusal([&] { decode_body(bytes + "zz"); }),
            "body data is malformed at byte 200: ends early (4 bytes wanted, 2 left)");
  const auto rounded = [&](std::uint32_t rounds) {
    std::string b = bytes;
    for (int k = 0; k < 4; ++k) b += char((rounds >> (8 * k)) & 0xff);
    return b;
  };
  EXPECT_EQ(decode_body(rounded(2)).report().smoothing, 2);
  EXPECT_EQ(refusal([&] { decode_body(rounded(0)); }),
            "body data is malformed at byte 204: the body's rounding is not 1 to 16 subdivisions");
  EXPECT_EQ(refusal([&] { decode_body(rounded(17)); }),
            "body data is malformed at byte 204: the body's rounding is not 1 to 16 subdivisions");
  EXPECT_EQ(refusal([&] { decode_body(rounded(2) + "zz"); }),
            "body data is malformed at byte 204: 2 bytes are left over after the body");
}
