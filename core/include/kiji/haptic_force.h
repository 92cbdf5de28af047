// The force a tool gives the hand, and what it is computed from: the snapshot of the cloth near the
// pointer that the haptic loop reads between simulation steps, and the force models a tool shares
// with the loop (a spring to the cloth it holds, as pinch; a push out of the surface, as paint). A
// tool uses the same model for the feedback of its stroke and for its haptic_force.
#pragma once

#include "kiji/garment.h"
#include "kiji/tool_event.h"

#include <array>
#include <cstddef>
#include <variant>
#include <vector>

namespace kiji {

// The cloth near the pointer, as it was after a simulation step.
struct HapticSnapshot {
  double time = 0;
  std::size_t garment = 0;
  Vec3 center{0, 0, 0};
  double radius = 0;
  std::vector<Vertex> vertices;             // the vertices within radius of center, in index order
  std::vector<Vec3> positions;              // their positions
  std::vector<std::array<int, 3>> triangles;  // faces whose three vertices are all in, as local indices

  // Where `v` was, or nullptr if it is not in the snapshot (a binary search of `vertices`).
  const Vec3* position_of(Vertex v) const;
  // The snapshot's cloth surface point nearest p (hit = false if the snapshot has no triangle).
  SurfaceHit nearest(const Vec3& p) const;
};

// The grabbed cloth pulls the hand (pinch's spring, the virtual coupling): the sum over the grabbed
// vertices of share() (x_v - offset_v - pointer), each vertex held at the offset from the pointer at
// which it was taken. Vertices the cloth no longer has, or the snapshot does not hold, add nothing.
struct HapticSpring {
  std::size_t garment = 0;
  std::vector<Vertex> vertices;  // sorted
  std::vector<Vec3> offsets;     // vertex - pointer when taken, one a vertex
  double stiffness = 0;          // N/m in all, shared among the vertices

  // Each vertex's stiffness: the hand's, shared so that a patch pulls as one vertex would.
  double share() const { return stiffness / double(vertices.size()); }
  // The pull on the hand at `pointer` from the cloth as the last step left it (the haptic loop);
  // none from a snapshot of another garment.
  Vec3 force(const HapticSnapshot& snapshot, const Vec3& pointer) const;
  // The same from the garment as it is now (a stroke's feedback).
  Vec3 force(const Garment& garment, const Vec3& pointer) const;
};

// The cloth pushes the pen back out along its normal, as paint's touch does: stiffness (touch - d) n
// when the pen is within `touch` metres of the surface, on whichever side it is.
struct HapticPush {
  double touch = 0.005;     // m
  double stiffness = 300;   // N/m

  // The push on the pen at `pen` from the surface point nearest it (none if not hit or beyond touch).
  Vec3 force(const SurfaceHit& nearest, const Vec3& pen) const;
};

// One of the models, declared by a tool whose own code cannot answer a thousand times a second (a
// tool written in Python): the haptic loop computes it by itself from the snapshot.
using HapticModel = std::variant<std::monostate, HapticSpring, HapticPush>;
// The model's force for a pointer; none for std::monostate.
Feedback haptic_model_force(const HapticModel& model, const HapticSnapshot& snapshot, const ToolEvent& event);

}  // namespace kiji
