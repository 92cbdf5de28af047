// What a tool may do during its stroke: the session as the tool's begin, update, end and cancel see
// it. A stroke is one operation of the session's journal, so a tool reads the scene and edits the
// garments in place, and holds the cloth through the solver, and nothing else: adding garments,
// undo, settings, listeners and the session's lock are the host's. Kiji's session implements it;
// `kiji.ToolSession` is the same for a tool written in Python.
#pragma once

#include "kiji/body.h"
#include "kiji/garment.h"
#include "kiji/solver.h"
#include "kiji/tool_event.h"

#include <cstddef>
#include <cstdint>

namespace kiji {

class ToolContext {
 public:
  // --- the garments: the tool edits them in place (the stroke is the operation) ---
  virtual std::size_t garment_count() const = 0;
  // Throws InputError naming the garments there are for an index out of range (as every call here
  // that takes a garment index).
  virtual Garment& garment(std::size_t index) = 0;
  virtual const Garment& garment(std::size_t index) const = 0;
  // The body the garments collide with, or nullptr.
  virtual const Body* body() const = 0;

  // --- the clock: the session's, at the event being applied ---
  virtual double time() const = 0;
  virtual std::uint64_t steps() const = 0;
  virtual double frame_rate() const = 0;

  // --- picking, as the session picks the events' hits ---
  virtual SurfaceHit pick(const Vec3& position, const Vec3& ray = Vec3::Zero()) const = 0;
  virtual double pick_radius() const = 0;

  // --- the solver of each garment: to read (parameters, the last step, measures) ---
  virtual const Solver& solver(std::size_t garment) const = 0;
  // The session's solver parameters, which every garment's solver has outside a local region.
  virtual const SolverParams& solver_params() const = 0;

  // --- hands on the cloth (see Solver::add_attachment): held until released ---
  // A zero-length spring of `stiffness` N/m from `target` to vertex `v`; returns the hand's id. A
  // firm hand wins over the strain limit (it can pull the cloth until it tears).
  virtual int attach(std::size_t garment, Vertex v, const Vec3& target, double stiffness, bool firm = false) = 0;
  virtual void move(std::size_t garment, int hand, const Vec3& target) = 0;
  // Lets go (an id no longer held is ignored). A tool releases its hands in end and cancel.
  virtual void release(std::size_t garment, int hand) = 0;
  // A force in newtons on a vertex, for the next step only.
  virtual void add_force(std::size_t garment, Vertex v, const Vec3& force) = 0;

  // --- the paper's local region: only the cloth within `radius` of `centre` moves ---
  // Until end_local_region, which gives the solver back the session's region (none, by default).
  virtual void set_local_region(std::size_t garment, const Vec3& centre, double radius) = 0;
  virtual void end_local_region(std::size_t garment) = 0;

 protected:
  ~ToolContext() = default;  // the host owns it; a tool only borrows it for a call
};

}  // namespace kiji
