// Flat pattern pieces: the cloth as it is cut from the roll, before it is placed on a body.
// A pattern lies in the plane z = 0 with its pattern coordinates (metres) as x and y; its uv is
// those coordinates scaled to [0,1] over the larger side.
#pragma once

#include "kiji/garment.h"

#include <string>
#include <vector>

namespace kiji {

// A rectangle width x height (metres) with nx x ny vertices (each at least 2), triangulated with
// alternating diagonals so the cloth has no preferred shear direction.
Garment make_rectangle(double width, double height, int nx, int ny, const Material& material = {});

// A rectangle whose vertices are about `spacing` metres apart.
Garment make_rectangle_spaced(double width, double height, double spacing,
                              const Material& material = {});

// The "rect:W,H,SPACING" garment spec of the command line; throws InputError saying what is wrong.
struct RectSpec {
  double width = 0, height = 0, spacing = 0;
  static RectSpec parse(const std::string& spec);
  void validate() const;
};

// A pattern piece: any simple polygon outline (counter-clockwise or clockwise, not closed by a
// repeated point), triangulated inside with edges of about `edge_length` metres. Throws InputError
// for fewer than 3 points, non-finite or self-intersecting outlines, or a non-positive edge length.
Garment make_panel(const std::vector<Vec2>& outline, double edge_length,
                   const Material& material = {}, int panel_id = 0);

}  // namespace kiji
