// Draping: a flat garment placed over a body, let fall under gravity and settle. The first thing a
// user does with Kiji, and the start of every design session.
#pragma once

#include "kiji/body.h"
#include "kiji/garment.h"
#include "kiji/solver.h"

#include <functional>

namespace kiji {

// Lays a flat pattern (in the z = 0 plane) horizontally over the body: its x along the body's
// shoulders (x), its y from front to back (-z), centred over the body's head and shoulders (its top
// quarter), `clearance` metres above the highest point of the body under it.
void place_over_body(Garment& garment, const Body& body, double clearance = 0.02);

struct DrapeOptions {
  double seconds = 3.0;          // simulated time
  double frame_rate = 60.0;      // steps per simulated second
  // The solver for the drape: 40 substeps a step rather than the interactive default of 10. A
  // falling cloth landing on a head wraps a dome in a fraction of a second; with 10 substeps its
  // first folds are compressed by up to 28 % and its mean strain is 1.4 % (10,000 vertices); with
  // 40 the largest edge strain stays under 7 % and the mean at 0.2 % (10,000 and 14,241 vertices),
  // at 2.3 times the time per step.
  SolverParams solver = [] {
    SolverParams p;
    p.substeps = 40;
    return p;
  }();
  // Coarse first: a flat garment at rest, without pins, falls as a copy of itself remeshed with
  // edges `coarse_ratio` times as long (a ninth of the vertices at 3), but no longer than 4 cm, at
  // `coarse_substeps`, for all but the last `fine_seconds`; the garment then takes the copy's shape and velocity and
  // settles at its own resolution and `solver`, its damping raised to at least `fine_damping`
  // (per second) meanwhile. The default cloth drapes in about a fifth of the time, as
  // unstretched (docs/benchmarks.md, "The drape, coarse first"). 1 drapes the garment itself
  // throughout; so is a garment that is not flat, is pinned, has under 2,000 vertices or whose
  // edges are over 2.7 cm (a copy could not be half as fine again).
  double coarse_ratio = 3.0;
  int coarse_substeps = 15;
  double fine_seconds = 0.5;
  double fine_damping = 8.0;
  void validate() const;
};

struct DrapeResult {
  double seconds_simulated = 0;
  double wall_seconds = 0;
  std::size_t steps = 0;          // the garment's own, after the coarse copy's
  ClothMeasures measures;        // at the end
  std::size_t coarse_vertices = 0;  // the coarse copy's (0: the garment was draped itself throughout)
  std::size_t coarse_steps = 0;
  double coarse_wall_seconds = 0;   // of wall_seconds: remeshing, the copy's drape, the transfer
};

// Called after each step with the fraction done; return false to stop early.
using DrapeProgress = std::function<bool(double fraction)>;

// Whether drape() lets this garment fall as a coarse copy first with these options (a flat garment at
// rest, unpinned, of 2,000 vertices or more, draped for longer than fine_seconds). Throws
// InputError for bad options.
bool drapes_coarse(const Garment& garment, const DrapeOptions& options = {});

// Simulates the garment on the body for options.seconds (coarse first where DrapeOptions says).
// Throws InputError for bad options.
DrapeResult drape(Garment& garment, const Body& body, const DrapeOptions& options = {},
                  const DrapeProgress& progress = {});

}  // namespace kiji
