// Setting a scene up: garments made from a pattern and put where a user expects them (laid over the
// body, or hanging at head height from two corners where there is none), and the drape. Each change
// goes through the session's operations, so a saved session or journal replays it.
#pragma once

#include "kiji/body.h"
#include "kiji/garment.h"

#include <functional>
#include <string>
#include <vector>

namespace kiji {
class Session;
}

namespace kiji::studio {

struct GarmentSpec {
  enum class Kind { Rectangle, Panel };
  Kind kind = Kind::Rectangle;
  double width = 1.0, height = 1.0;  // a rectangle, metres
  std::vector<Vec2> outline;        // a panel's outline, metres
  double spacing = 0.02;            // vertex spacing (rectangle) or edge length (panel), metres
  std::string material = "cotton";  // a preset: Material::preset_names()
  // Throws InputError for a size, spacing or material a garment cannot be made of.
  Garment make() const;
  std::string describe() const;  // "rectangle 1 x 1.2 m, 0.02 m apart, cotton"
  // "rect:W,H,SPACING" as on the command line.
  static GarmentSpec rectangle(const std::string& spec);
};

// Adds a garment: laid flat over the body if the session has one, else hanging in front of the
// origin at head height from its two top corners (it would fall forever otherwise). Its index.
std::size_t add_garment(Session& session, const GarmentSpec& spec);

// Whether the session has had a stroke (before one, a new body re-lays the garments over it).
bool has_strokes(const Session& session);

// Lays every garment flat over the session's body (a garment not yet touched, when a body comes).
void lay_over_body(Session& session);

}  // namespace kiji::studio
