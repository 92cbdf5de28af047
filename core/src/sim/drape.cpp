#include "kiji/drape.h"

#include "kiji/error.h"

#include <chrono>
#include <cmath>
#include <sstream>

namespace kiji {

void place_over_body(Garment& garment, const Body& body, double clearance) {
  if (garment.mesh().is_empty()) throw InputError("place_over_body: the garment has no vertices");
  const Box3 pattern = garment.bounds();
  // Pattern x -> world x, pattern y -> world -z, pattern z -> world y: the cloth lies flat, facing up.
  Eigen::Matrix3d r;
  r << 1, 0, 0,
       0, 0, 1,
       0, -1, 0;
  const Vec3 pattern_centre = pattern.center();
  // Centred over the head and shoulders (the body's top quarter), which carry the cloth: the whole
  // body's box is off centre wherever hands, feet or a pose reach further one way, and a cloth
  // centred on it hangs longer on that side.
  const Box3 box = body.bounds();
  Box3 shoulders;
  const double quarter = box.max().y() - 0.25 * box.sizes().y();
  for (const Vec3& p : body.vertices())
    if (p.y() >= quarter) shoulders.extend(p);
  const Vec3 c = shoulders.center();
  // The highest body point under the cloth's footprint.
  const double half_x = 0.5 * pattern.sizes().x(), half_z = 0.5 * pattern.sizes().y();
  double top = box.min().y();
  for (const Vec3& p : body.vertices())
    if (std::abs(p.x() - c.x()) <= half_x && std::abs(p.z() - c.z()) <= half_z) top = std::max(top, p.y());
  if (top == box.min().y()) top = box.max().y();
  const Vec3 target(c.x(), top + clearance + garment.material().thickness, c.z());
  Eigen::Affine3d t = Eigen::Translation3d(target) * Eigen::Affine3d(r) * Eigen::Translation3d(-pattern_centre);
  garment.transform(t);
  for (Vertex v : garment.mesh().vertices()) garment.velocity(v) = Vec3::Zero();
}

void DrapeOptions::validate() const {
  if (!std::isfinite(seconds) || seconds <= 0 || seconds > 3600) {
    std::ostringstream msg;
    msg << "drape seconds is " << seconds << ": give a simulated time between 0 and 3600 seconds";
    throw InputError(msg.str());
  }
  if (!std::isfinite(frame_rate) || frame_rate < 1 || frame_rate > 10000) {
    std::ostringstream msg;
    msg << "drape frame rate is " << frame_rate << ": give 1 to 10000 steps a second";
    throw InputError(msg.str());
  }
  solver.validate();
}

DrapeResult drape(Garment& garment, const Body& body, const DrapeOptions& options,
                  const DrapeProgress& progress) {
  options.validate();
  garment.validate();
  Solver solver(options.solver);
  solver.set_body(&body);
  const double dt = 1.0 / options.frame_rate;
  const auto steps = static_cast<std::size_t>(std::llround(options.seconds * options.frame_rate));
  DrapeResult result;
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < steps; ++i) {
    solver.step(garment, dt);
    ++result.steps;
    result.seconds_simulated += dt;
    if (progress && !progress(double(i + 1) / double(steps))) break;
  }
  result.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.measures = solver.measure(garment);
  return result;
}

}  // namespace kiji
