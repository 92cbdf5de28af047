#include "kiji/session.h"

#include "geometry.h"
#include "kiji/error.h"
#include "parallel.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

namespace kiji {

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

std::size_t Session::add_garment(Garment garment) {
  garment.validate();
  garments_.push_back(std::move(garment));
  solvers_.push_back(std::make_unique<Solver>(solver_params_));
  solvers_.back()->set_body(body());
  return garments_.size() - 1;
}

Garment& Session::garment(std::size_t index) {
  if (index >= garments_.size())
    throw InputError("garment " + std::to_string(index) + " does not exist: the session has " +
                     std::to_string(garments_.size()));
  return garments_[index];
}

const Garment& Session::garment(std::size_t index) const { return const_cast<Session*>(this)->garment(index); }

void Session::set_body(std::optional<Body> body) {
  body_ = std::move(body);
  for (auto& s : solvers_) s->set_body(this->body());
}

Solver& Session::solver(std::size_t index) {
  garment(index);
  return *solvers_[index];
}

void Session::set_solver_params(const SolverParams& params) {
  params.validate();
  solver_params_ = params;
  for (auto& s : solvers_) s->set_params(params);
}

void Session::set_frame_rate(double steps_per_second) {
  if (!std::isfinite(steps_per_second) || steps_per_second < 1 || steps_per_second > 10000) {
    std::ostringstream msg;
    msg << "frame rate " << steps_per_second << " is out of range: use 1 to 10000 steps a second";
    throw InputError(msg.str());
  }
  frame_rate_ = steps_per_second;
}

void Session::step() {
  const double dt = 1.0 / frame_rate_;
  if (simulating)
    for (std::size_t i = 0; i < garments_.size(); ++i) solvers_[i]->step(garments_[i], dt);
  time_ += dt;
}

void Session::advance_to(double t) {
  if (!std::isfinite(t)) throw InputError("event time is not a finite number");
  // A small tolerance so that t = n / frame_rate does not take an extra step to rounding.
  while (time_ + 1e-9 < t) step();
}

SurfaceHit Session::pick(const Vec3& position, const Vec3& ray) const {
  SurfaceHit best;
  if (!all_finite(position) || !all_finite(ray)) return best;
  const bool use_ray = ray.squaredNorm() > 0;
  const Vec3 dir = use_ray ? Vec3(ray.normalized()) : Vec3::Zero();
  const double reach = 1e3;
  // Each vertex's side of the ray's line (or of the box within pick_radius of the point), in a
  // mask of six bits: a triangle whose three corners share a bit is wholly to one side, missed,
  // with no test of its own. The few left are tested exactly.
  Vec3 e1 = Vec3::UnitX(), e2 = Vec3::UnitY(), e3 = Vec3::UnitZ();
  if (use_ray) {
    e3 = dir;
    e1 = dir.unitOrthogonal();
    e2 = e3.cross(e1);
  }
  const Vec3 lo = use_ray ? Vec3(0, 0, 0) : Vec3::Constant(-pick_radius);
  const Vec3 hi = use_ray ? Vec3(0, 0, reach) : Vec3::Constant(pick_radius);
  // In parallel, in pieces of the face indices: each piece keeps its nearest hit (the first of
  // equals), and the pieces' are taken in order, as one loop over the faces would; the winner's
  // normal, uv and nearest corner are filled in after.
  for (std::size_t gi = 0; gi < garments_.size(); ++gi) {
    const Garment& g = garments_[gi];
    const Mesh& m = g.mesh();
    const int nv = static_cast<int>(g.vertex_capacity());
    const int nf = static_cast<int>(m.number_of_faces() + m.number_of_removed_faces());
    std::vector<unsigned char> side(nv, 0);
    parallel::for_range(nv, 4096, [&](int b0, int b1) {
      for (int i = b0; i < b1; ++i) {
        const Vertex v(i);
        if (m.is_removed(v)) continue;
        const Vec3 r = g.position(v) - position;
        const Vec3 q(r.dot(e1), r.dot(e2), r.dot(e3));
        const double tol = 1e-9 * (1 + r.cwiseAbs().maxCoeff());  // the projections' rounding, well covered
        unsigned char bits = 0;
        for (int k = 0; k < 3; ++k)
          bits |= static_cast<unsigned char>(((q[k] < lo[k] - tol) << (2 * k)) | ((q[k] > hi[k] + tol) << (2 * k + 1)));
        side[i] = bits;
      }
    });
    const int pieces = parallel::piece_count(nf, 4096);
    std::vector<SurfaceHit> found(pieces);
    parallel::for_each(pieces, [&](int piece) {
      SurfaceHit& mine = found[piece];
      for (int fi = parallel::piece_begin(nf, piece, pieces), fe = parallel::piece_begin(nf, piece + 1, pieces);
           fi < fe; ++fi) {
        const Face f(fi);
        if (m.is_removed(f)) continue;
        const Halfedge h0 = m.halfedge(f), h1 = m.next(h0), h2 = m.next(h1);
        if (side[m.target(h0).idx()] & side[m.target(h1).idx()] & side[m.target(h2).idx()]) continue;
        const Vec3 a = g.position(m.target(h0)), b = g.position(m.target(h1)), c = g.position(m.target(h2));
        Vec3 point, bary;
        double distance;
        if (use_ray) {
          double t = 0;
          if (!geom::segment_crosses_triangle(position, position + reach * dir, a, b, c, t)) continue;
          point = position + t * reach * dir;
          const geom::ClosestPoint cp = geom::closest_on_triangle(point, a, b, c);
          bary = Vec3(cp.b0, cp.b1, cp.b2);
          distance = t * reach;
        } else {
          const geom::ClosestPoint cp = geom::closest_on_triangle(position, a, b, c);
          point = cp.point;
          bary = Vec3(cp.b0, cp.b1, cp.b2);
          distance = (point - position).norm();
          if (distance > pick_radius) continue;
        }
        if (distance >= mine.distance) continue;
        mine.hit = true;
        mine.garment = gi;
        mine.face = f;
        mine.barycentric = bary;
        mine.point = point;
        mine.distance = distance;
      }
    });
    for (const SurfaceHit& mine : found)
      if (mine.distance < best.distance) best = mine;
  }
  if (!best.hit) return best;
  const Garment& g = garments_[best.garment];
  const Mesh& m = g.mesh();
  const Halfedge h0 = m.halfedge(best.face), h1 = m.next(h0), h2 = m.next(h1);
  const Vec3 a = g.position(m.target(h0)), b = g.position(m.target(h1)), c = g.position(m.target(h2));
  const Vec3& bary = best.barycentric;
  const Vec3 n = (b - a).cross(c - a);
  best.normal = n.norm() > 0 ? Vec3(n.normalized()) : Vec3(0, 1, 0);
  best.uv = bary[0] * g.uv(h0) + bary[1] * g.uv(h1) + bary[2] * g.uv(h2);
  int k = 0;
  bary.maxCoeff(&k);
  best.nearest = m.target(k == 0 ? h0 : (k == 1 ? h1 : h2));
  return best;
}

ParamSet Session::params_for(const std::string& tool_id, const std::map<std::string, ParamValue>& values) const {
  ParamSet p(registry_->info(tool_id).parameters);
  for (const auto& [name, value] : values) p.set(name, value);
  return p;
}

Tool& Session::tool(const std::string& id) {
  auto it = tool_instances_.find(id);
  if (it != tool_instances_.end()) return *it->second;
  auto created = registry_->create(id);
  Tool& t = *created;
  tool_instances_.emplace(id, std::move(created));
  return t;
}

const std::string& Session::active_tool() const {
  static const std::string none;
  return active_ ? active_->id : none;
}

std::vector<Garment> Session::snapshot() const { return garments_; }

void Session::restore(const std::vector<Garment>& garments) {
  // Assignment gives every garment a fresh topology version, so every solver rebuilds its arrays.
  garments_ = garments;
  solvers_.resize(garments_.size());
  for (auto& s : solvers_) {
    if (!s) s = std::make_unique<Solver>(solver_params_);
    s->set_body(body());
  }
}

Feedback Session::apply(const std::string& tool_id, const ToolEvent& event, const ParamSet* params) {
  return apply(tool(tool_id), event, params);
}

Feedback Session::apply(Tool& tool, const ToolEvent& event_in, const ParamSet* params) {
  const std::string id = tool.info().id;
  if (!all_finite(event_in.position) || !all_finite(event_in.ray) || !std::isfinite(event_in.time) ||
      !std::isfinite(event_in.pressure) || !event_in.orientation.coeffs().allFinite())
    throw InputError("tool event for '" + id + "' has a coordinate, time or pressure that is not a finite number");
  if (event_in.phase == Phase::Begin) {
    if (active_)
      throw InputError("a '" + active_->id + "' stroke is in progress: end or cancel it before starting '" + id + "'");
    if (!params) throw InputError("a '" + id + "' stroke begins without parameters");
  } else {
    if (!active_) throw InputError(std::string("a '") + phase_name(event_in.phase) + "' event for '" + id +
                                   "' came without a stroke: a stroke starts with a begin event");
    if (active_->tool != &tool)
      throw InputError("a '" + id + "' event came during a '" + active_->id + "' stroke");
  }
  if (event_in.time > time_) advance_to(event_in.time);
  ToolEvent event = event_in;
  event.hit = pick(event.position, event.ray);

  if (event.phase == Phase::Cancel) {
    auto stroke = std::move(active_);
    tool.cancel(*this);
    restore(stroke->entry.before);
    return {};
  }
  if (event.phase == Phase::Begin) {
    auto stroke = std::make_unique<ActiveStroke>();
    stroke->tool = &tool;
    stroke->id = id;
    stroke->params = *params;
    stroke->entry.tool = id;
    stroke->entry.params = params->values();
    stroke->entry.before = snapshot();
    active_ = std::move(stroke);
  }
  active_->entry.events.push_back(event);
  try {
    switch (event.phase) {
      case Phase::Begin: return tool.begin(*this, active_->params, event);
      case Phase::Move: return tool.update(*this, event);
      case Phase::End: {
        tool.end(*this, event);
        auto stroke = std::move(active_);
        stroke->entry.after = snapshot();
        journal_.push(std::move(stroke->entry));
        return {};
      }
      case Phase::Cancel: break;
    }
  } catch (...) {
    // Nothing half-applied: the garments go back to where the stroke began.
    auto stroke = std::move(active_);
    try {
      tool.cancel(*this);
    } catch (...) {
    }
    restore(stroke->entry.before);
    throw;
  }
  return {};
}

void Session::run(const std::string& tool_id, const ParamSet& params, const Stroke& stroke) {
  run(tool(tool_id), params, stroke);
}

void Session::run(Tool& tool, const ParamSet& params, const Stroke& stroke) {
  if (stroke.empty() || stroke.front().phase != Phase::Begin)
    throw InputError("a stroke for '" + tool.info().id + "' must start with a begin event");
  for (const ToolEvent& e : stroke) apply(tool, e, &params);
  // A stroke that stops without End or Cancel is finished, as a released button would.
  if (active_) {
    ToolEvent end = stroke.back();
    end.phase = Phase::End;
    apply(tool, end, &params);
  }
}

bool Session::undo() {
  if (active_) {
    ToolEvent cancel;
    cancel.phase = Phase::Cancel;
    cancel.time = time_;
    apply(*active_->tool, cancel);
  }
  if (!journal_.can_undo()) return false;
  restore(journal_.undo().before);
  return true;
}

bool Session::redo() {
  if (active_ || !journal_.can_redo()) return false;
  restore(journal_.redo().after);
  return true;
}

}  // namespace kiji
