#include "session/stroke_context.h"

#include "kiji/error.h"

namespace kiji {

int StrokeContext::attach(std::size_t garment, Vertex v, const Vec3& target, double stiffness, bool firm) {
  const Garment& g = session_.garment(garment);
  if (!g.mesh().has_valid_index(v) || g.mesh().is_removed(v))
    throw InputError("a hand on garment " + std::to_string(garment) + " takes vertex " + std::to_string(v.idx()) +
                     ", which the garment does not have");
  return session_.solver(garment).add_attachment(v, target, stiffness, firm);
}

void StrokeContext::move(std::size_t garment, int hand, const Vec3& target) {
  session_.solver(garment).move_attachment(hand, target);
}

void StrokeContext::release(std::size_t garment, int hand) { session_.solver(garment).remove_attachment(hand); }

void StrokeContext::add_force(std::size_t garment, Vertex v, const Vec3& force) {
  const Garment& g = session_.garment(garment);
  if (!g.mesh().has_valid_index(v) || g.mesh().is_removed(v))
    throw InputError("a force on garment " + std::to_string(garment) + " pushes vertex " + std::to_string(v.idx()) +
                     ", which the garment does not have");
  if (!all_finite(force)) throw InputError("a force on the cloth is not finite");
  session_.solver(garment).add_external_force(v, force);
}

void StrokeContext::set_local_region(std::size_t garment, const Vec3& centre, double radius) {
  Solver& solver = session_.solver(garment);
  SolverParams p = solver.params();
  p.local_radius = radius;
  p.local_center = centre;
  solver.set_params(p);  // validates: a radius below 0, or anything not finite, is refused
}

void StrokeContext::end_local_region(std::size_t garment) {
  Solver& solver = session_.solver(garment);
  SolverParams p = solver.params();
  p.local_radius = session_.solver_params().local_radius;
  p.local_center = session_.solver_params().local_center;
  solver.set_params(p);
}

}  // namespace kiji
