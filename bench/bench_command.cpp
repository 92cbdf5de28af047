// kiji bench: figures for this machine, measured, never typed in. The paper's tables 1-2 (the rate
// while each tool is in use) at its sizes and a hundred times larger, Kiji's solvers beside Bullet's
// own cloth (btSoftBody) on the same cloth, the haptic loop, and scaling with the vertex count.
#include "args.h"
#include "bench_commands.h"
#include "kiji/body.h"
#include "kiji/drape.h"
#include "kiji/error.h"
#include "kiji/haptics.h"
#include "kiji/pattern.h"
#include "kiji/render.h"
#include "kiji/session.h"

#include <BulletCollision/BroadphaseCollision/btDbvtBroadphase.h>
#include <BulletDynamics/ConstraintSolver/btSequentialImpulseConstraintSolver.h>
#include <BulletSoftBody/btSoftBodyHelpers.h>
#include <BulletSoftBody/btSoftBodyRigidBodyCollisionConfiguration.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>

#include <algorithm>
#include <iterator>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <malloc.h>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <utility>
#include <vector>

namespace kiji::cli {

namespace {

static_assert(sizeof(btScalar) == 8, "Kiji uses Bullet in double precision");

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// The report's objects keep their fields in the order they are written (a person reads them too).
// A figure that is not finite (no steps timed) is written as null.
using Json = nlohmann::ordered_json;

// Bytes in use on the heap: what a garment and its solver take. glibc's count, or the sanitizer's
// allocator's under AddressSanitizer (whose mallinfo2 says nothing).
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define KIJI_HEAP_FROM_SANITIZER 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(KIJI_HEAP_FROM_SANITIZER)
}  // namespace
extern "C" std::size_t __sanitizer_get_current_allocated_bytes();  // the sanitizers' allocator interface
namespace {
double heap_bytes() { return static_cast<double>(__sanitizer_get_current_allocated_bytes()); }
#else
double heap_bytes() { return static_cast<double>(mallinfo2().uordblks); }
#endif

// A square-ish rectangle of about `vertices` vertices, 1 m wide.
Garment cloth_of(int vertices, const Material& m = {}) {
  const int n = std::max(2, static_cast<int>(std::lround(std::sqrt(double(vertices)))));
  return make_rectangle(1.0, 1.0, n, n, m);
}

// ---- 1. the paper's tables: each tool in use on a garment on the body ----

// One row of the tables: the median of several strokes started at different places (the work a
// stroke makes is chaotic: the same stroke 3 cm aside can cost three times as much), so that two
// builds compare.
struct ToolRate {
  std::string tool;  // the tool, or "pinch_local": the pinch with the paper's local region
  double steps_per_second = 0, frames_per_second = 0;  // the median stroke's
  int moving_vertices = 0;  // pinch_local: the vertices within the radius at the median stroke's end
  StepReport::Times ms;     // the solver's own account of a step, averaged over the median stroke's steps
  double asleep = 0;        // the share of the garment's vertices asleep at the median stroke's end
  std::vector<double> stroke_steps_per_second;  // each stroke's, in the order they were made
  // The largest edge strain (|length / rest - 1|) of the garment during a stroke and once it has ended
  // (half a second later): the median over the strokes.
  double max_strain_during = 0, max_strain_after = 0;
  // The edges stretched or compressed beyond 10 %: the most at any step of a stroke, and half a
  // second after it, the median over the strokes. The largest strain is one edge; this is how much
  // of the cloth is out of shape.
  double beyond_10pct_during = 0, beyond_10pct_after = 0;
  // The steps that rebuilt the solver after the row's strokes changed the garment's topology (a cut,
  // a tear, a seam), during each stroke and in the half second after it, and the median time a
  // rebuild took (StepReport::ms.rebuild).
  int topology_edits = 0;
  double topology_edit_ms = 0;
};

// A step's time by phase, as the solver reports it (StepReport::ms), with the share of the step
// outside loops shared between threads: what more cores cannot shorten.
Json phases_json(const StepReport::Times& t) {
  return {{"total_ms", t.total},
          {"solve_ms", t.solve},
          {"strain_limit_ms", t.strain_limit},
          {"self_search_ms", t.self_search},
          {"self_resolve_ms", t.self_resolve},
          {"body_ms", t.body},
          {"serial_share", t.total > 0 ? (t.total - t.shared) / t.total : 0.0}};
}

std::string phases_text(const StepReport::Times& t) {
  char b[256];
  const double k = t.total > 0 ? 100 / t.total : 0;
  std::snprintf(b, sizeof b, "%.1f ms: solve %.0f%%, strain limit %.0f%%, self %.0f%%+%.0f%%, body %.0f%%; serial %.0f%%",
                t.total, k * t.solve, k * t.strain_limit, k * t.self_search, k * t.self_resolve, k * t.body,
                k * (t.total - t.shared));
  return b;
}

void add_times(StepReport::Times& sum, const StepReport::Times& t, double scale) {
  sum.total += scale * t.total, sum.solve += scale * t.solve, sum.strain_limit += scale * t.strain_limit;
  sum.self_search += scale * t.self_search, sum.self_resolve += scale * t.self_resolve, sum.body += scale * t.body;
  sum.shared += scale * t.shared;
}

// The pinch's local region in the tables (the paper simulates only the vertices within a distance
// of the pen; it gives none): about a hand's span.
constexpr double kLocalRadius = 0.2;

// The paper's own figures (its table 1, without and with edge and vertex drawing), for V = 289,
// 400, 521.
Json paper_table() {
  return {{"sizes", {289, 400, 521}},
          {"without_edges", {{"pinch", {32, 18, 10}}, {"tear", {32, 18, 10}}, {"cut", {65, 65, 65}},
                             {"sew", {64, 46, 32}}, {"paint", {25, 22, 22}}}},
          {"with_edges", {{"pinch", {22, 13, 7}}, {"tear", {22, 13, 7}}, {"cut", {53, 33, 33}},
                          {"sew", {33, 27, 18}}, {"paint", {22, 18, 17}}}}};
}

// Whether every vertex of the session's garment sleeps (see SolverParams::sleep_after).
bool all_asleep(Session& s) {
  return s.solver(0).measure(s.garment(0)).sleeping == s.garment(0).mesh().number_of_vertices();
}

// A garment on the body at rest, as a designer finds it: placed over the body and let fall with
// its damping raised (so that it comes to rest in a few seconds, not a minute), until every part
// of it sleeps (see SolverParams::sleep_after) or 12 s have passed. Not timed.
Garment settled_on(const Body& body, int vertices, std::shared_ptr<ToolRegistry> tools) {
  Session s(tools);
  s.set_body(body);
  Garment g = cloth_of(vertices);
  const Material cloth = g.material();
  Material damped = cloth;
  damped.damping = 8.0;
  g.set_material(damped);
  place_over_body(g, body);
  s.add_garment(std::move(g));
  for (int i = 0; i < 12 * 60; ++i) {
    s.step();
    if (i % 15 == 14 && all_asleep(s)) break;
  }
  Garment out = s.garment(0);
  out.set_material(cloth);
  for (Vertex v : out.mesh().vertices()) out.velocity(v) = Vec3::Zero();
  return out;
}

// The rows of the paper's tables, in the order they are measured.
const std::vector<std::string> kToolRows = {"pinch", "pinch_local", "pinch_landing", "tear", "cut", "sew", "paint"};

// The largest edge strain of the garment.
double max_strain(const Garment& g) {
  double m = 0;
  for (Edge e : g.mesh().edges()) m = std::max(m, std::abs(g.strain(e)));
  return m;
}

// The garment's edges stretched or compressed by more than 10 %.
int edges_beyond_10pct(const Garment& g) {
  int n = 0;
  for (Edge e : g.mesh().edges()) n += std::abs(g.strain(e)) > 0.1;
  return n;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t h = v.size() / 2;
  return v.size() % 2 ? v[h] : 0.5 * (v[h - 1] + v[h]);
}

// Where the strokes of a row start, from the first stroke's place (m, across and along the body):
// the first `strokes` of them that begin on the cloth.
constexpr double kStrokeOffsets[][2] = {{0, 0},        {0.03, -0.04}, {-0.03, 0.04}, {0.05, 0.02}, {-0.05, -0.02},
                                        {0.02, 0.06},  {-0.02, -0.06}, {0.06, -0.05}, {-0.06, 0.05}, {0.04, 0.05},
                                        {-0.04, -0.05}};

std::vector<ToolRate> tool_rates(const Body& body, int vertices, int frames, int strokes,
                                 std::shared_ptr<ToolRegistry> tools, const std::vector<std::string>& rows) {
  std::vector<ToolRate> out;
  // Settled only when a row needs the garment at rest (the landing row does not).
  std::optional<Garment> settled;
  for (const std::string& name : rows) {
    const bool local = name == "pinch_local", landing = name == "pinch_landing";
    const std::string tool = (local || landing) ? "pinch" : name;
    std::vector<ToolRate> made;
    std::vector<double> during, after, rebuilds, beyond_during, beyond_after;
    for (const auto& offset : kStrokeOffsets) {
      if (static_cast<int>(made.size()) == strokes) break;
      Session s(tools);
      s.set_body(body);
      if (landing) {
        // The pinch while the garment is still landing on the body: everything in motion.
        Garment g = cloth_of(vertices);
        place_over_body(g, body);
        s.add_garment(std::move(g));
        for (int i = 0; i < 10; ++i) s.step();
      } else {
        // The garment at rest, as it slept at the end of its settling (the garment carries where it
        // sleeps to a new session's solver: see Garment::sleep_record). Should a part of it be awake,
        // it is given up to 1 s to sleep (not timed).
        if (!settled) settled = settled_on(body, vertices, tools);
        s.add_garment(*settled);
        for (int i = 0; i < 60 && !all_asleep(s); i += 10)
          for (int k = 0; k < 10; ++k) s.step();
      }
      // A stroke 0.4 m long across the cloth, seen from above (over the shoulders on the garment at
      // rest, over its front while it lands): each event is on the cloth where it is at that moment
      // (the pen a millimetre above it, pointing down), as a pen drawn over the cloth would be.
      const Box3 b = s.garment(0).bounds();
      const Vec3 down(0, -1, 0);
      const Vec3 a(b.center().x() - 0.2 + offset[0], b.max().y() + 0.1,
                   b.center().z() + (landing ? 0.2 : 0.0) + offset[1]),
          z = a + Vec3(0.4, 0, 0);
      if (!s.pick(a, down).hit) continue;  // this place is off the cloth: the next one
      ParamSet p = local ? s.params_for(tool, {{"local_radius", kLocalRadius}}) : s.params_for(tool);
      const Camera cam = Camera::framing(body.bounds());
      double step_s = 0, frame_s = 0, strain_during = 0;
      int beyond = 0;
      StepReport::Times times;
      Vec3 last = a;
      for (int f = 0; f <= frames; ++f) {
        ToolEvent e;
        e.phase = f == 0 ? Phase::Begin : (f == frames ? Phase::End : Phase::Move);
        e.time = s.time() + 1.0 / s.frame_rate();
        const Vec3 above = a + (z - a) * (double(f) / frames);
        const SurfaceHit under = s.pick(above, down);
        // Off the cloth (it has slid away under the pen), the pen goes on at the height it had.
        e.position = under.hit ? Vec3(under.point - 0.001 * down) : Vec3(above.x(), last.y(), above.z());
        e.ray = down;
        last = e.position;
        const auto t0 = Clock::now();
        s.apply(tool, e, &p);  // advances the simulation one step, then the tool acts
        step_s += seconds_since(t0);
        add_times(times, s.solver(0).last_step().ms, 1.0 / (frames + 1));
        if (s.solver(0).last_step().ms.rebuild > 0) rebuilds.push_back(s.solver(0).last_step().ms.rebuild);
        const auto t1 = Clock::now();
        const Garment& gg = s.garment(0);
        render({&gg}, &body, cam, 320, 240);
        frame_s += seconds_since(t1);
        strain_during = std::max(strain_during, max_strain(gg));
        beyond = std::max(beyond, edges_beyond_10pct(gg));
      }
      int moving = 0;
      if (local)
        for (Vertex v : s.garment(0).mesh().vertices())
          moving += (s.garment(0).position(v) - last).norm() <= kLocalRadius;
      const double asleep = double(s.solver(0).measure(s.garment(0)).sleeping) /
                            double(std::max<std::size_t>(1, s.garment(0).mesh().number_of_vertices()));
      for (int k = 0; k < 30; ++k) {  // half a second after the stroke (not timed)
        s.step();
        // A cut made at the stroke's end, or a seam sewn as its tacks meet, is built into the solver here.
        if (s.solver(0).last_step().ms.rebuild > 0) rebuilds.push_back(s.solver(0).last_step().ms.rebuild);
      }
      during.push_back(strain_during);
      after.push_back(max_strain(s.garment(0)));
      beyond_during.push_back(beyond);
      beyond_after.push_back(edges_beyond_10pct(s.garment(0)));
      ToolRate r;
      r.tool = name;
      r.steps_per_second = (frames + 1) / step_s;
      r.frames_per_second = (frames + 1) / (step_s + frame_s);
      r.moving_vertices = moving;
      r.ms = times;
      r.asleep = asleep;
      made.push_back(r);
    }
    if (made.empty())
      throw std::runtime_error("the bench's " + name + " strokes all begin off the cloth: its figures would be of steps alone");
    // The median stroke by steps a second (the lower middle one of an even count), with the row's
    // strokes and strains.
    std::vector<std::size_t> by_rate(made.size());
    for (std::size_t k = 0; k < made.size(); ++k) by_rate[k] = k;
    std::sort(by_rate.begin(), by_rate.end(),
              [&](std::size_t x, std::size_t y) { return made[x].steps_per_second < made[y].steps_per_second; });
    ToolRate r = made[by_rate[(made.size() - 1) / 2]];
    for (const ToolRate& m : made) r.stroke_steps_per_second.push_back(m.steps_per_second);
    r.max_strain_during = median(during);
    r.max_strain_after = median(after);
    r.beyond_10pct_during = median(beyond_during);
    r.beyond_10pct_after = median(beyond_after);
    r.topology_edits = static_cast<int>(rebuilds.size());
    r.topology_edit_ms = median(rebuilds);
    out.push_back(r);
  }
  return out;
}

// ---- 2. Kiji beside btSoftBody on the same cloth ----

struct ClothResult {
  double ms_per_step = 0, max_strain = 0, mean_strain = 0, sag = 0;
  double setup_ms = 0;  // building the solver's own structures, once, before the first step
};

// A solver's own clock: the time of its steps alone, so that cloths can be stepped in turns.
class StepClock {
 public:
  template <typename F>
  void time(int count, F&& step) {
    const auto t0 = Clock::now();
    for (int i = 0; i < count; ++i) step();
    seconds_ += seconds_since(t0);
    steps_ += count;
  }
  double ms_per_step() const { return steps_ ? 1000 * seconds_ / steps_ : 0.0; }

 private:
  double seconds_ = 0;
  int steps_ = 0;
};

// A horizontal cloth 1 m square, pinned at two corners, under gravity at 60 steps a second, in
// Kiji's solver, on its own clock (see compare()).
class KijiCloth {
 public:
  KijiCloth(int n, SolverModel model, int substeps = 10, bool strain_limit = true)
      : garment_(make_rectangle(1.0, 1.0, n, n)), solver_(params(model, substeps, strain_limit)) {
    // Lay it flat (pattern y -> world -z) and pin the corners (0,0) and (1,0) as Bullet's fixeds 1+2.
    Eigen::Matrix3d r;
    r << 1, 0, 0, 0, 0, 1, 0, -1, 0;
    garment_.transform(Eigen::Affine3d(r));
    double best = 1e9;
    for (Vertex v : garment_.mesh().vertices()) {
      const Vec3 p = garment_.position(v);
      if (std::abs(p.z()) < 1e-9 && (p.x() < 1e-9 || p.x() > 1 - 1e-9)) garment_.set_pinned(v, true);
      const double d = (p - Vec3(0.5, 0, -0.5)).norm();
      if (d < best) best = d, centre_ = v;
    }
    const auto t_setup = Clock::now();
    solver_.prepare(garment_);  // as Bullet's patch and links are built before its clock starts
    res_.setup_ms = 1000 * seconds_since(t_setup);
  }
  void step(int count) {
    clock_.time(count, [&] { solver_.step(garment_, 1.0 / 60); });
  }
  ClothResult result() const {
    ClothResult res = res_;
    res.ms_per_step = clock_.ms_per_step();
    double sum = 0;
    for (Edge e : garment_.mesh().edges()) {
      res.max_strain = std::max(res.max_strain, std::abs(garment_.strain(e)));
      sum += std::abs(garment_.strain(e));
    }
    res.mean_strain = sum / garment_.mesh().number_of_edges();
    res.sag = -garment_.position(centre_).y();
    return res;
  }

 private:
  static SolverParams params(SolverModel model, int substeps, bool strain_limit) {
    SolverParams params;
    params.model = model;
    params.self_collision = false;
    params.body_collision = false;
    params.substeps = substeps;
    // Every step computed, as Bullet's are: no part of the swinging cloth is let sleep.
    params.sleep_after = 0;
    if (!strain_limit) params.strain_limit = 0;
    if (model == SolverModel::MassSpring) {
      params.spring_k = 2000;  // the paper's unit masses: a stiff spring, the paper's explicit steps
      params.spring_damping = 2.0;
      params.substeps = 40;
    }
    return params;
  }
  Garment garment_;
  Solver solver_;
  Vertex centre_;
  ClothResult res_;
  StepClock clock_;
};

// The links btSoftBody::generateBendingConstraints(2) appends, in its order: one for each two nodes
// exactly two links apart, marked as bending. Bullet's own finds them in an n x n matrix of the
// nodes' distances, which cannot be had at 50,000 nodes (10 GB, and n * n beyond an int: it threw
// std::bad_alloc and ended the bench); this walks each node's neighbours' neighbours instead.
void add_bending_links(btSoftBody& cloth) {
  const int n = cloth.m_nodes.size();
  std::vector<std::vector<int>> nbr(n);
  for (int k = 0; k < cloth.m_links.size(); ++k) {
    const int a = static_cast<int>(cloth.m_links[k].m_n[0] - &cloth.m_nodes[0]);
    const int b = static_cast<int>(cloth.m_links[k].m_n[1] - &cloth.m_nodes[0]);
    nbr[a].push_back(b);
    nbr[b].push_back(a);
  }
  std::vector<int> seen(n, -1), found;
  for (int j = 0; j < n; ++j) {
    seen[j] = j;
    for (int k : nbr[j]) seen[k] = j;
    found.clear();
    for (int k : nbr[j])
      for (int i : nbr[k])
        if (i > j && seen[i] != j) seen[i] = j, found.push_back(i);
    std::sort(found.begin(), found.end());
    for (int i : found) {
      cloth.appendLink(i, j);
      cloth.m_links[cloth.m_links.size() - 1].m_bbending = 1;
    }
  }
}

// The same cloth in Bullet's btSoftBody (Debian's libbullet, double precision).
class BulletCloth {
 public:
  explicit BulletCloth(int n)
      : n_(n), dispatcher_(&config_), world_(&dispatcher_, &broadphase_, &solver_, &config_) {
    world_.setGravity(btVector3(0, -9.81, 0));
    const auto t_setup = Clock::now();
    btSoftBodyWorldInfo& info = world_.getWorldInfo();
    info.m_gravity = btVector3(0, -9.81, 0);
    info.m_sparsesdf.Initialize();
    // Corners: (0,0,0) (1,0,0) (0,0,-1) (1,0,-1); fixeds 1 + 2 pin the first two.
    cloth_.reset(btSoftBodyHelpers::CreatePatch(info, btVector3(0, 0, 0), btVector3(1, 0, 0), btVector3(0, 0, -1),
                                                btVector3(1, 0, -1), n, n, 1 + 2, true));
    cloth_->m_cfg.piterations = 10;
    add_bending_links(*cloth_);  // as generateBendingConstraints(2)
    cloth_->setTotalMass(0.15);  // cotton, 0.15 kg/m^2
    world_.addSoftBody(cloth_.get());
    res_.setup_ms = 1000 * seconds_since(t_setup);
  }
  ~BulletCloth() { world_.removeSoftBody(cloth_.get()); }
  BulletCloth(const BulletCloth&) = delete;
  BulletCloth& operator=(const BulletCloth&) = delete;
  void step(int count) {
    clock_.time(count, [&] { world_.stepSimulation(1.0 / 60, 0); });
  }
  ClothResult result() const {
    ClothResult res = res_;
    res.ms_per_step = clock_.ms_per_step();
    double sum = 0;
    int count = 0;
    for (int i = 0; i < cloth_->m_links.size(); ++i) {
      const btSoftBody::Link& l = cloth_->m_links[i];
      if (l.m_bbending) continue;  // the structural links only, like Kiji's edges
      const double len = (l.m_n[0]->m_x - l.m_n[1]->m_x).length();
      const double s = std::abs(len / l.m_rl - 1);
      res.max_strain = std::max(res.max_strain, s);
      sum += s;
      ++count;
    }
    res.mean_strain = count ? sum / count : 0;
    const int centre = (n_ / 2) * n_ + n_ / 2;
    res.sag = -cloth_->m_nodes[centre].m_x.y();
    return res;
  }

 private:
  int n_;
  btSoftBodyRigidBodyCollisionConfiguration config_;
  btCollisionDispatcher dispatcher_;
  btDbvtBroadphase broadphase_;
  btSequentialImpulseConstraintSolver solver_;
  btSoftRigidDynamicsWorld world_;
  std::unique_ptr<btSoftBody> cloth_;
  ClothResult res_;
  StepClock clock_;
};

ClothResult run_kiji(int n, SolverModel model, int steps, int substeps = 10, bool strain_limit = true) {
  KijiCloth cloth(n, model, substeps, strain_limit);
  cloth.step(steps);
  return cloth.result();
}

// Kiji's cloths and Bullet's stepped in turns, 20 steps each, every solver on its own clock: on a
// shared machine all of them meet the same load (run one after the other, the ratio also measured
// whatever load came or went between the runs). The cloths are independent: each one's result is
// what it is alone. Turns of 5 steps cost Kiji's step about 15 % at 20,000 vertices (its arrays
// evicted from the cache by the others' at every turn); at 20 that is within the noise.
struct Compared {
  std::vector<ClothResult> kiji;
  ClothResult bullet;
};
Compared compare(int n, int steps, const std::vector<std::pair<int, bool>>& kiji_settings) {
  std::vector<std::unique_ptr<KijiCloth>> kiji;
  for (const auto& [substeps, limit] : kiji_settings)
    kiji.push_back(std::make_unique<KijiCloth>(n, SolverModel::Xpbd, substeps, limit));
  BulletCloth bullet(n);
  constexpr int kTurn = 20;
  for (int done = 0; done < steps; done += kTurn) {
    const int count = std::min(kTurn, steps - done);
    for (auto& k : kiji) k->step(count);
    bullet.step(count);
  }
  Compared out;
  for (const auto& k : kiji) out.kiji.push_back(k->result());
  out.bullet = bullet.result();
  return out;
}

Json cloth_json(const ClothResult& r) {
  return {{"ms_per_step", r.ms_per_step}, {"max_strain", r.max_strain}, {"mean_strain", r.mean_strain},
          {"sag_m", r.sag}, {"setup_ms", r.setup_ms}};
}

// ---- 3. haptics: the force callback and the loop while a 20k garment simulates ----

HapticStats haptics(const Body& body, int vertices, double seconds, std::shared_ptr<ToolRegistry> tools,
                    double* sim_ms) {
  Session s(tools);
  s.set_body(body);
  Garment g = cloth_of(vertices);
  place_over_body(g, body);
  s.add_garment(std::move(g));
  for (int i = 0; i < 5; ++i) s.step();
  const Box3 b = s.garment(0).bounds();
  const Vec3 grab(b.center().x(), b.max().y(), b.center().z());
  ParamSet p = s.params_for("pinch", {{"stiffness", 100.0}});
  ToolEvent e;
  e.phase = Phase::Begin;
  e.time = s.time();
  e.position = grab;
  s.apply("pinch", e, &p);
  ScriptedDevice device([&](double t) {
    ToolEvent d;
    d.position = grab + Vec3(0.05 * std::sin(2 * t), 0.05 * std::sin(3 * t), 0.02);
    return d;
  });
  HapticLoop loop(device);
  loop.set_tool(&s.tool("pinch"));
  loop.publish(std::make_shared<HapticSnapshot>(take_snapshot(s, 0, grab, 0.1)));
  loop.start();
  // The simulation thread: events from the device's latest sample, a step, a new snapshot.
  const auto t0 = Clock::now();
  int steps = 0;
  double stepping = 0;
  while (seconds_since(t0) < seconds) {
    ToolEvent m = loop.latest_sample();
    m.phase = Phase::Move;
    m.time = s.time() + 1.0 / s.frame_rate();
    const auto ts = Clock::now();
    s.apply("pinch", m);
    stepping += seconds_since(ts);
    ++steps;
    loop.publish(std::make_shared<HapticSnapshot>(take_snapshot(s, 0, m.position, 0.1)));
  }
  loop.stop();
  e.phase = Phase::End;
  e.time = s.time();
  s.apply("pinch", e);
  *sim_ms = steps ? 1000 * stepping / steps : 0;
  return loop.stats();
}

}  // namespace

int bench_command(const std::vector<std::string>& argv) {
  const Args args(argv, {"--sizes", "--tools", "--bullet-sizes", "--scaling-sizes", "--haptic-vertices", "--haptic-seconds",
                   "--frames", "--strokes", "--scaling-substeps"},
                  {"--json", "--quick", "--help", "-h"});
  if (args.has("--help") || args.has("-h")) {
    std::puts(
        "usage: kiji bench [--json] [--quick] [--sizes V,V,...] [--tools T,T,...] [--bullet-sizes V,...]\n"
        "                  [--scaling-sizes V,...] [--scaling-substeps N] [--haptic-vertices V] [--haptic-seconds S]\n"
        "                  [--frames N] [--strokes N]\n\n"
        "Measures on this machine: (1) the paper's tables 1-2, steps and frames a second while each tool is in\n"
        "use, on the default body; (2) Kiji's solvers beside Bullet's btSoftBody on the same cloth; (3) the\n"
        "haptic loop while a garment simulates; (4) time per step and memory per vertex against size.\n"
        "--quick uses tiny sizes (a check that everything runs, not figures to quote). --tools picks the rows of\n"
        "(1): pinch, pinch_local, pinch_landing, tear, cut, sew, paint (all by default). --scaling-substeps sets\n"
        "the substeps a step in (4) (10, the solver's default, unless given). Each row of (1) is the median of\n"
        "--strokes strokes (5; 1 with --quick) of --frames steps, started at different places on the cloth.");
    return 0;
  }
  const bool quick = args.has("--quick");
  auto sizes_of = [&](const std::string& name, const std::vector<int>& full, const std::vector<int>& small) {
    if (!args.has(name)) return quick ? small : full;
    std::vector<int> out;
    std::stringstream ss(args.get(name, ""));
    std::string item;
    while (std::getline(ss, item, ',')) {
      try {
        const int v = std::stoi(item);
        if (v < 4 || v > 2'000'000) throw std::out_of_range(item);
        out.push_back(v);
      } catch (const std::exception&) {
        throw UsageError(name + " expects vertex counts between 4 and 2,000,000, not '" + item + "'");
      }
    }
    return out;
  };
  const auto tool_sizes = sizes_of("--sizes", {289, 400, 521, 5000, 20000, 50000}, {289, 400});
  const auto bullet_sizes = sizes_of("--bullet-sizes", {500, 5000, 20000, 50000}, {100, 400});
  const auto scaling_sizes = sizes_of("--scaling-sizes", {500, 2000, 5000, 20000, 50000, 100000, 200000}, {100, 400});
  std::vector<std::string> rows = kToolRows;
  if (args.has("--tools")) {
    std::string names;
    for (const std::string& r : kToolRows) names += (names.empty() ? "" : ", ") + r;
    rows.clear();
    std::stringstream ss(args.get("--tools", ""));
    std::string item;
    while (std::getline(ss, item, ',')) {
      if (std::find(kToolRows.begin(), kToolRows.end(), item) == kToolRows.end())
        throw UsageError("--tools: '" + item + "' is not a row of the tables: use one or more of " + names);
      rows.push_back(item);
    }
    if (rows.empty()) throw UsageError("--tools expects one or more of " + names);
  }
  const int haptic_vertices = static_cast<int>(args.number("--haptic-vertices", quick ? 400 : 20000));
  const double haptic_seconds = args.number("--haptic-seconds", quick ? 0.3 : 3.0);
  const int frames = static_cast<int>(args.number("--frames", quick ? 3 : 30));
  const int strokes = static_cast<int>(args.number("--strokes", quick ? 1 : 5));
  SolverParams scaling_params;
  scaling_params.substeps = args.integer("--scaling-substeps", scaling_params.substeps);
  try {
    scaling_params.validate();  // now, not minutes later when section 4 starts
  } catch (const InputError& e) {
    throw UsageError(std::string("--scaling-substeps: ") + e.what());
  }
  if (frames < 1 || haptic_seconds <= 0 || haptic_vertices < 4)
    throw UsageError("--frames, --haptic-seconds and --haptic-vertices must be positive");
  if (strokes < 1 || strokes > static_cast<int>(std::size(kStrokeOffsets)))
    throw UsageError("--strokes must be between 1 and " + std::to_string(std::size(kStrokeOffsets)));
  const bool json = args.has("--json");
  auto say = [&](const char* fmt, auto... a) {
    if (json) return;
    if constexpr (sizeof...(a) == 0) std::fputs(fmt, stdout);  // no format to read: a plain line
    else std::printf(fmt, a...);
    std::fflush(stdout);
  };

  const Body body = Body::load(Body::default_path());
  auto tools = std::make_shared<ToolRegistry>();
  tools->load_plugins();
  for (const char* t : {"pinch", "tear", "cut", "sew", "paint"})
    if (!tools->has(t)) throw InputError(std::string("the '") + t + "' tool plugin was not found: build the plugins or set KIJI_PLUGIN_PATH");

  say("Kiji's solvers on %d threads (KIJI_THREADS sets it), on a machine with %u\n", solver_threads(),
      std::thread::hardware_concurrency());
  // 1. The paper's tables.
  say("1. the paper's tables 1-2: steps / frames a second while each tool is in use, on %s\n"
      "   (on the garment at rest on the body; pinch_local: the pinch simulating only the cloth within %.2f m of the\n"
      "   pen, the paper's local region; pinch_landing: the pinch while the garment is still landing on the body);\n"
      "   each the median of %d strokes started at different places\n",
      body.name().c_str(), kLocalRadius, strokes);
  Json table = Json::array();
  for (int v : tool_sizes) {
    const auto rates = tool_rates(body, v, frames, strokes, tools, rows);
    Json row = {{"vertices", v}};
    say("   V = %6d:", v);
    for (const auto& r : rates) {
      Json rate = {{"steps_per_second", r.steps_per_second}, {"frames_per_second", r.frames_per_second}};
      if (r.tool == "pinch_local") {
        rate["local_radius_m"] = kLocalRadius;
        rate["moving_vertices"] = r.moving_vertices;
      }
      rate["step_phases"] = phases_json(r.ms);
      rate["asleep_at_end"] = r.asleep;
      rate["strokes"] = r.stroke_steps_per_second;
      rate["max_strain_during"] = r.max_strain_during;
      rate["max_strain_after"] = r.max_strain_after;
      rate["edges_beyond_10pct_during"] = r.beyond_10pct_during;
      rate["edges_beyond_10pct_after"] = r.beyond_10pct_after;
      rate["topology_edits"] = r.topology_edits;
      if (r.topology_edits > 0) rate["topology_edit_ms"] = r.topology_edit_ms;
      row[r.tool] = rate;
      say("  %s %.1f/%.1f", r.tool.c_str(), r.steps_per_second, r.frames_per_second);
    }
    say("\n");
    for (const auto& r : rates) {
      say("      %-13s a step %s; %.0f%% asleep at the end; largest strain %.3f during, %.3f after; "
          "edges beyond 10%%: %.0f during, %.0f after",
          r.tool.c_str(), phases_text(r.ms).c_str(), 100 * r.asleep, r.max_strain_during, r.max_strain_after,
          r.beyond_10pct_during, r.beyond_10pct_after);
      if (r.topology_edits > 0)
        say("; %d topology edits, %.1f ms each (topology_edit_ms, the median)", r.topology_edits, r.topology_edit_ms);
      say("\n");
    }
    table.push_back(row);
  }

  // 2. Beside btSoftBody.
  say("2. the same cloth (1 m, two corners pinned, 2 s at 60 Hz; the solvers stepped in turns, 20 steps each): ms a step\n"
      "   (each solver's set-up before the clock), max/mean strain, sag\n");
  Json versus = Json::array();
  const int steps = quick ? 10 : 120;
  for (int v : bullet_sizes) {
    const int n = std::max(2, static_cast<int>(std::lround(std::sqrt(double(v)))));
    // xpbd at the session's defaults (10 substeps, strain limit on), and at its cheapest still no more
    // stretched than Bullet's cloth (max and mean strain): the speed at equal or better strain. 1, 2,
    // 3, 5 and 10 substeps, each with and without the strain limit (a few Gauss-Seidel passes a
    // substep over the edges beyond it); the fastest of those whose strain is no worse. All of them
    // and Bullet's cloth stepped in turns (compare()).
    std::vector<std::pair<int, bool>> settings;
    for (int sub : {10, 1, 2, 3, 5})
      for (bool limit : {true, false}) settings.push_back({sub, limit});
    const Compared c = compare(n, steps, settings);
    const ClothResult& x = c.kiji[0];  // 10 substeps, strain limit on
    const ClothResult& b = c.bullet;
    const ClothResult m = run_kiji(n, SolverModel::MassSpring, steps);
    const double ratio = b.ms_per_step / x.ms_per_step;
    int matched = 0;
    bool matched_limit = true;
    ClothResult xm;
    for (std::size_t k = 0; k < settings.size(); ++k) {
      const ClothResult& r = c.kiji[k];
      if (r.max_strain > b.max_strain || r.mean_strain > b.mean_strain) continue;
      if (matched && r.ms_per_step >= xm.ms_per_step) continue;
      matched = settings[k].first;
      matched_limit = settings[k].second;
      xm = r;
    }
    const double matched_ratio = matched ? b.ms_per_step / xm.ms_per_step : 0.0;
    say("   V = %6d: xpbd %.2f ms (%.3f/%.4f, %.3f m)  mass_spring %.2f ms (%.3f/%.4f)  btSoftBody %.2f ms (%.3f/%.4f, %.3f m)  speed-up %.2fx\n",
        n * n, x.ms_per_step, x.max_strain, x.mean_strain, x.sag, m.ms_per_step, m.max_strain, m.mean_strain,
        b.ms_per_step, b.max_strain, b.mean_strain, b.sag, ratio);
    if (matched)
      say("              at equal or better strain: xpbd with %d substeps, strain limit %s: %.2f ms (%.3f/%.4f, %.3f m)  speed-up %.2fx\n",
          matched, matched_limit ? "on" : "off", xm.ms_per_step, xm.max_strain, xm.mean_strain, xm.sag, matched_ratio);
    else
      say("              at equal or better strain: none of 1-10 substeps\n");
    versus.push_back({{"vertices", n * n},
                      {"xpbd", cloth_json(x)},
                      {"mass_spring", cloth_json(m)},
                      {"bullet", cloth_json(b)},
                      {"speedup_xpbd_over_bullet", ratio},
                      {"matched_substeps", matched},
                      {"matched_strain_limit", matched ? Json(matched_limit) : Json()},
                      {"xpbd_matched", matched ? cloth_json(xm) : Json()},
                      {"speedup_at_equal_strain", matched_ratio}});
  }

  // 3. Haptics.
  double sim_ms = 0;
  const HapticStats h = haptics(body, haptic_vertices, haptic_seconds, tools, &sim_ms);
  say("3. haptics on %d vertices: loop %.0f Hz (jitter %.1f us, %s), force callback median %.2f us, p99 %.2f us; "
      "simulation %.1f ms a step\n", haptic_vertices, h.rate_hz, h.period_jitter_us,
      h.realtime ? "real-time priority" : "normal priority: no right to real-time", h.force_median_us, h.force_p99_us,
      sim_ms);

  // 4. Scaling: a 1 m cloth falling onto the body, 20 steps after the one that builds its arrays:
  // 10 falling free (with the first contacts at the end) and 10 landing on the body and on itself
  // (a tenth of the vertices come to touch the body; the landing's work is counted below). The
  // sizes are stepped in turns, as the Bullet comparison's solvers are, so that a burst of load
  // from elsewhere on the machine falls on all of them rather than on the one that was running:
  // each turn is a step untimed (the size's arrays back into the cache after the others') and one
  // timed. Each phase's median timed step, which such a burst moves less than a mean, and the
  // growth exponent fitted to them. By default up to 200,000 vertices, twice the largest the
  // tables ask for: at 10 substeps the landing's cost a vertex rises from 50,000 to 100,000, as its
  // crash comes to outrun the solver's sweeps (the edges moved a substep, below), and the largest
  // size shows whether it goes on rising (it levels off).
  constexpr int kTurns = 10;
  constexpr double kDt = 1.0 / 60;
  say("4. scaling (xpbd, %d substeps a step, cloth falling onto the body; the sizes stepped in turns, every second step "
      "timed: median step falling free, then landing on the body and itself)\n", scaling_params.substeps);
  struct Scaled {
    Garment garment;
    std::unique_ptr<Solver> solver;
    double bytes = 0;
    std::vector<double> step_ms;  // the timed steps in order
    std::vector<StepReport> work;  // what each did
    std::vector<double> speed;     // the cloth's mean speed after each, m/s
    double spacing = 0;            // its mean rest edge length, m
  };
  std::vector<Scaled> sized;
  for (int v : scaling_sizes) {
    const double before = heap_bytes();
    Scaled c{cloth_of(v), std::make_unique<Solver>(scaling_params), 0, {}, {}, {}, 0};
    for (Edge e : c.garment.mesh().edges()) c.spacing += c.garment.rest_length(e);
    c.spacing /= double(c.garment.mesh().number_of_edges());
    place_over_body(c.garment, body);
    c.solver->set_body(&body);
    c.solver->step(c.garment, kDt);  // builds the arrays
    c.bytes = heap_bytes() - before;
    sized.push_back(std::move(c));
  }
  for (int turn = 0; turn < kTurns; ++turn)
    for (Scaled& c : sized) {
      c.solver->step(c.garment, kDt);
      const auto t0 = Clock::now();
      c.solver->step(c.garment, kDt);
      c.step_ms.push_back(1000 * seconds_since(t0));
      c.work.push_back(c.solver->last_step());
      double speed = 0;
      for (Vertex u : c.garment.mesh().vertices()) speed += c.garment.velocity(u).norm();
      c.speed.push_back(speed / double(c.garment.mesh().number_of_vertices()));
    }
  auto median_of = [](std::vector<double> t) {
    std::sort(t.begin(), t.end());
    const std::size_t n = t.size();
    return 0.5 * (t[(n - 1) / 2] + t[n / 2]);
  };
  Json scaling = Json::array();
  std::vector<double> vertices, falling, landing;  // medians, ms
  for (const Scaled& c : sized) {
    const std::vector<double>& t = c.step_ms;
    double ms = 0;
    for (double x : t) ms += x;
    ms /= double(t.size());
    const double fall = median_of({t.begin(), t.begin() + kTurns / 2}), land = median_of({t.begin() + kTurns / 2, t.end()});
    const double nv = double(c.garment.mesh().number_of_vertices());
    vertices.push_back(nv), falling.push_back(fall), landing.push_back(land);
    // The landing's work, counted (the same in every run, unlike its time): self-collision pairs
    // a vertex and searches a step, and the share of the edges beyond the strain limit a substep.
    // And how far the landing moves the cloth in a substep, in edges: one Gauss-Seidel sweep a
    // substep carries a correction a few edges across the cloth, so the more edges the cloth
    // crosses in a substep, the more of them it crushes or pulls out before the sweeps can stop it
    // (the share beyond the strain limit follows this figure whatever the vertex count).
    double pairs = 0, gathers = 0, limited = 0, speed = 0;
    StepReport::Times landing_times;
    for (std::size_t k = kTurns / 2; k < c.work.size(); ++k) {
      add_times(landing_times, c.work[k].ms, 1.0 / double(c.work.size() - kTurns / 2));
      pairs += double(c.work[k].self_pairs), gathers += c.work[k].self_gathers;
      limited += double(c.work[k].strain_limited);
      speed += c.speed[k];
    }
    const double landing_steps = double(c.work.size() - kTurns / 2);
    const double substeps = double(c.solver->params().substeps);
    pairs /= landing_steps * nv, gathers /= landing_steps;
    limited /= landing_steps * substeps * double(c.garment.mesh().number_of_edges());
    const double edges_a_substep = speed / landing_steps * kDt / substeps / c.spacing;
    say("   V = %6.0f: %.2f ms a step (%.3f us a vertex); median falling %.2f ms (%.3f us a vertex), landing %.2f ms "
        "(%.3f); %.0f bytes a vertex\n", nv, ms, 1000 * ms / nv, fall, 1000 * fall / nv, land, 1000 * land / nv,
        c.bytes / nv);
    say("              landing's work a step: %.2f self-collision pairs a vertex in %.1f searches; %.1f %% of the "
        "edges beyond the strain limit a substep, the cloth moving %.2f edges a substep\n", pairs, gathers,
        100 * limited, edges_a_substep);
    say("              landing's mean step %s\n", phases_text(landing_times).c_str());
    scaling.push_back({{"vertices", nv},
                       {"ms_per_step", ms},
                       {"us_per_vertex", 1000 * ms / nv},
                       {"falling_median_us_per_vertex", 1000 * fall / nv},
                       {"landing_median_us_per_vertex", 1000 * land / nv},
                       {"landing_self_pairs_per_vertex", pairs},
                       {"landing_self_gathers_per_step", gathers},
                       {"landing_strain_limited_share", limited},
                       {"landing_edges_moved_per_substep", edges_a_substep},
                       {"bytes_per_vertex", c.bytes / nv},
                       {"landing_step_phases", phases_json(landing_times)}});
  }
  // Time ~ V^k: k over all the sizes (least squares on the logarithms) and between the two
  // largest. 1 is linear; under 1, the fixed costs of a step still count.
  Json growth;
  if (sized.size() >= 2) {
    auto exponents = [&](const std::vector<double>& ms) {
      std::vector<std::size_t> by_size(ms.size());
      for (std::size_t k = 0; k < by_size.size(); ++k) by_size[k] = k;
      std::sort(by_size.begin(), by_size.end(), [&](std::size_t a, std::size_t b) { return vertices[a] < vertices[b]; });
      double sx = 0, sy = 0, sxx = 0, sxy = 0;
      for (std::size_t k : by_size) {
        const double x = std::log(vertices[k]), y = std::log(ms[k]);
        sx += x, sy += y, sxx += x * x, sxy += x * y;
      }
      const double m = double(ms.size());
      const std::size_t a = by_size[by_size.size() - 2], b = by_size.back();
      return std::pair<double, double>{(m * sxy - sx * sy) / (m * sxx - sx * sx),
                                       std::log(ms[b] / ms[a]) / std::log(vertices[b] / vertices[a])};
    };
    const auto [fall_all, fall_top] = exponents(falling);
    const auto [land_all, land_top] = exponents(landing);
    say("   median step ~ V^k: falling k = %.2f over these sizes, %.2f between the two largest; landing %.2f and %.2f\n",
        fall_all, fall_top, land_all, land_top);
    growth = {{"falling_exponent_all_sizes", fall_all},
              {"falling_exponent_largest_two", fall_top},
              {"landing_exponent_all_sizes", land_all},
              {"landing_exponent_largest_two", land_top}};
  }

  if (json) {
    Json out = {{"threads", solver_threads()},
                {"hardware_threads", std::thread::hardware_concurrency()},
                {"paper", paper_table()},
                {"tool_rates", table},
                {"versus_bullet", versus},
                {"haptics",
                 {{"vertices", haptic_vertices},
                  {"loop_hz", h.rate_hz},
                  {"jitter_us", h.period_jitter_us},
                  {"force_median_us", h.force_median_us},
                  {"force_p99_us", h.force_p99_us},
                  {"ticks", h.ticks},
                  {"simulation_ms_per_step", sim_ms},
                  {"realtime", h.realtime}}},
                {"scaling_substeps", scaling_params.substeps},
                {"scaling", scaling}};
    if (!growth.is_null()) out["scaling_growth"] = growth;
    std::printf("%s\n", out.dump().c_str());
  }
  return 0;
}

}  // namespace kiji::cli
