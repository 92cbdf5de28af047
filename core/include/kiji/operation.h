// Operations: every change to a session, as data. A tool event, a new garment, a direct edit, a new
// body, new solver parameters, pausing, undo: each enters the session as an Operation, is applied,
// and is appended to the session's log, so that replay, autosave, undo and peers see one history.
// Replaying a log on a new session gives the same garments bit for bit.
//
// Operations have a compact binary form (encode_operation / decode_operation) for files and the
// network. The decoder trusts nothing: every length and index is checked against the bytes that
// are there and against fixed limits before anything is allocated.
#pragma once

#include "kiji/body.h"
#include "kiji/codec.h"
#include "kiji/garment.h"
#include "kiji/params.h"
#include "kiji/solver.h"
#include "kiji/tool_event.h"

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace kiji {

// Who made a change: 0 is the local user; peers and recordings get their own numbers. Each user has
// at most one stroke in progress, with its own instance of the tool.
using UserId = std::uint32_t;

namespace op {

// One event of a stroke (Begin carries the tool's parameters; Move, End and Cancel do not).
struct ToolInput {
  std::string tool;
  std::map<std::string, ParamValue> params;  // Begin only: every parameter's value
  ToolEvent event;                           // as the device gave it (the session fills in the hit)
};
// A garment added at the end of the list. The garment is carried in its binary form, so that every
// session that applies the operation builds the very same mesh from the same bytes.
struct AddGarment {
  std::shared_ptr<const std::string> garment;  // encode_garment()
};
struct RemoveGarment {
  std::uint32_t index = 0;
};
// A garment replaced by an edited copy: what direct edits become (arrays assigned from Python, a
// piece removed, a new material, a topology edit outside a tool).
struct SetGarment {
  std::uint32_t index = 0;
  std::shared_ptr<const std::string> garment;  // encode_garment()
};
struct SetBody {
  std::shared_ptr<const std::string> body;  // encode_body(); null: no body
};
struct SetSolverParams {
  SolverParams params;
};
struct SetFrameRate {
  double steps_per_second = 60;
};
struct SetSimulating {
  bool simulating = true;
};
struct SetPickRadius {
  double radius = 0.05;
};
struct Undo {};
struct Redo {};
// Time passed: the session's clock reached op.step, and nothing else changed. Saved files end with
// one, so that replaying them ends where the session was, not at its last change.
struct Advance {};
// The session starts again from a whole state (Session::encode_state): every stroke in progress
// ended, a new undo history, garments rebuilt from their binary forms and fresh solvers. With no
// state, from its own: what every peer does at once when a peer joins, so that all of them and the
// newcomer go on from the very same state.
struct Checkpoint {
  std::shared_ptr<const std::string> state;  // Session::encode_state(); null: the session's own
};

}  // namespace op

using OperationData = std::variant<op::ToolInput, op::AddGarment, op::RemoveGarment, op::SetGarment, op::SetBody,
                                   op::SetSolverParams, op::SetFrameRate, op::SetSimulating, op::SetPickRadius,
                                   op::Undo, op::Redo, op::Advance, op::Checkpoint>;

struct Operation {
  // The number of simulation steps the session had taken when the operation was applied: replay
  // steps to this count first. (A tool event may step the clock further, to its own time.)
  std::uint64_t step = 0;
  UserId user = 0;
  OperationData data;
};

// The operation's kind as a word: "tool", "add_garment", "remove_garment", "set_garment",
// "set_body", "set_solver_params", "set_frame_rate", "set_simulating", "set_pick_radius", "undo",
// "redo", "advance", "checkpoint".
const char* operation_kind(const OperationData& data);

// Whether an operation can change a garment (and so is a step of the undo history when it
// completes): tool strokes, adding, removing and setting garments.
bool changes_garments(const OperationData& data);

// --- checks ---
// How far an orientation's squared length may be from 1: a device's rotation in single precision
// is well within it, a quaternion of zeros or of garbage is not.
constexpr double kOrientationTolerance = 1e-3;
// Every field of a tool event that can be checked without a session: the time a finite number, the
// position and ray finite and within the world's bounds (limits.world_extent), the orientation a
// unit quaternion (within kOrientationTolerance), the pressure from 0 to 1. Throws InputError naming
// the field and what it must be. (Whether the time is before the session's clock is the session's
// check: see Session::apply.)
void check_tool_event(const ToolEvent& event, const DecodeLimits& limits = {});
// Every field of an operation that can be checked without a session: its tool event (above), a
// frame rate from 1 to 10,000, a pick radius above 0 and at most 10 m, solver parameters in range
// with their local centre within the world's bounds and gravity at most 1,000 m/s^2. Throws
// InputError naming the field. Decoders, the journal reader and Session::perform call it, so an
// operation is checked before it is applied wherever it came from.
void check_operation(const Operation& op, const DecodeLimits& limits = {});

// --- binary forms (garments and bodies: kiji/codec.h) ---
// The newest version of an operation's binary form. 2 added SolverParams::floor, 3
// SolverParams::held_substeps; an operation is written in the oldest version that holds it (1
// unless it sets the floor on or held substeps).
constexpr std::uint16_t kOperationVersion = 3;
std::string encode_operation(const Operation& op);
// Throws InputError saying what is malformed (and at which byte) for bytes that are not a whole,
// valid operation of a version this Kiji reads, or whose fields are out of range (check_operation).
Operation decode_operation(std::string_view bytes, const DecodeLimits& limits = {});

}  // namespace kiji
