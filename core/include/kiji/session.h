// A design session: the scene (garments, a body, their solvers), the tools, the clock and the
// journal. Every change enters as an Operation (kiji/operation.h): a tool event, a garment added,
// removed or edited, a new body, new solver parameters, pausing, undo. Each is applied, appended to
// the journal's log and handed to the session's listeners (autosave, peers), so that undo, replay,
// recovery and peers all see one history, and a log replayed on a new session gives the same
// garments bit for bit.
#pragma once

#include "kiji/body.h"
#include "kiji/drape.h"
#include "kiji/garment.h"
#include "kiji/journal.h"
#include "kiji/operation.h"
#include "kiji/plugin_loader.h"
#include "kiji/solver.h"
#include "kiji/tool.h"

#include <functional>
#include <map>
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

  // --- scene (each change is an operation) ---
  // Adds a garment (validated) at the end; returns its index. The session keeps the garment as its
  // binary form gives it back (encode_garment), as every replay and peer will.
  std::size_t add_garment(const Garment& garment);
  // Removes a garment; the ones after it move down one index.
  void remove_garment(std::size_t index);
  // Replaces a garment by an edited copy (validated): how a change made outside a tool (arrays
  // assigned, a piece removed, a new material, a topology edit) enters the journal.
  void set_garment(std::size_t index, const Garment& garment);
  std::size_t garment_count() const { return garments_.size(); }
  // The garment at an index. A tool changes it in place during its stroke (the stroke is the
  // operation); any other change must go through set_garment, or it is not journaled.
  Garment& garment(std::size_t index);
  const Garment& garment(std::size_t index) const;
  void set_body(std::optional<Body> body);
  const Body* body() const { return body_.get(); }
  // The solver of one garment (each garment has its own, with the session's solver parameters).
  Solver& solver(std::size_t garment);
  const Solver& solver(std::size_t garment) const;
  const SolverParams& solver_params() const { return solver_params_; }
  void set_solver_params(const SolverParams& params);  // validates; applies to every garment

  // --- clock and simulation ---
  double time() const { return time_; }
  // Simulation steps taken since the session began (paused ones included: the clock ran).
  std::uint64_t steps() const { return steps_; }
  double frame_rate() const { return frame_rate_; }
  void set_frame_rate(double steps_per_second);  // 1..10000
  // One simulation step of every garment (1 / frame_rate seconds). Not an operation: time passing
  // is what every copy of the session does by itself. Refused while a gate is set (see set_gate).
  void step();
  // Steps until the clock reaches t (nothing if it already has). Refuses a t more than
  // max_advance_seconds ahead, which would not end in any useful time.
  void advance_to(double t);
  static constexpr double max_advance_seconds = 3600;
  // Times this close are the same instant on the clock (sums of 1 / frame_rate round).
  static constexpr double kClockTolerance = 1e-9;
  // Whether time steps the cloth (false: tools still edit, nothing falls; the clock runs).
  bool simulating() const { return simulating_; }
  void set_simulating(bool simulating);
  // Lets the garments fall and settle on the body for `seconds` (0 to 3600), each laid over the
  // body first (place_over_body, when `place`), with the session's own solver settings at the
  // drape's substeps (at least DrapeOptions's).
  // - `coarse` and every garment one that kiji::drape lets fall as a coarse copy first (flat, at
  //   rest, unpinned, 2,000 vertices or more, and `seconds` over DrapeOptions::fine_seconds; a body
  //   set): each is draped so, alone on the body as the session steps it, and set back as one
  //   operation (set_garment); the clock, the settings and the pause are left as they were. A
  //   garment that starts through the body is refused (InputError) before any is changed.
  // - Otherwise the session steps: a paused session runs for it, the settings and the pause come
  //   back after, and the clock moves by `seconds`. For one garment and default settings it gives
  //   what kiji::drape gives with coarse_ratio 1, bit for bit.
  // Every change is a journaled operation. `progress` (with the fraction done) may return false to
  // stop early: the garments are left where the drape had brought them. Returns what each garment's
  // drape did. Throws InputError when `place` and there is no body (without one and not placed, the
  // garments settle under their pins).
  std::vector<DrapeResult> drape(double seconds, const std::function<bool(double)>& progress = {}, bool place = true,
                                 double clearance = 0.02, bool coarse = true);

  // --- picking ---
  // The cloth under a pointer: the nearest surface point within pick_radius() of `position`, or
  // where the ray from `position` along `ray` (when non-zero) first meets the cloth.
  SurfaceHit pick(const Vec3& position, const Vec3& ray = Vec3::Zero()) const;
  double pick_radius() const { return pick_radius_; }
  void set_pick_radius(double metres);  // (0, 10]

  // --- tools ---
  ToolRegistry& tools() { return *registry_; }
  const ToolRegistry& tools() const { return *registry_; }
  // Checked parameter values for a tool: its defaults overridden by `values`.
  ParamSet params_for(const std::string& tool, const std::map<std::string, ParamValue>& values = {}) const;

  // The one path every tool event takes: checks the event (check_tool_event, and a time not before
  // the clock), advances the clock to the event's time, fills in the
  // surface hit, calls the tool, and journals it. Each user has at most one stroke in progress and
  // its own instance of each tool. Begin starts a stroke (snapshotting the garments), End finishes
  // it (a step of the undo history), Cancel restores the garments as they were at its Begin. If the
  // tool throws, the stroke is cancelled the same way and the error rethrown: nothing is
  // half-applied. `params` is required for Begin and ignored after it.
  Feedback apply(Tool& tool, const ToolEvent& event, const ParamSet* params = nullptr, UserId user = 0);
  Feedback apply(const std::string& tool, const ToolEvent& event, const ParamSet* params = nullptr,
                 UserId user = 0);
  // A whole recorded stroke through apply(); the stroke must start with Begin.
  void run(Tool& tool, const ParamSet& params, const Stroke& stroke, UserId user = 0);
  void run(const std::string& tool, const ParamSet& params, const Stroke& stroke, UserId user = 0);
  bool stroke_active(UserId user = 0) const { return active_.count(user) > 0; }
  // Users with a stroke in progress.
  std::vector<UserId> active_users() const;
  // The tool of a user's stroke in progress, as applied ("" if none).
  const std::string& active_tool(UserId user = 0) const;
  // The same as its user sees it: while the session is shared, a stroke begun here is in progress
  // from its begin, before its turn to be applied comes.
  const std::string& stroke_tool(UserId user = 0) const;
  // The tool instance a user's strokes use for an id (created on first use).
  Tool& tool(const std::string& id, UserId user = 0);

  // --- operations ---
  // Applies an operation as the session would have made it: steps the clock to op.step first (no
  // further than max_advance_seconds), then applies it for op.user. What replay, recovery and
  // peers call. Throws InputError (and changes nothing) for an operation that cannot apply here:
  // a field out of range (check_operation, before the clock moves), a garment index that does not
  // exist, bad bytes, a tool the session does not have, an event before the clock.
  Feedback perform(const Operation& op);
  // Called after each operation is applied and logged, on the thread that applied it (autosave,
  // peers). Returns an id for remove_listener. A listener's error reaches the caller of the
  // operation, which has been applied and logged all the same.
  using OperationListener = std::function<void(const Operation&)>;
  int add_listener(OperationListener listener);
  void remove_listener(int id);
  // Why the last tool event that perform() applied failed (its stroke was cancelled), or "" if it
  // did not: perform() does not rethrow a tool's error, which a replay or a peer expects to recur.
  const std::string& last_tool_error() const { return last_tool_error_; }

  // --- journal ---
  const Journal& journal() const { return journal_; }
  // Restores the garments as they were before the last step of the undo history (a stroke, a
  // garment added, removed or set); false if none. Strokes in progress are cancelled first.
  bool undo();
  bool redo();
  // Bytes the undo history may hold (see Journal::set_history_limit).
  void set_history_limit(std::size_t bytes) { journal_.set_history_limit(bytes); }

  // --- sharing (peers) ---
  // A gate takes the changes this session's users make (every public method above that changes the
  // session, tool events, undo and redo) instead of applying them: a peer proposes them to the
  // others, and applies them in the order they all agree on with perform(). Each goes to the gate
  // checked as far as it can be without applying it, with op.step the step it asks to be applied at
  // (for a tool event, the step its time falls on). While a gate is set, the clock is the gate
  // owner's: step() from anyone else is refused.
  using OperationGate = std::function<void(const Operation&)>;
  void set_gate(OperationGate gate, const void* owner);
  void clear_gate();
  bool gated() const { return static_cast<bool>(gate_); }
  // One step, by the gate's owner (or anyone when no gate is set).
  void step(const void* owner);

  // The whole state as bytes: settings, body, garments and clock (not the undo history, strokes in
  // progress, or the log). A Checkpoint operation with these bytes makes any session this state.
  std::string encode_state() const;

  // --- threads ---
  // A session is used by one thread at a time. Code that shares one between threads (an app's
  // simulation thread and its script console, Python with the GIL released) holds this lock for
  // each use; it is recursive so that a holder may call code that takes it again. The haptic
  // thread never takes it: it reads only published snapshots.
  std::recursive_mutex& mutex() const { return mutex_; }

 private:
  struct ActiveStroke;
  void check_event(const op::ToolInput& input) const;
  GarmentSnapshot snapshot() const;
  void restore(const GarmentSnapshot& snapshot);
  void advance_to_step(std::uint64_t step);
  void log(Operation op);
  void do_add_garment(std::shared_ptr<const std::string> bytes);
  void do_set_garment(std::size_t index, std::shared_ptr<const std::string> bytes);
  void do_remove_garment(std::size_t index);
  Feedback do_tool(Tool& tool, const op::ToolInput& input, const ParamSet* params, UserId user, bool rethrow);
  void cancel_all_strokes();
  // Applies the operation, or hands it to the gate.
  void submit(Operation op);
  void load_state(std::string_view state);
  void simulate_step();
  // Sews garment i's tacks that the step drew together (close_tacks), as a seam closes.
  void sew_met_tacks(std::size_t i);

  std::shared_ptr<ToolRegistry> registry_;
  std::vector<Garment> garments_;
  std::vector<std::unique_ptr<Solver>> solvers_;
  // Per garment: the mesh and the met pairs close_tacks last found nothing to sew in.
  std::vector<std::pair<std::uint64_t, std::uint64_t>> tacks_tried_;
  std::shared_ptr<const Body> body_;
  SolverParams solver_params_;
  double time_ = 0;
  std::uint64_t steps_ = 0;
  double frame_rate_ = 60;
  bool simulating_ = true;
  double pick_radius_ = 0.05;
  std::map<std::pair<UserId, std::string>, std::unique_ptr<Tool>> tool_instances_;
  std::map<UserId, std::unique_ptr<ActiveStroke>> active_;
  Journal journal_;
  std::map<int, OperationListener> listeners_;
  OperationGate gate_;
  std::string last_tool_error_;
  const void* gate_owner_ = nullptr;
  // While shared: the strokes this session's users began and have not ended, applied or not yet.
  std::map<UserId, std::string> proposed_;
  int next_listener_ = 0;
  mutable std::recursive_mutex mutex_;
};

}  // namespace kiji
