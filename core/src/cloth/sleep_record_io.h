// A garment's sleep record (Garment::sleep_record) as the garment's bytes carry it: the vertices
// that sleep where the garment has them, with the edges and mass they slept with. Whoever decodes
// the garment (a session adding it, a peer after a checkpoint, a session file) gets the same record
// back, so a settled garment does not wake whole in each of them, and all of them step alike.
#pragma once

#include "kiji/garment.h"

#include <array>
#include <cstdint>
#include <vector>

namespace kiji::detail {

struct SleepingVertices {
  std::array<double, 15> physics{};     // what the resting shape depended on (the solver's own key)
  std::vector<std::uint32_t> vertices;  // ascending; empty when nothing sleeps as recorded
};

// The vertices the garment's record finds exactly as they slept (position, zero velocity, inverse
// mass, edges and rest lengths): the only ones a solver would start asleep.
SleepingVertices sleeping_vertices(const Garment& g);

// Gives the garment the record of `asleep` (its vertices must exist): what sleeping_vertices read.
void restore_sleep_record(Garment& g, const SleepingVertices& asleep);

}  // namespace kiji::detail
