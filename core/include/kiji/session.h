// A design session: the scene (garments, a body, their solvers), the tools, the clock and the
// journal. Every change to the garments by a tool enters here as a ToolEvent, is applied, and is
// journaled; undo, redo and replay are built on that.
#pragma once

#include "kiji/body.h"
#include "kiji/garment.h"
#include "kiji/journal.h"
#include "kiji/plugin_loader.h"
#include "kiji/solver.h"
#include "kiji/tool.h"

#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace kiji {

class Session {
 public:
  // A session with the tools of `registry` (shared, so several sessions can use one set of loaded
  // plugins); a new registry that loads the plugins on the default search path if null.
  explicit Session(std::shared_ptr<ToolRegistry> registry = nullptr);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  // --- scene ---
  std::size_t add_garment(Garment garment);  // returns its index
  std::size_t garment_count() const { return garments_.size(); }
  Garment& garment(std::size_t index);
  const Garment& garment(std::size_t index) const;
  void set_body(std::optional<Body> body);
  const Body* body() const { return body_ ? &*body_ : nullptr; }
  // The solver of one garment (each garment has its own, with the session's solver parameters).
  Solver& solver(std::size_t garment);
  const SolverParams& solver_params() const { return solver_params_; }
  void set_solver_params(const SolverParams& params);  // validates; applies to every garment

  // --- clock and simulation ---
  double time() const { return time_; }
  double frame_rate() const { return frame_rate_; }
  void set_frame_rate(double steps_per_second);  // 1..10000
  // One simulation step of every garment (1 / frame_rate seconds).
  void step();
  // Steps until the clock reaches t (nothing if it already has).
  void advance_to(double t);
  // Whether the simulation runs at all (a paused session still applies tool edits).
  bool simulating = true;

  // --- picking ---
  // The cloth under a pointer: the nearest surface point within `radius` of `position`, or where
  // the ray from `position` along `ray` (when non-zero) first meets the cloth.
  SurfaceHit pick(const Vec3& position, const Vec3& ray = Vec3::Zero()) const;
  double pick_radius = 0.05;  // metres

  // --- tools ---
  ToolRegistry& tools() { return *registry_; }
  const ToolRegistry& tools() const { return *registry_; }
  // Checked parameter values for a tool: its defaults overridden by `values`.
  ParamSet params_for(const std::string& tool, const std::map<std::string, ParamValue>& values = {}) const;

  // The one path every tool event takes: advances the clock to the event's time, fills in the
  // surface hit, calls the tool, and journals it. Begin starts a stroke (snapshotting the garments),
  // End finishes and journals it, Cancel restores the garments. If the tool throws, the garments
  // are restored to where the stroke began and the error is rethrown: nothing is half-applied.
  // `params` is required for Begin and ignored after it.
  Feedback apply(Tool& tool, const ToolEvent& event, const ParamSet* params = nullptr);
  Feedback apply(const std::string& tool, const ToolEvent& event, const ParamSet* params = nullptr);
  // A whole recorded stroke through apply(); the stroke must start with Begin.
  void run(Tool& tool, const ParamSet& params, const Stroke& stroke);
  void run(const std::string& tool, const ParamSet& params, const Stroke& stroke);
  bool stroke_active() const { return active_ != nullptr; }
  const std::string& active_tool() const;
  // The tool instance the session uses for an id (created on first use).
  Tool& tool(const std::string& id);

  // --- journal ---
  const Journal& journal() const { return journal_; }
  bool undo();  // restores the garments as they were before the last stroke; false if none
  bool redo();

  // --- threads ---
  // A session is used by one thread at a time. Code that shares one between threads (an app's
  // simulation thread and its script console, Python with the GIL released) holds this lock for
  // each use; it is recursive so that a holder may call code that takes it again. The haptic
  // thread never takes it: it reads only published snapshots.
  std::recursive_mutex& mutex() const { return mutex_; }

 private:
  struct ActiveStroke;
  std::vector<Garment> snapshot() const;
  void restore(const std::vector<Garment>& garments);

  std::shared_ptr<ToolRegistry> registry_;
  std::vector<Garment> garments_;
  std::vector<std::unique_ptr<Solver>> solvers_;
  std::optional<Body> body_;
  SolverParams solver_params_;
  double time_ = 0;
  double frame_rate_ = 60;
  std::map<std::string, std::unique_ptr<Tool>> tool_instances_;
  std::unique_ptr<ActiveStroke> active_;
  Journal journal_;
  mutable std::recursive_mutex mutex_;
};

}  // namespace kiji
