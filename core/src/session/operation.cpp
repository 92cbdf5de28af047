#include "kiji/operation.h"

#include "base/archive.h"
#include "base/overloaded.h"
#include "kiji/error.h"

#include <array>
#include <cmath>
#include <sstream>
#include <type_traits>

namespace kiji {

using detail::Field;

namespace {

using detail::Overloaded;

// The tags of the binary form, by the alternative's place in its variant; the numbers are the
// format's, never reused.
constexpr std::array<std::uint8_t, 13> kKindTags = {
    1,   // ToolInput
    2,   // AddGarment
    3,   // RemoveGarment
    4,   // SetGarment
    5,   // SetBody
    6,   // SetSolverParams
    7,   // SetFrameRate
    8,   // SetSimulating
    9,   // SetPickRadius
    10,  // Undo
    11,  // Redo
    12,  // Advance
    13,  // Checkpoint
};
constexpr std::array<std::uint8_t, 5> kValueTags = {0 /* bool */, 1 /* int */, 2 /* float */, 3 /* string */,
                                                     4 /* colour */};

// Each type's fields, in the order they are in the binary form: encode_operation and
// decode_operation are these and nothing else.

template <class A>
void fields(A& a, Field<A, ParamValue>& value, const DecodeLimits& limits) {
  a.variant(value, kValueTags, "a parameter has an unknown type", [&](auto& v) {
    using T = std::decay_t<decltype(v)>;
    if constexpr (std::is_same_v<T, bool>) a.boolean(v, "a boolean parameter");
    else if constexpr (std::is_same_v<T, long long>) a.i64(v);
    else if constexpr (std::is_same_v<T, double>) a.finite(v, "a number parameter");
    else if constexpr (std::is_same_v<T, std::string>) a.str(v, limits.max_string, "a text parameter");
    else a.vec3(v, "a colour parameter");
  });
}

template <class A>
void fields(A& a, Field<A, ToolEvent>& e) {
  a.enumeration(e.phase, Phase::Cancel, "the event's phase is not begin, move, end or cancel");
  a.finite(e.time, "the event's time");
  a.vec3(e.position, "the event's position");
  a.quaternion(e.orientation, "the event's orientation");
  a.u32(e.buttons);
  a.finite(e.pressure, "the event's pressure");
  a.vec3(e.ray, "the event's ray");
}

template <class A>
void fields(A& a, Field<A, SolverParams>& p) {
  a.enumeration(p.model, SolverModel::MassSpring, "unknown solver model");
  a.vec3(p.gravity, "gravity");
  a.i32(p.substeps);
  a.i32(p.iterations);
  a.boolean(p.body_collision, "body_collision");
  a.boolean(p.self_collision, "self_collision");
  a.f64(p.strain_limit);
  a.f64(p.spring_k);
  a.f64(p.spring_damping);
  a.f64(p.local_radius);
  a.vec3(p.local_center, "local_center");
  a.f64(p.sleep_after);
  a.f64(p.sleep_distance);
  // Version 2 added the floor; parameters of version 1 (written before it, or with it off) have it
  // off, so that a session saved before it replays as it ran.
  if (a.form_version() >= 2)
    a.boolean(p.floor, "floor");
  else if constexpr (A::reading)
    p.floor = false;
  // Version 3 added the substeps while a hand holds; before it a hand's step took `substeps`.
  if (a.form_version() >= 3)
    a.i32(p.held_substeps);
  else if constexpr (A::reading)
    p.held_substeps = 0;
  a.validate(p, "the solver parameters are out of range: ");
}

template <class A>
void fields(A& a, Field<A, op::ToolInput>& t, const DecodeLimits& limits) {
  a.str(t.tool, limits.max_string, "the tool id");
  a.entries(t.params, limits.max_params, 6, "the number of parameters", [&](auto& name, auto& value) {
    a.str(name, limits.max_string, "a parameter name");
    fields(a, value, limits);
  });
  fields(a, t.event);
}

template <class A>
void fields(A& a, Field<A, op::AddGarment>& g, const DecodeLimits&) {
  a.shared_bytes(g.garment, "the garment");
}

template <class A>
void fields(A& a, Field<A, op::RemoveGarment>& g, const DecodeLimits&) {
  a.u32(g.index);
}

template <class A>
void fields(A& a, Field<A, op::SetGarment>& g, const DecodeLimits&) {
  a.u32(g.index);
  a.shared_bytes(g.garment, "the garment");
}

template <class A>
void fields(A& a, Field<A, op::SetBody>& b, const DecodeLimits&) {
  if (a.present(b.body != nullptr, "whether there is a body")) a.shared_bytes(b.body, "the body");
}

template <class A>
void fields(A& a, Field<A, op::SetSolverParams>& p, const DecodeLimits&) {
  fields(a, p.params);
}

template <class A>
void fields(A& a, Field<A, op::SetFrameRate>& f, const DecodeLimits&) {
  a.finite(f.steps_per_second, "the frame rate");
}

template <class A>
void fields(A& a, Field<A, op::SetSimulating>& s, const DecodeLimits&) {
  a.boolean(s.simulating, "simulating");
}

template <class A>
void fields(A& a, Field<A, op::SetPickRadius>& p, const DecodeLimits&) {
  a.finite(p.radius, "the pick radius");
}

template <class A>
void fields(A& a, Field<A, op::Checkpoint>& c, const DecodeLimits&) {
  if (a.present(c.state != nullptr, "whether there is a state")) a.shared_bytes(c.state, "the state");
}

// Undo, redo and advance have no fields.
template <class A, class Empty, class = std::enable_if_t<std::is_empty_v<Empty>>>
void fields(A&, Empty&, const DecodeLimits&) {}

template <class A>
void fields(A& a, Field<A, Operation>& op, const DecodeLimits& limits) {
  // The oldest version that holds the operation, so that an older Kiji reads what it can.
  const auto* params = std::get_if<op::SetSolverParams>(&op.data);
  a.version(kOperationVersion, !params ? 1 : params->params.held_substeps != 0 ? 3 : params->params.floor ? 2 : 1,
            "operation");
  a.u64(op.step);
  a.u32(op.user);
  a.variant(op.data, kKindTags, "unknown operation kind", [&](auto& data) { fields(a, data, limits); });
  a.end(" after the operation");
}

std::string vector_text(const Vec3& v) {
  std::ostringstream o;
  o << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return o.str();
}

// A point within the world's bounds: finite, and no further than `extent` from the origin on any axis.
void check_within_world(const Vec3& p, const char* what, double extent) {
  if (!all_finite(p)) throw InputError(std::string(what) + " " + vector_text(p) + " is not finite");
  if (p.cwiseAbs().maxCoeff() > extent) {
    std::ostringstream o;
    o << what << " " << vector_text(p) << " is outside the world's bounds (" << extent
      << " m from the origin on each axis)";
    throw InputError(o.str());
  }
}

}  // namespace

void check_tool_event(const ToolEvent& e, const DecodeLimits& limits) {
  if (!std::isfinite(e.time)) throw InputError("the event's time is not a finite number");
  check_within_world(e.position, "the event's position", limits.world_extent);
  check_within_world(e.ray, "the event's ray", limits.world_extent);
  const auto& q = e.orientation;
  if (!q.coeffs().allFinite()) throw InputError("the event's orientation is not finite");
  const double n2 = q.squaredNorm();
  if (!(std::abs(n2 - 1) <= kOrientationTolerance)) {
    std::ostringstream o;
    o << "the event's orientation (" << q.w() << ", " << q.x() << ", " << q.y() << ", " << q.z()
      << ") is not a unit quaternion (its length is " << std::sqrt(n2) << "): give (w, x, y, z) of length 1";
    throw InputError(o.str());
  }
  if (!(e.pressure >= 0 && e.pressure <= 1)) {
    std::ostringstream o;
    o << "the event's pressure is " << e.pressure << ": it must be from 0 to 1";
    throw InputError(o.str());
  }
}

void check_operation(const Operation& op, const DecodeLimits& limits) {
  std::visit(Overloaded{[&](const op::ToolInput& t) {
                          if (t.tool.empty()) throw InputError("a tool event names no tool");
                          check_tool_event(t.event, limits);
                        },
                        [&](const op::SetSolverParams& p) {
                          p.params.validate();
                          check_within_world(p.params.local_center, "the solver's local_center", limits.world_extent);
                          if (!(p.params.gravity.norm() <= 1000))
                            throw InputError("the solver's gravity " + vector_text(p.params.gravity) +
                                             " is over 1000 m/s^2 (100 g)");
                        },
                        [&](const op::SetFrameRate& f) {
                          if (!(f.steps_per_second >= 1 && f.steps_per_second <= 10000)) {
                            std::ostringstream o;
                            o << "the frame rate is " << f.steps_per_second << ": use 1 to 10000 steps a second";
                            throw InputError(o.str());
                          }
                        },
                        [&](const op::SetPickRadius& p) {
                          if (!(p.radius > 0 && p.radius <= 10)) {
                            std::ostringstream o;
                            o << "the pick radius is " << p.radius << " m: use more than 0 and at most 10 m";
                            throw InputError(o.str());
                          }
                        },
                        [&](const auto&) {}},
             op.data);
}

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
  detail::WriteArchive a;
  fields(a, op, DecodeLimits{});
  return a.take();
}

Operation decode_operation(std::string_view bytes, const DecodeLimits& limits) {
  detail::ReadArchive a(bytes, "operation");
  Operation op;
  fields(a, op, limits);
  try {
    check_operation(op, limits);
  } catch (const InputError& e) {
    throw InputError(std::string("operation: ") + e.what());
  }
  return op;
}

}  // namespace kiji
