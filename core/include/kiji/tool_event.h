// What a tool sees of the user: device-agnostic events in, a force out. A Phantom, a mouse, a
// script, a replayed journal and a remote peer all produce these same events.
#pragma once

#include "kiji/types.h"

#include <cstdint>
#include <limits>
#include <vector>

namespace kiji {

enum class Phase : std::uint8_t { Begin, Move, End, Cancel };
const char* phase_name(Phase phase);

// The cloth surface under the pointer, filled in by the core (never by a device).
struct SurfaceHit {
  bool hit = false;
  std::size_t garment = 0;        // index of the garment in the session
  Face face;                      // the face hit
  Vec3 barycentric{1, 0, 0};      // weights of the face's three corners (halfedge order from halfedge(face))
  Vertex nearest;                 // the face's corner nearest the hit point
  Vec3 point{0, 0, 0};            // the hit point on the cloth, world space
  Vec3 normal{0, 1, 0};           // the face's unit normal
  Vec2 uv{0, 0};                  // texture coordinates at the hit point
  double distance = std::numeric_limits<double>::infinity();  // pointer to hit point
};

enum Button : std::uint32_t { kButtonPrimary = 1u, kButtonSecondary = 2u };

struct ToolEvent {
  Phase phase = Phase::Move;
  double time = 0;                               // seconds, on the session's clock
  Vec3 position{0, 0, 0};                        // pointer position, world space, metres
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  std::uint32_t buttons = kButtonPrimary;
  double pressure = 1.0;                         // 0..1
  // Optional pick ray (a mouse): when non-zero, the hit is where the ray from `position` along
  // `ray` meets the cloth; otherwise it is the cloth point nearest `position` (a 3D pen).
  Vec3 ray{0, 0, 0};
  SurfaceHit hit;                                // filled in by the session
};

// A recorded stroke: Begin, Moves, then End (or Cancel).
using Stroke = std::vector<ToolEvent>;

// The event that ends a stroke unfinished at `time` (a peer gone, a lease taken back, a journal
// that ends mid-stroke).
inline ToolEvent cancel_event(double time) {
  ToolEvent e;
  e.phase = Phase::Cancel;
  e.time = time;
  return e;
}

struct Feedback {
  Vec3 force{0, 0, 0};   // newtons, on the user's hand
  Vec3 torque{0, 0, 0};  // newton-metres
};

}  // namespace kiji
