// The cloth solver: steps garments forward in time, on flat arrays mirrored from the mesh.
//
// Two models behind one interface:
//  - MassSpring: the paper's model exactly (its eqs. 1-3): unit masses, the spring force
//    g_ij = k (1 - l_ij / l'_ij) d_ij on every edge, gravity and tool forces, explicit integration,
//    with the paper's local region (only vertices within a radius of a point are computed).
//  - Xpbd (the default): extended position-based dynamics with small substeps: stretch and bending
//    constraints from the material, damping, pins, body collision with the cloth's thickness
//    (continuous, so a fast hand does not push cloth through the body) and self-collision.
// The arrays are rebuilt when the garment's topology version changes; the mesh stays the truth.
#pragma once

#include "kiji/collision.h"
#include "kiji/garment.h"

#include <memory>
#include <string>
#include <vector>

namespace kiji {

class Solver;
namespace solver_detail {
// Whether the body keeps the cloth's edges out as well as its vertices (on in every solver but the
// drape's coarse copy, which keeps its vertices further out instead). Internal to the drape.
void set_body_edges(Solver& solver, bool on);
}  // namespace solver_detail

enum class SolverModel { Xpbd, MassSpring };
SolverModel parse_solver_model(const std::string& name);  // "xpbd" | "mass_spring"
std::string solver_model_name(SolverModel model);
// The threads the solvers' loops share (KIJI_THREADS, else the hardware's, at most 8), fixed for the
// process at its first use: what a benchmark reports it ran with.
int solver_threads();

struct SolverParams {
  SolverModel model = SolverModel::Xpbd;
  Vec3 gravity{0.0, -9.81, 0.0};
  int substeps = 10;             // substeps per step() call
  // Xpbd: substeps per step while a plain hand (a pinch: add_attachment, not firm) holds the
  // garment, where more than `substeps`. One sweep a substep carries the hand's pull a ring or two
  // of edges, so at 10 a hand dragging a whole garment stretches the cloth beside it; at 20 a third
  // as many edges go beyond 10 %, for about 1.3 times the step. 0: `substeps`.
  int held_substeps = 20;
  int iterations = 1;            // constraint iterations per substep (Xpbd)
  bool body_collision = true;
  bool self_collision = true;
  // Xpbd: strain limiting (Provot 1995): after each substep's constraint pass, edges stretched or
  // compressed by more than this fraction of their rest length are brought back to it, a few
  // Gauss-Seidel passes over the offending edges only. Woven cloth barely stretches; one pass of
  // small-step XPBD leaves local over-stretch where the cloth hangs on a contact. 0 turns it off.
  double strain_limit = 0.05;
  // MassSpring (the paper): spring constant k of eq. 3 and the damping gamma of eq. 1 (the paper
  // uses 0). Masses are 1, as in eq. 2.
  double spring_k = 100.0;
  double spring_damping = 0.0;
  // The paper's local region: when radius > 0, only vertices within `local_radius` of
  // `local_center` are computed; the others are held exactly where they are, still (velocity
  // zero), and fall or move on from rest when the region leaves them.
  double local_radius = 0.0;
  Vec3 local_center{0.0, 0.0, 0.0};
  // Sleeping: the live vertices are in blocks of about a thousand neighbours (compact patches).
  // A block whose every vertex has stayed within `sleep_distance` (m) of where it was for
  // `sleep_after` seconds falls asleep: it is held still (velocity zero) and costs nothing, as
  // the local region holds what is outside it, until something disturbs it: a vertex of a
  // neighbouring block, or of cloth in contact with it, moving more than sleep_distance; a hand
  // (attachment), a force or a seam on it; an edit of its vertices (position, velocity, pin) or
  // rest lengths; a topology edit; new physics (parameters, material, body). A garment at rest
  // on the body then costs what its moving part costs. sleep_after = 0 turns it off.
  double sleep_after = 0.5;
  double sleep_distance = 0.005;
  // A floor: with a body, the cloth rests on the horizontal plane through the body's lowest point
  // (its feet), the cloth's thickness above it, with the cloth's friction, as on the ground; cloth
  // cut away or dropped lands there rather than falling for ever. Cloth that is already below it
  // stays where it is. Without a body there is no floor.
  bool floor = true;

  // Throws InputError naming the parameter out of range.
  void validate() const;
};

// A force from a tool on one vertex, in newtons, for the next step (cleared after it).
struct ExternalForce {
  Vertex vertex;
  Vec3 force;
};

// What a user checks after a step: is the cloth at rest, on the body, not inside it, not torn apart.
struct ClothMeasures {
  double max_penetration = 0;    // deepest vertex inside the body surface, metres (0 = none)
  double max_strain = 0;         // largest |l / rest - 1| over edges
  double mean_strain = 0;
  double kinetic_energy = 0;     // joules
  std::size_t contacts = 0;      // vertices within 1.5 thickness of the body surface
  std::size_t vertices = 0;
  std::size_t sleeping = 0;      // vertices asleep after the last step (see SolverParams::sleep_after)
};

// What the last step did, for a profile or an app's status line.
struct StepReport {
  int substeps = 0;             // substeps the step took (SolverParams::held_substeps while a hand holds)
  int self_gathers = 0;         // searches for self-collision pairs (one per window of substeps)
  std::size_t self_pairs = 0;   // vertex-triangle pairs they found, summed over the searches
  // A search met more pairs than its budget: about 256 a vertex over each part of the cloth (the
  // vertex tree's subtrees), where cloth at work has at most about 160, in a fast whole-garment
  // drag, and a few at rest. Only a garment in a knot (cloth pulled through the body, or crushed
  // into a ball and thrown) has more; the search then keeps the pairs it met first and leaves out
  // the rest, so that the step still takes a bounded time and memory. (A 20,000-vertex garment
  // yanked 1.7 m through the body in one step had 35 million pairs, 3.3 GB and 24 s a step when
  // its knot tightened, and the next step ran out of memory; with the budget, at most 0.4 GB and
  // 3 s, and 0.2 s a step once the knot loosened.) Undo, or let go of what pulls it through itself.
  bool self_overloaded = false;
  // Edges found beyond the strain limit (SolverParams::strain_limit), summed over the substeps
  // (each substep's first look, before the limit projects them back). A few in a pulled seam or a
  // fold are the limit at work; a large share of the edges every substep means the cloth is held
  // by the limit rather than by its stretch constraints (a soft cloth, few substeps, a crash into
  // the body or into itself): more substeps or iterations, or a stiffer cloth, leave it less to do.
  std::size_t strain_limited = 0;
  // Where the step's time went: milliseconds of wall clock on the thread that called step(), by
  // phase (the rest of `total` mirrors the mesh into the solver's arrays and back, and sleeps), and
  // how much of it was in loops shared between threads: the part outside them (total - shared)
  // is what more cores cannot shorten. Measured, so it varies from run to run where the counts
  // above do not. The phases are the xpbd model's: the paper's mass-spring model gives only total
  // and shared.
  struct Times {
    double total = 0;
    double solve = 0;         // integration, hands, long-range limits, stretch, bending, seams
    double strain_limit = 0;
    double self_search = 0;   // gathering self-collision pairs
    double self_resolve = 0;  // keeping them apart
    double body = 0;          // body candidates, contacts, and vertices escaping their boxes
    // Building the arrays (constraints, colouring, long-range limits, collision trees) at the start
    // of the step: after a topology edit (a cut, a tear, a seam) or for a new garment; else zero.
    double rebuild = 0;
    double shared = 0;
  } ms;
};

class Solver {
 public:
  explicit Solver(SolverParams params = {});
  ~Solver();
  Solver(const Solver&) = delete;
  Solver& operator=(const Solver&) = delete;

  const SolverParams& params() const { return params_; }
  void set_params(const SolverParams& params);  // validates

  // The body to collide with (kept by reference; nullptr for none).
  void set_body(const Body* body);
  const BodyCollider* collider() const { return collider_.get(); }

  // Forces for the next step only.
  void add_external_force(Vertex v, const Vec3& force);

  // Attachments: a spring of `stiffness` N/m and zero rest length from a point in space to a vertex
  // (a tool's hand on the cloth), kept until removed. Xpbd solves it implicitly (as a constraint of
  // compliance 1 / stiffness), so a stiff hand on a light vertex stays stable; MassSpring adds its
  // force k (target - x) like any other force of eq. 2. Returns an id; an attachment to a vertex
  // that a topology edit removes is dropped.
  // Xpbd solves a plain attachment in the same sweep as the cloth's own constraints, before them,
  // so that the cloth pulls back: a hand brings the cloth along as far as the cloth's stiffness
  // carries it in the step, and does not pull a fine cloth out as a spike past its strain limit. The
  // hand has a mass of its own, carried by the vertex it holds, so that the cloth gets the hand's
  // stiffness however light the vertex (a cloth of weight W hangs W / k below the target), and its
  // target moves from where it was at the last step to where it is now over the step's substeps. A
  // `firm` one is projected after them and after the strain limit: it wins, and can stretch the
  // cloth past the limit (the tear tool pulls until the cloth tears).
  int add_attachment(Vertex v, const Vec3& target, double stiffness, bool firm = false);
  void move_attachment(int id, const Vec3& target);
  void remove_attachment(int id);
  std::size_t attachment_count() const { return attachments_.size(); }

  // Builds the solver's arrays for this garment now (constraints, colouring, long-range limits,
  // collision trees): what the first step after a new garment or a topology edit would otherwise
  // do. A caller that wants that step to come on time (a tool after a cut, a benchmark) pays for
  // it here. Does nothing when they are up to date.
  void prepare(const Garment& garment);

  // Advances the garment by dt seconds (params.substeps substeps), writing positions and velocities
  // back to the mesh. Throws InputError for dt <= 0 or non-finite, or if the garment's state is not
  // finite before the step. Never writes a non-finite state: a step that would (forces or pulls too
  // large for the time step) is undone and throws SimulationError, the garment as it was.
  void step(Garment& garment, double dt);

  // Total spring force on every vertex by the paper's eq. 3 (MassSpring), indexed by vertex index.
  std::vector<Vec3> spring_forces(const Garment& garment) const;

  ClothMeasures measure(const Garment& garment) const;

  // What the last step() did (zeros before the first).
  StepReport last_step() const;

 private:
  friend void solver_detail::set_body_edges(Solver& solver, bool on);
  SolverParams params_;
  const Body* body_ = nullptr;
  std::unique_ptr<BodyCollider> collider_;
  std::vector<ExternalForce> forces_;
  struct Attachment {
    int id;
    Vertex vertex;
    Vec3 target;
    Vec3 from;  // the target when the last step ended
    double stiffness;
    bool firm;
  };
  std::vector<Attachment> attachments_;
  int next_attachment_ = 0;
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace kiji
