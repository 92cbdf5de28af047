#include "kiji/operation.h"

#include "base/byte_io.h"
#include "base/overloaded.h"

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

void check_version(ByteReader& r, const char* what) { detail::check_format_version(r, kOperationFormatVersion, what); }

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

}  // namespace kiji
