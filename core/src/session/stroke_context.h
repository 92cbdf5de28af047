// The session as a tool sees it during a call of its stroke (kiji/tool_context.h): the session's
// garments, body, clock and picking, and hands on its solvers. Made by Session for each call.
#pragma once

#include "kiji/session.h"
#include "kiji/tool_context.h"

namespace kiji {

class StrokeContext final : public ToolContext {
 public:
  explicit StrokeContext(Session& session) : session_(session) {}

  std::size_t garment_count() const override { return session_.garment_count(); }
  Garment& garment(std::size_t index) override { return session_.garment(index); }
  const Garment& garment(std::size_t index) const override { return session_.garment(index); }
  const Body* body() const override { return session_.body(); }

  double time() const override { return session_.time(); }
  std::uint64_t steps() const override { return session_.steps(); }
  double frame_rate() const override { return session_.frame_rate(); }

  SurfaceHit pick(const Vec3& position, const Vec3& ray) const override { return session_.pick(position, ray); }
  double pick_radius() const override { return session_.pick_radius(); }

  const Solver& solver(std::size_t garment) const override { return session_.solver(garment); }
  const SolverParams& solver_params() const override { return session_.solver_params(); }

  int attach(std::size_t garment, Vertex v, const Vec3& target, double stiffness, bool firm) override;
  void move(std::size_t garment, int hand, const Vec3& target) override;
  void release(std::size_t garment, int hand) override;
  void add_force(std::size_t garment, Vertex v, const Vec3& force) override;

  void set_local_region(std::size_t garment, const Vec3& centre, double radius) override;
  void end_local_region(std::size_t garment) override;

 private:
  Session& session_;
};

}  // namespace kiji
