#include "kiji/session.h"

#include "base/overloaded.h"
#include "kiji/drape.h"
#include "kiji/error.h"
#include "kiji/pick.h"
#include "kiji/topology.h"

#include "base/byte_io.h"
#include "session/stroke_context.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

namespace kiji {

namespace {

using detail::Overloaded;

std::shared_ptr<const std::string> shared_bytes(std::string bytes) {
  return std::make_shared<const std::string>(std::move(bytes));
}

ToolEvent phase_event(Phase phase, double time) {
  ToolEvent e;
  e.phase = phase;
  e.time = time;
  return e;
}

}  // namespace

struct Session::ActiveStroke {
  Tool* tool = nullptr;
  std::string id;
  ParamSet params;
  JournalEntry entry;
};

Session::Session(std::shared_ptr<ToolRegistry> registry) : registry_(std::move(registry)) {
  if (!registry_) {
    registry_ = std::make_shared<ToolRegistry>();
    registry_->load_plugins();
  }
}

Session::~Session() = default;

// --- scene ---

std::size_t Session::add_garment(const Garment& garment) {
  garment.validate();
  const std::size_t index = garments_.size();
  submit({steps_, 0, op::AddGarment{shared_bytes(encode_garment(garment))}});
  return index;
}

void Session::remove_garment(std::size_t index) {
  this->garment(index);
  submit({steps_, 0, op::RemoveGarment{static_cast<std::uint32_t>(index)}});
}

void Session::set_garment(std::size_t index, const Garment& garment) {
  this->garment(index);
  garment.validate();
  submit({steps_, 0, op::SetGarment{static_cast<std::uint32_t>(index), shared_bytes(encode_garment(garment))}});
}

Garment& Session::garment(std::size_t index) {
  if (index >= garments_.size())
    throw InputError("garment " + std::to_string(index) + " does not exist: the session has " +
                     std::to_string(garments_.size()));
  return garments_[index];
}

const Garment& Session::garment(std::size_t index) const { return const_cast<Session*>(this)->garment(index); }

void Session::set_body(std::optional<Body> body) {
  op::SetBody b;
  if (body) b.body = shared_bytes(encode_body(*body));
  submit({steps_, 0, std::move(b)});
}

Solver& Session::solver(std::size_t index) {
  garment(index);
  return *solvers_[index];
}

const Solver& Session::solver(std::size_t index) const { return const_cast<Session*>(this)->solver(index); }

void Session::set_solver_params(const SolverParams& params) {
  params.validate();
  submit({steps_, 0, op::SetSolverParams{params}});
}

void Session::set_frame_rate(double steps_per_second) {
  if (!std::isfinite(steps_per_second) || steps_per_second < 1 || steps_per_second > 10000) {
    std::ostringstream msg;
    msg << "frame rate " << steps_per_second << " is out of range: use 1 to 10000 steps a second";
    throw InputError(msg.str());
  }
  submit({steps_, 0, op::SetFrameRate{steps_per_second}});
}

void Session::set_simulating(bool simulating) { submit({steps_, 0, op::SetSimulating{simulating}}); }

void Session::set_pick_radius(double metres) {
  if (!std::isfinite(metres) || metres <= 0 || metres > 10) {
    std::ostringstream msg;
    msg << "pick radius " << metres << " m is out of range: use more than 0 and at most 10 m";
    throw InputError(msg.str());
  }
  submit({steps_, 0, op::SetPickRadius{metres}});
}

// --- clock ---

void Session::step() {
  if (gate_)
    throw InputError("this session is shared with peers: its clock is the shared one, stepped by the peer; "
                     "wait for time to pass through the peer instead");
  simulate_step();
}

void Session::step(const void* owner) {
  if (gate_ && owner != gate_owner_) step();
  simulate_step();
}

void Session::simulate_step() {
  const double dt = 1.0 / frame_rate_;
  if (simulating_)
    for (std::size_t i = 0; i < garments_.size(); ++i) {
      solvers_[i]->step(garments_[i], dt);
      sew_met_tacks(i);
    }
  time_ += dt;
  ++steps_;
}

void Session::sew_met_tacks(std::size_t i) {
  Garment& g = garments_[i];
  if (g.tacks.empty()) return;
  // Met within three quarters of the cloth's spacing at the seam (at least twice the cloth's
  // thickness): the cloth's own collision and the body keep some pairs a little apart, and the last
  // step to sew them is then shorter than an edge. The spacing is the median rest length of the
  // edges at the tacked vertices, not of the border's: a seam between borders of unequal spacing is
  // tacked at both sides' vertices, whose border edges are then a fraction of the cloth's.
  std::vector<double> lengths;
  for (const auto& [a, b] : g.tacks)
    for (Vertex v : {a, b})
      for (Halfedge h : CGAL::halfedges_around_target(g.mesh().halfedge(v), g.mesh()))
        lengths.push_back(g.rest_length(g.mesh().edge(h)));
  auto middle = lengths.begin() + std::ptrdiff_t(lengths.size() / 2);
  std::nth_element(lengths.begin(), middle, lengths.end());
  const double spacing = *middle;
  const double within = std::max(2 * g.material().thickness, 0.75 * spacing);
  // The pairs that have met (tack_met: a seam's last pair from twice as far), as a key: the same
  // pairs on the same mesh, found nothing to sew before, would find nothing again (what is sewn
  // depends on which pairs met and on the mesh alone).
  std::size_t met = 0;
  std::uint64_t key = 1469598103934665603ull;
  for (const auto& [a, b] : g.tacks)
    if (tack_met(g, a, b, within)) {
      ++met;
      for (std::uint64_t x : {std::uint64_t(a.idx()), std::uint64_t(b.idx())}) key = (key ^ x) * 1099511628211ull;
    }
  if (met == 0) return;
  if (tacks_tried_.size() <= i) tacks_tried_.resize(i + 1);
  const std::pair<std::uint64_t, std::uint64_t> tried{g.topology_version(), key};
  if (tacks_tried_[i] == tried) return;
  if (close_tacks(g, within) == 0) tacks_tried_[i] = tried;
}

std::vector<DrapeResult> Session::drape(double seconds, const std::function<bool(double)>& progress, bool place,
                                        double clearance, bool coarse) {
  if (place && !body_) throw InputError("drape: the session has no body to lay the garments over: set one first");
  if (!std::isfinite(seconds) || seconds < 0 || seconds > max_advance_seconds)
    throw InputError("drape: seconds must be from 0 to 3600");
  if (place)
    for (std::size_t i = 0; i < garments_.size(); ++i) {
      Garment g = garments_[i];
      place_over_body(g, *body_, clearance);
      set_garment(i, g);
    }
  const SolverParams own = solver_params_;
  SolverParams draping = own;
  draping.substeps = std::max(own.substeps, DrapeOptions{}.solver.substeps);
  DrapeOptions options;
  options.seconds = seconds;
  options.frame_rate = frame_rate_;
  options.solver = draping;
  const auto start = std::chrono::steady_clock::now();
  std::vector<DrapeResult> results(garments_.size());

  bool all_coarse = coarse && seconds > 0 && body_ && !garments_.empty();
  for (std::size_t i = 0; all_coarse && i < garments_.size(); ++i) all_coarse = drapes_coarse(garments_[i], options);
  if (all_coarse) {
    // Each garment has a solver of its own in the session, so each drapes alone as it would fall here.
    // All are draped before any is set, so that a refusal changes nothing.
    std::vector<Garment> draped(garments_.begin(), garments_.end());
    bool stopped = false;
    for (std::size_t i = 0; i < draped.size() && !stopped; ++i)
      results[i] = kiji::drape(draped[i], *body_, options, [&](double f) {
        stopped = progress && !progress((double(i) + f) / double(draped.size()));
        return !stopped;
      });
    for (std::size_t i = 0; i < draped.size(); ++i)
      if (results[i].seconds_simulated > 0) set_garment(i, draped[i]);
    return results;
  }

  const bool paused = !simulating_;
  set_solver_params(draping);
  if (paused) set_simulating(true);
  auto restore = [&] {
    set_solver_params(own);
    if (paused) set_simulating(false);
  };
  std::size_t taken = 0;
  try {
    const auto steps = static_cast<std::size_t>(std::llround(seconds * frame_rate_));
    for (std::size_t i = 0; i < steps; ++i) {
      step();
      ++taken;
      if (progress && !progress(double(i + 1) / double(steps))) break;
    }
  } catch (...) {
    restore();
    throw;
  }
  restore();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (std::size_t i = 0; i < garments_.size(); ++i) {
    results[i].seconds_simulated = double(taken) / frame_rate_;
    results[i].wall_seconds = wall;
    results[i].steps = taken;
    results[i].measures = solvers_[i]->measure(garments_[i]);
  }
  return results;
}

void Session::advance_to(double t) {
  if (!std::isfinite(t)) throw InputError("event time is not a finite number");
  if (t - time_ > max_advance_seconds) {
    std::ostringstream msg;
    msg << "time " << t << " s is " << (t - time_) << " s after the session's clock (" << time_
        << " s): the clock steps at most " << max_advance_seconds << " s ahead at once";
    throw InputError(msg.str());
  }
  // A small tolerance so that t = n / frame_rate does not take an extra step to rounding.
  while (time_ + kClockTolerance < t) simulate_step();
}

void Session::advance_to_step(std::uint64_t step) {
  if (step < steps_)
    throw InputError("an operation for step " + std::to_string(step) + " came when the session is at step " +
                     std::to_string(steps_) + ": operations apply in the order they were made");
  if (double(step - steps_) > max_advance_seconds * frame_rate_)
    throw InputError("an operation for step " + std::to_string(step) + " is more than " +
                     std::to_string(int(max_advance_seconds)) + " s after the session's step " +
                     std::to_string(steps_));
  while (steps_ < step) simulate_step();
}

void Session::check_event(const op::ToolInput& input) const {
  try {
    check_tool_event(input.event);
  } catch (const InputError& e) {
    throw InputError("a '" + input.tool + "' event was refused: " + e.what());
  }
  // The clock moves a step at a time, so events a device samples faster than that come within the
  // step just taken; one before it belongs to a step that has passed, and would rewrite the past.
  const double step_before = time_ - 1.0 / frame_rate_;
  if (input.event.time < step_before - kClockTolerance) {
    std::ostringstream msg;
    msg << "a '" << input.tool << "' event was refused: its time " << input.event.time
        << " s is before the session's clock (" << time_ << " s, and its last step began at " << step_before
        << " s): an event comes at the clock's time or later";
    throw InputError(msg.str());
  }
}

// --- picking and tools ---

SurfaceHit Session::pick(const Vec3& position, const Vec3& ray) const {
  return kiji::pick(garments_, position, ray, pick_radius_);
}

ParamSet Session::params_for(const std::string& tool_id, const std::map<std::string, ParamValue>& values) const {
  ParamSet p(registry_->info(tool_id).parameters);
  for (const auto& [name, value] : values) p.set(name, value);
  return p;
}

Tool& Session::tool(const std::string& id, UserId user) {
  const auto key = std::make_pair(user, id);
  auto it = tool_instances_.find(key);
  if (it != tool_instances_.end()) return *it->second;
  auto created = registry_->create(id);
  Tool& t = *created;
  tool_instances_.emplace(key, std::move(created));
  return t;
}

std::vector<UserId> Session::active_users() const {
  std::vector<UserId> out;
  for (const auto& [user, stroke] : active_) out.push_back(user);
  return out;
}

const std::string& Session::stroke_tool(UserId user) const {
  static const std::string none;
  if (!gate_) return active_tool(user);
  auto p = proposed_.find(user);
  return p != proposed_.end() ? p->second : none;
}

const std::string& Session::active_tool(UserId user) const {
  static const std::string none;
  auto it = active_.find(user);
  return it != active_.end() ? it->second->id : none;
}

GarmentSnapshot Session::snapshot() const { return GarmentSnapshot(garments_, journal_.latest_snapshot()); }

void Session::restore(const GarmentSnapshot& snapshot) {
  // Assignment gives every garment a fresh topology version, so every solver rebuilds its arrays. A
  // different number of garments gets new solvers throughout: each solver's arrays follow its index.
  const bool same_count = snapshot.size() == garments_.size();
  garments_ = snapshot.garments();
  if (!same_count) {
    solvers_.clear();
    for (std::size_t i = 0; i < garments_.size(); ++i) solvers_.push_back(std::make_unique<Solver>(solver_params_));
  }
  for (auto& s : solvers_) s->set_body(body());
}

Feedback Session::apply(const std::string& tool_id, const ToolEvent& event, const ParamSet* params, UserId user) {
  return apply(tool(tool_id, user), event, params, user);
}

Feedback Session::apply(Tool& tool, const ToolEvent& event, const ParamSet* params, UserId user) {
  op::ToolInput input;
  input.tool = tool.info().id;
  input.event = event;
  input.event.hit = SurfaceHit{};
  if (event.phase == Phase::Begin && params) input.params = params->values();
  if (gate_) {
    const ToolEvent& e = input.event;
    check_event(input);
    if (e.phase == Phase::Begin && !params) throw InputError("a '" + input.tool + "' stroke begins without parameters");
    const double ahead = std::max(0.0, e.time - time_);
    if (ahead > max_advance_seconds) advance_to(e.time);  // throws, saying why
    if (e.phase == Phase::Begin) proposed_[user] = input.tool;
    if (e.phase == Phase::End || e.phase == Phase::Cancel) proposed_.erase(user);
    submit({steps_ + static_cast<std::uint64_t>(std::ceil(ahead * frame_rate_ - 1e-9)), user, std::move(input)});
    return {};
  }
  return do_tool(tool, input, params, user, /*rethrow=*/true);
}

Feedback Session::do_tool(Tool& tool, const op::ToolInput& input, const ParamSet* params, UserId user, bool rethrow) {
  const std::string& id = input.tool;
  const ToolEvent& in = input.event;
  check_event(input);
  auto it = active_.find(user);
  if (in.phase == Phase::Begin) {
    if (it != active_.end())
      throw InputError("a '" + it->second->id + "' stroke is in progress: end or cancel it before starting '" + id + "'");
    if (!params) throw InputError("a '" + id + "' stroke begins without parameters");
  } else {
    if (it == active_.end())
      throw InputError(std::string("a '") + phase_name(in.phase) + "' event for '" + id +
                       "' came without a stroke: a stroke starts with a begin event");
    if (it->second->tool != &tool) throw InputError("a '" + id + "' event came during a '" + it->second->id + "' stroke");
  }
  if (in.time > time_) advance_to(in.time);
  ToolEvent event = in;
  event.hit = pick(event.position, event.ray);
  Operation logged{steps_, user, input};

  StrokeContext context(*this);
  if (event.phase == Phase::Cancel) {
    auto stroke = std::move(it->second);
    active_.erase(it);
    try {
      tool.cancel(context);
    } catch (...) {  // the garments go back all the same
    }
    restore(stroke->entry.before);
    log(std::move(logged));
    return {};
  }
  if (event.phase == Phase::Begin) {
    auto stroke = std::make_unique<ActiveStroke>();
    stroke->tool = &tool;
    stroke->id = id;
    stroke->params = *params;
    stroke->entry.tool = id;
    stroke->entry.user = user;
    stroke->entry.params = params->values();
    stroke->entry.before = snapshot();
    it = active_.emplace(user, std::move(stroke)).first;
  }
  ActiveStroke& active = *it->second;
  active.entry.events.push_back(event);
  Feedback feedback;
  last_tool_error_.clear();
  try {
    switch (event.phase) {
      case Phase::Begin: feedback = tool.begin(context, active.params, event); break;
      case Phase::Move: feedback = tool.update(context, event); break;
      case Phase::End: tool.end(context, event); break;
      case Phase::Cancel: break;
    }
  } catch (...) {
    // Nothing half-applied: the garments go back to where the stroke began. The event is logged all
    // the same: replayed, it fails again and is undone again, so the replay takes the same path.
    auto stroke = std::move(it->second);
    active_.erase(it);
    try {
      tool.cancel(context);
    } catch (...) {
    }
    restore(stroke->entry.before);
    log(std::move(logged));
    if (rethrow) throw;
    try {
      throw;
    } catch (const std::exception& e) {
      last_tool_error_ = std::string("the '") + id + "' stroke failed and was undone: " + e.what();
    } catch (...) {
      last_tool_error_ = "the '" + id + "' stroke failed and was undone";
    }
    return {};
  }
  if (event.phase == Phase::End) {
    auto stroke = std::move(it->second);
    active_.erase(it);
    stroke->entry.after = snapshot();
    journal_.push(std::move(stroke->entry));
  }
  log(std::move(logged));
  return feedback;
}

void Session::run(const std::string& tool_id, const ParamSet& params, const Stroke& stroke, UserId user) {
  run(tool(tool_id, user), params, stroke, user);
}

void Session::run(Tool& tool, const ParamSet& params, const Stroke& stroke, UserId user) {
  if (stroke.empty() || stroke.front().phase != Phase::Begin)
    throw InputError("a stroke for '" + tool.info().id + "' must start with a begin event");
  if (gate_) {  // the whole stroke goes to the gate, to be applied in its turn
    for (const ToolEvent& e : stroke) apply(tool, e, &params, user);
    if (stroke.back().phase != Phase::End && stroke.back().phase != Phase::Cancel) {
      ToolEvent end = stroke.back();
      end.phase = Phase::End;
      apply(tool, end, &params, user);
    }
    return;
  }
  for (const ToolEvent& e : stroke) {
    apply(tool, e, &params, user);
    if (!stroke_active(user)) return;  // an End or Cancel closed it
  }
  // A stroke that stops without End or Cancel is finished, as a released button would.
  ToolEvent end = stroke.back();
  end.phase = Phase::End;
  apply(tool, end, &params, user);
}

void Session::cancel_all_strokes() {
  // Applied here and now, gate or no gate: these cancels are part of the operation being applied.
  while (!active_.empty()) {
    const auto& [user, stroke] = *active_.begin();
    op::ToolInput cancel{stroke->id, {}, phase_event(Phase::Cancel, time_)};
    do_tool(*stroke->tool, cancel, nullptr, user, /*rethrow=*/true);
  }
}

// --- operations ---

Feedback Session::perform(const Operation& operation) {
  check_operation(operation);
  const auto* checkpoint = std::get_if<op::Checkpoint>(&operation.data);
  if (!checkpoint || !checkpoint->state) advance_to_step(operation.step);  // a given state sets the clock
  const UserId user = operation.user;
  return std::visit(
      Overloaded{
          [&](const op::ToolInput& t) -> Feedback {
            if (t.event.phase == Phase::Begin) {
              const ParamSet params = params_for(t.tool, t.params);
              return do_tool(tool(t.tool, user), t, &params, user, /*rethrow=*/false);
            }
            return do_tool(tool(t.tool, user), t, nullptr, user, /*rethrow=*/false);
          },
          [&](const op::AddGarment& a) -> Feedback {
            if (!a.garment) throw InputError("an add_garment operation carries no garment");
            Garment g = decode_garment(*a.garment);
            JournalEntry entry{"add_garment", user, {}, {}, snapshot(), {}};
            garments_.push_back(std::move(g));
            solvers_.push_back(std::make_unique<Solver>(solver_params_));
            solvers_.back()->set_body(body());
            entry.after = snapshot();
            journal_.push(std::move(entry));
            log(operation);
            return {};
          },
          [&](const op::RemoveGarment& r) -> Feedback {
            garment(r.index);
            cancel_all_strokes();
            JournalEntry entry{"remove_garment", user, {}, {}, snapshot(), {}};
            garments_.erase(garments_.begin() + r.index);
            solvers_.clear();
            for (std::size_t i = 0; i < garments_.size(); ++i) {
              solvers_.push_back(std::make_unique<Solver>(solver_params_));
              solvers_.back()->set_body(body());
            }
            entry.after = snapshot();
            journal_.push(std::move(entry));
            log(operation);
            return {};
          },
          [&](const op::SetGarment& s) -> Feedback {
            garment(s.index);
            if (!s.garment) throw InputError("a set_garment operation carries no garment");
            Garment g = decode_garment(*s.garment);
            JournalEntry entry{"set_garment", user, {}, {}, snapshot(), {}};
            garments_[s.index] = std::move(g);
            entry.after = snapshot();
            journal_.push(std::move(entry));
            log(operation);
            return {};
          },
          [&](const op::SetBody& b) -> Feedback {
            // A new object for every body, so that a solver never mistakes it for the one it had.
            std::shared_ptr<const Body> body = b.body ? std::make_shared<const Body>(decode_body(*b.body)) : nullptr;
            for (auto& s : solvers_) s->set_body(body.get());
            body_ = std::move(body);
            log(operation);
            return {};
          },
          [&](const op::SetSolverParams& p) -> Feedback {
            p.params.validate();
            for (auto& s : solvers_) s->set_params(p.params);
            solver_params_ = p.params;
            log(operation);
            return {};
          },
          [&](const op::SetFrameRate& f) -> Feedback {
            if (!std::isfinite(f.steps_per_second) || f.steps_per_second < 1 || f.steps_per_second > 10000)
              throw InputError("a set_frame_rate operation is out of range: 1 to 10000 steps a second");
            frame_rate_ = f.steps_per_second;
            log(operation);
            return {};
          },
          [&](const op::SetSimulating& s) -> Feedback {
            simulating_ = s.simulating;
            log(operation);
            return {};
          },
          [&](const op::SetPickRadius& p) -> Feedback {
            if (!std::isfinite(p.radius) || p.radius <= 0 || p.radius > 10)
              throw InputError("a set_pick_radius operation is out of range: more than 0 and at most 10 m");
            pick_radius_ = p.radius;
            log(operation);
            return {};
          },
          [&](const op::Undo&) -> Feedback {
            cancel_all_strokes();
            if (!journal_.can_undo()) return {};
            restore(journal_.undo().before);
            log(operation);
            return {};
          },
          [&](const op::Redo&) -> Feedback {
            cancel_all_strokes();
            if (!journal_.can_redo()) return {};
            restore(journal_.redo().after);
            log(operation);
            return {};
          },
          [&](const op::Advance&) -> Feedback {
            log(operation);
            return {};
          },
          [&](const op::Checkpoint& c) -> Feedback {
            if (!c.state) cancel_all_strokes();
            const std::string own = c.state ? std::string() : encode_state();
            load_state(c.state ? std::string_view(*c.state) : std::string_view(own));
            log(operation);
            return {};
          }},
      operation.data);
}

std::string Session::encode_state() const {
  // The clock, then the settings and the scene as the operations that would make them.
  detail::ByteWriter w;
  w.u16(kOperationFormatVersion);
  w.u64(steps_);
  w.f64(time_);
  std::vector<Operation> ops = {{steps_, 0, op::SetFrameRate{frame_rate_}},
                                {steps_, 0, op::SetSimulating{simulating_}},
                                {steps_, 0, op::SetPickRadius{pick_radius_}},
                                {steps_, 0, op::SetSolverParams{solver_params_}}};
  op::SetBody b;
  if (body_) b.body = shared_bytes(encode_body(*body_));
  ops.push_back({steps_, 0, std::move(b)});
  for (const Garment& g : garments_) ops.push_back({steps_, 0, op::AddGarment{shared_bytes(encode_garment(g))}});
  w.u32(static_cast<std::uint32_t>(ops.size()));
  for (const Operation& op : ops) w.bytes(encode_operation(op));
  return w.take();
}

void Session::load_state(std::string_view state) {
  // Everything is read and built before anything of this session changes.
  detail::ByteReader r(state, "session state");
  const std::uint16_t version = r.u16();
  if (version == 0 || version > kOperationFormatVersion)
    r.fail("version " + std::to_string(version) + "; this Kiji reads 1 to " + std::to_string(kOperationFormatVersion));
  const std::uint64_t steps = r.u64();
  const double time = r.finite("the clock");
  const std::size_t n = r.count(1u << 20, 8, "the number of parts");
  double frame_rate = 60, pick_radius = 0.05;
  bool simulating = true;
  SolverParams params;
  std::shared_ptr<const Body> body;
  std::vector<Garment> garments;
  for (std::size_t i = 0; i < n; ++i) {
    const Operation op = decode_operation(r.bytes(r.left(), "a part"));
    std::visit(Overloaded{[&](const op::SetFrameRate& f) { frame_rate = f.steps_per_second; },
                          [&](const op::SetSimulating& s) { simulating = s.simulating; },
                          [&](const op::SetPickRadius& p) { pick_radius = p.radius; },
                          [&](const op::SetSolverParams& p) { params = p.params; },
                          [&](const op::SetBody& b) {
                            body = b.body ? std::make_shared<const Body>(decode_body(*b.body)) : nullptr;
                          },
                          [&](const op::AddGarment& a) {
                            if (!a.garment) throw InputError("session state: a garment is missing");
                            garments.push_back(decode_garment(*a.garment));
                          },
                          [&](const auto&) { throw InputError("session state: a part is not a setting or a garment"); }},
               op.data);
  }
  if (!(frame_rate >= 1 && frame_rate <= 10000) || !(pick_radius > 0 && pick_radius <= 10))
    throw InputError("session state: a setting is out of range");
  // Strokes in progress end (their tools let go of what they hold), and the tools start afresh.
  StrokeContext context(*this);
  for (auto& [user, stroke] : active_) {
    try {
      stroke->tool->cancel(context);
    } catch (...) {
    }
  }
  active_.clear();
  tool_instances_.clear();
  steps_ = steps;
  time_ = time;
  frame_rate_ = frame_rate;
  simulating_ = simulating;
  pick_radius_ = pick_radius;
  solver_params_ = params;
  garments_ = std::move(garments);
  solvers_.clear();
  for (std::size_t i = 0; i < garments_.size(); ++i) solvers_.push_back(std::make_unique<Solver>(solver_params_));
  for (auto& s : solvers_) s->set_body(body.get());
  body_ = std::move(body);
  journal_.clear_history();
}

void Session::submit(Operation op) {
  if (gate_) {
    gate_(op);
    return;
  }
  perform(op);
}

void Session::set_gate(OperationGate gate, const void* owner) {
  gate_ = std::move(gate);
  gate_owner_ = owner;
}

void Session::clear_gate() {
  proposed_.clear();
  gate_ = nullptr;
  gate_owner_ = nullptr;
}

void Session::log(Operation op) {
  journal_.record(op);
  for (auto& [id, listener] : listeners_) listener(journal_.operations().back());
}

int Session::add_listener(OperationListener listener) {
  const int id = next_listener_++;
  listeners_.emplace(id, std::move(listener));
  return id;
}

void Session::remove_listener(int id) { listeners_.erase(id); }

bool Session::undo() {
  if (gate_) {
    submit({steps_, 0, op::Undo{}});
    return journal_.can_undo();
  }
  cancel_all_strokes();
  if (!journal_.can_undo()) return false;
  perform({steps_, 0, op::Undo{}});
  return true;
}

bool Session::redo() {
  if (gate_) {
    submit({steps_, 0, op::Redo{}});
    return journal_.can_redo();
  }
  cancel_all_strokes();
  if (!journal_.can_redo()) return false;
  perform({steps_, 0, op::Redo{}});
  return true;
}

// A tool's run() is the session's run(), defined here so that tools/ does not depend on session/.
void Tool::run(Session& session, const ParamSet& params, const Stroke& stroke) {
  session.run(*this, params, stroke);
}

}  // namespace kiji
