// What the fuzz targets of operations share: an operation a session accepts, wherever it came from
// (a session file, a journal, a peer), leaves every garment finite and valid.
#pragma once

#include "kiji/error.h"
#include "kiji/operation.h"
#include "kiji/pattern.h"
#include "kiji/session.h"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace kiji::fuzz {

// An operation's step, and a tool event's time, are taken at most this far ahead of the clock:
// stepping there is the same code whatever the distance, and a fuzzed step count or an event an
// hour ahead (which a session accepts) would spend the run's time on it.
constexpr std::uint64_t kMaxStepsAhead = 4;

// Performs the operations in order on a session holding a small garment, as a replay or a peer
// does, leaving out those it refuses with InputError, then takes a step. A step that would diverge
// is the solver's SimulationError, which undoes it. Traps (a finding) if a garment then has a
// position or velocity that is not finite, or is not a valid mesh.
inline void perform_and_check(const std::vector<Operation>& operations) {
  Session session;
  session.add_garment(make_rectangle(0.2, 0.2, 4, 4));
  for (Operation op : operations) {
    op.step = std::min(op.step, session.steps() + kMaxStepsAhead);
    if (auto* input = std::get_if<op::ToolInput>(&op.data))
      input->event.time = std::min(input->event.time, session.time() + kMaxStepsAhead / session.frame_rate());
    try {
      session.perform(op);
    } catch (const InputError&) {
    } catch (const SimulationError&) {
    }
  }
  try {
    session.step();
  } catch (const SimulationError&) {
  }
  for (std::size_t i = 0; i < session.garment_count(); ++i)
    if (!session.garment(i).is_valid()) __builtin_trap();
}

}  // namespace kiji::fuzz
