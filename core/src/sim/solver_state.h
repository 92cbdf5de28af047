// The solver's flat arrays (structure of arrays), private to libkiji.
//
// Everything per vertex is indexed by the garment's vertex index (0 .. vertex_capacity()-1);
// removed vertices are inert (alive = 0, inverse mass 0, no constraints). The arrays are rebuilt
// when the garment's topology version changes and refreshed from the mesh (positions, velocities,
// inverse masses, rest lengths) at the start of every step: the mesh stays the truth.
#pragma once

#include "kiji/solver.h"

#include <BulletCollision/BroadphaseCollision/btDbvt.h>

#include <array>
#include <memory>
#include <chrono>
#include <cstdint>
#include <vector>

namespace kiji {

namespace solver_detail {
class BodyField;
}

// Where a garment's cloth sleeps, kept with the garment (see Garment::sleep_record), by vertex index.
struct SleepRecord {
  std::array<double, 15> physics{};  // what the resting shape depends on (as SolverArrays::physics)
  std::vector<Vec3> at;              // where the vertex sleeps; NaN where it does not
  std::vector<std::uint64_t> key;    // its edges, their rest lengths and its inverse mass, hashed
};

// What a solver carries from one step to the next beyond the garment's own state
// (Garment::step_record), for a solver built anew on the same mesh to step on as this one would.
struct StepRecord {
  std::uint64_t mesh = 0;  // the mesh's vertices and faces, hashed (mesh_key): whose record it is
  // Where the vertices lay when the arrays were built: their order, and from it the blocks, the
  // constraints' order, the long-range limits and the collision clusters. Kept through an edit for
  // the vertices it kept. Shared until a rebuild.
  std::shared_ptr<const std::vector<Vec3>> built_at;
  // Which vertices the mesh had then: a rebuild after an edit keeps where they lay (the order).
  std::shared_ptr<const std::vector<unsigned char>> built_alive;
  // The long-range anchors, level by level (S = 2, 4 ... 64), in the order the solver took them: a
  // rebuild after an edit keeps them where it can. Shared until a rebuild.
  std::shared_ptr<const std::vector<std::vector<int>>> anchors;
  std::vector<double> surprise, surprise_self;  // per vertex, as SolverArrays
  std::vector<unsigned char> held_up;
  // Sleeping as the last step left it (ready: the solver had its blocks; see solver_sleep.cpp):
  // per block whether it sleeps, how long it has been calm, and its vertices' positions, inverse
  // masses and edges' rest lengths hashed (an edit since the step disturbs it); per vertex its anchor.
  bool sleep_ready = false;
  std::array<double, 15> physics{};
  std::vector<unsigned char> asleep;
  std::vector<double> calm;
  std::vector<std::uint64_t> block_key;
  std::vector<Vec3> anchor;
};

// Memory a record holds (the journal's history budget counts it), its shared positions and anchors apart.
inline std::size_t bytes_of(const SleepRecord& r) {
  return sizeof(r) + r.at.size() * sizeof(Vec3) + r.key.size() * sizeof(std::uint64_t);
}
inline std::size_t bytes_of(const StepRecord& r) {
  return sizeof(r) + (r.surprise.size() + r.surprise_self.size() + r.calm.size()) * sizeof(double) +
         r.held_up.size() + r.asleep.size() + r.block_key.size() * sizeof(std::uint64_t) +
         r.anchor.size() * sizeof(Vec3);
}

struct SolverArrays {
  SolverArrays() = default;
  SolverArrays(const SolverArrays&) = delete;  // the trees point into their own node blocks
  SolverArrays& operator=(const SolverArrays&) = delete;

  // ---- identity of what the arrays mirror ----
  const Garment* garment = nullptr;
  std::uint64_t topology = 0;
  std::size_t n = 0;  // vertex capacity
  bool built = false;
  std::uint64_t mesh_key = 0;                         // solver_detail::mesh_key at the last rebuild
  std::shared_ptr<const std::vector<Vec3>> built_at;  // where the vertices lay for it (StepRecord)
  std::shared_ptr<const std::vector<unsigned char>> built_alive;  // which vertices it had (StepRecord)
  std::shared_ptr<const std::vector<std::vector<int>>> anchors;  // its long-range anchors (StepRecord)
  std::shared_ptr<const StepRecord> carried;          // the record it took up, until its sleep is too
  std::shared_ptr<StepRecord> written;                // the record it gave the garment last

  // ---- per vertex ----
  std::vector<unsigned char> alive;   // vertex exists
  std::vector<unsigned char> moving;  // integrated this step (alive, unpinned, in the local region)
  std::vector<int> order;             // alive vertices in spatial (Morton) order at the last rebuild
  std::vector<Vec3> x, xp, x0, v, fext, pred;
  std::vector<double> w;              // inverse mass used by the model (0 = fixed)
  std::vector<double> im_median;      // scratch: the live vertices' inverse masses, for their median
  std::vector<double> surprise;       // |end of the last step - its predicted end| (collision margin)
  std::vector<double> surprise_self;  // the same less the cloth's mean miss (self-collision margin)

  // ---- how the constraints are ordered and shared between threads ----
  // The live vertices are cut into blocks of about a thousand, consecutive in the spatial order.
  // Each set of constraints below is ordered in ranges [ranges[k], ranges[k + 1]) of a kind:
  //  - kFirstBlock, kBlock: the constraints within one block, solved in sequence by one thread;
  //    a kFirstBlock range and the kBlock ranges after it (the other blocks) are solved in
  //    parallel (no vertex is in two blocks);
  //  - kGroup: constraints across blocks of one colour (no shared vertex), solved in parallel;
  //  - kSerial: the colouring's overflow (they may share vertices), solved in sequence.
  // The ranges one after the other: Gauss-Seidel, and the same result whatever the thread count.
  enum RangeKind : unsigned char { kFirstBlock, kBlock, kGroup, kSerial };
  static constexpr int kMaxBlocks = 64;
  int blocks = 1;
  std::vector<int> block;             // per vertex: its block

  // ---- stretch: one distance constraint per edge ----
  std::vector<int> e_i, e_j;
  std::vector<Edge> e_handle;
  std::vector<double> e_rest;
  std::vector<int> e_ranges;
  std::vector<unsigned char> e_kinds;

  // ---- long-range stretch limits (hierarchical, unilateral): |x_i - x_j| <= rest ----
  // Between "anchor" vertices S = 2, 4, 8, ... edges apart, with rest = the shortest rest-length
  // path between them (never shorter than the flat distance, so never active unless the cloth is
  // stretched). Solved coarse to fine before the edges, they carry stretch across the cloth in one
  // sweep, as the coarse levels of hierarchical PBD (Mueller 2008) do.
  std::vector<int> l_i, l_j;
  std::vector<double> l_rest;
  std::vector<int> l_ranges;               // level by level, coarse to fine
  std::vector<unsigned char> l_kinds;
  // What the last rebuild's levels found, and the graph they searched (the cloth's edges at the two
  // fine levels, S = 2, 4; the finer level's limits at the coarse ones): a search from an anchor
  // reads only the graph within 2 S edges of the cloth from it, so the next rebuild searches again
  // only from the anchors near what an edit changed (build_long_range), and finds the same limits.
  struct LimitSearch {
    std::vector<char> anchor;        // per vertex: an anchor of the level
    std::vector<int> first, count;   // per vertex: its search's limits in to / rest / edges
    std::vector<int> to, edges;
    std::vector<double> rest;
    std::vector<int> g_begin, g_to, g_edges;  // a coarse level's graph: the finer level's limits
    std::vector<double> g_len;
  };
  std::array<LimitSearch, 4> searched;  // S = 2 ... 16
  std::vector<int> searched_nbr_begin, searched_nbr;  // the adjacency those searches read
  std::vector<double> searched_nbr_rest;
  int searches = 0;  // searches the last rebuild ran (the rest were kept)

  // ---- bending: isometric (quadratic) bending per interior edge ----
  struct Bend {
    int v[4];       // edge endpoints a, b and the opposite vertices c, d
    double g[4];    // sqrt(1 / (A0 + A1)) * K_i, the constant gradient weights
  };
  std::vector<Bend> bends;
  std::vector<int> b_ranges;
  std::vector<unsigned char> b_kinds;

  // ---- this step's share of the constraints ----
  // When some live vertices are held this step (pins, the paper's local region), the constraints
  // with a moving vertex are copied here in the same order and the same ranges (as many ranges as
  // the full arrays, of the same kinds, empty ones included), so that a region of 1,000 moving
  // vertices in a 20,000-vertex garment costs what 1,000 vertices cost; when every live vertex
  // moves, the full arrays are used as they are. The copies are sized for all the constraints
  // (each is written, kept or not, without a branch); their ranges' last offset is how many are kept.
  std::vector<int> act;               // the moving vertices, in index order
  std::vector<int> ae_i, ae_j, ae_ranges;
  std::vector<double> ae_rest;
  std::vector<int> al_i, al_j, al_ranges;
  std::vector<double> al_rest;
  std::vector<Bend> a_bends;
  std::vector<int> ab_ranges;
  std::vector<double> lam_e;          // XPBD multipliers (reset every substep)
  std::vector<Vec3> lam_b;
  std::vector<Vec3> force;            // MassSpring: force per vertex

  // ---- hands and tacks: zero-length springs to a point, and between two vertices ----
  struct Attach {
    int i;
    Vec3 target;
    Vec3 from;  // the target at the last step's end: a plain hand's target moves from it over the substeps
    double k;   // N/m
    bool firm;  // projected after the cloth's constraints (wins), or with them
  };
  std::vector<Attach> attach;
  std::vector<std::array<int, 2>> tacks;
  // An edge beyond the strain limit: its index and, for the passes, its ends and rest length.
  struct OverEdge {
    int k, i, j;
    double rest;
  };
  std::vector<OverEdge> over;  // edges beyond the strain limit this substep, in edge order
  std::vector<std::vector<int>> over_pieces;  // each scan piece's scratch: its edges' indices, those beyond first
  std::vector<std::vector<OverEdge>> over_found;  // each piece's edges beyond, with their ends
  std::vector<int> over_runs;  // where each colour starts in `over`

  // ---- faces and adjacency ----
  std::vector<std::array<int, 3>> tris;
  std::vector<int> nbr_begin, nbr;    // CSR of vertex neighbours (edges)
  std::vector<double> nbr_rest;       // rest length of each neighbour's edge
  std::vector<double> spacing;        // per vertex: shortest incident rest length

  // ---- body collision (candidates gathered once per step, used by every substep) ----
  const Body* body = nullptr;
  std::shared_ptr<const solver_detail::BodyField> field;  // the body's distance field
  struct BodyTri {
    Vec3 a, b, c, n;
  };
  std::vector<BodyTri> body_tris;
  std::vector<Box3> body_boxes;
  Box3 body_bounds;
  // The body's sharp points (find_body_points) and, for a step, the cloth triangles near each.
  std::vector<Vec3> body_points;
  struct PointPair {
    int point, t;
    double side;  // +1 / -1: the side of the triangle the point was on when the pair was gathered
  };
  std::vector<PointPair> point_pairs;
  std::vector<int> point_held;  // this substep: the vertices of triangles a point pushed up
  std::vector<unsigned char> escaped;  // per vertex: moved further than a field cell in the substep
  bool body_edges = true;  // solver_detail::set_body_edges
  std::vector<float> body_gap;  // per vertex: at least how far from the body it was (0: not known)
  std::vector<float> body_turn;  // per vertex: BodyField::turn of its cell (1 far from the body, -1 not known)
  std::vector<int> escapees;           // those vertices, in index order
  // resolve_body_edges shared among threads: per edge, whether it would push; per vertex, whether
  // an edge moved it in this pass (all 0 between passes), and those vertices.
  std::vector<char> edge_pushes;
  std::vector<unsigned char> edge_moved;
  std::vector<int> edge_moved_list;

  // ---- self collision: two btDbvt trees, refitted at each gather, whose leaves are clusters of
  // nearby vertices and of nearby triangles (runs in Morton order); cluster c holds the items
  // *_items[*_begin[c] .. *_begin[c + 1]). A leaf per item made the trees' own traversal most of a
  // gather's cost (20 leaf overlaps a vertex at rest, nearly all its own neighbourhood); a leaf
  // per cluster tests its items' boxes in a flat loop instead. ----
  static constexpr int kVertCluster = 8, kTriCluster = 8;
  btDbvt tri_tree, vert_tree;
  // The trees' nodes, one block each (build_tree): a rebuild drops the block instead of freeing
  // thousands of nodes one by one. The trees are let go of them before a btDbvt would free them.
  std::vector<btDbvtNode> tri_nodes, vert_nodes;
  struct LetGoOfNodes {
    SolverArrays* s;
    ~LetGoOfNodes() { s->tri_tree.m_root = s->vert_tree.m_root = nullptr; }
  } let_go_of_nodes{this};
  std::vector<int> vcl_begin, vcl_items, tcl_begin, tcl_items;
  std::vector<btDbvtNode*> vcl_leaf, tcl_leaf;
  // Per vertex (in cluster order, as vcl_items): the triangles it is never paired with, those with
  // a corner at it or at a neighbour (close at rest), as bits of their clusters: the masks
  // excl_mask[k] of the triangle clusters excl_cluster[k], k in [excl_begin[p], excl_begin[p + 1]).
  // About 20 triangles a vertex, most of the boxes it meets: testing them was most of a gather.
  std::vector<int> excl_begin, excl_cluster;
  std::vector<std::uint8_t> excl_mask;
  // Boxes in floats rounded outwards (an empty one: lo > hi); a triangle cluster's side by side for
  // a search (tested against a vertex's all at once).
  struct FloatBox {
    float lo[3], hi[3];
  };
  struct TriClusterBoxes {
    alignas(16) float lo[3][kTriCluster];
    alignas(16) float hi[3][kTriCluster];
  };
  std::vector<TriClusterBoxes> tri_cluster_live;
  // Culling in moving frames (see gather_self_pairs): each cluster's frame, a motion its items are
  // swept less, and the same as a float box that holds it.
  std::vector<Vec3> vcl_frame, tcl_frame;
  std::vector<FloatBox> vcl_frame_box, tcl_frame_box;
  struct SelfPair {
    int v, t;
    double side;  // +1 / -1: the side of the triangle the vertex was on when the pair was gathered
    double d0;    // their distance then
  };
  std::vector<SelfPair> self_pairs;
  // Per triangle at the gather: its unit normal (zero when it has no area), centroid and the radius
  // of the sphere about it (self_pair_test).
  std::vector<Vec3> tri_n, tri_g;
  std::vector<double> tri_r;
  // The pairs in runs [self_runs[r], self_runs[r + 1]): those before self_runs_serial_from share
  // no vertex with another run's and are resolved together; the rest in sequence (see
  // partition_self_pairs).
  std::vector<int> self_runs;
  int self_runs_serial_from = 0;
  std::vector<double> pair_key;
  std::vector<unsigned char> pair_slab;
  std::vector<SelfPair> pair_scratch;
  std::vector<std::vector<SelfPair>> self_gather;  // one list per vertex subtree, joined in order
  std::vector<unsigned char> self_gather_full;     // per subtree: its list reached its budget
  // What each triangle and vertex sweeps in the window (when the gathering makes two searches,
  // only the moving vertices' and the triangles' with a moving corner are kept), and the box it
  // takes part in this search with (its own, or none), both in cluster order (indexed as *_items).
  std::vector<FloatBox> tri_box, vert_box, tri_live, vert_live;
  // Per vertex, for skipping far pairs: the length of its path since the pairs were gathered, up
  // to the last substep, and up to now (path + this substep's motion + the self-collision pushes).
  std::vector<double> path, reach;
  // Per vertex: the body held it up (pushed it out against gravity, or it lies within a small
  // margin of the thickness above an upward surface, or a body's point pushed one of its
  // triangles up) in the last substep; reset by
  // rebuild, and each step for a vertex with no body triangle near. `up` is against gravity (zero
  // without it). A long-range limit from a held vertex to cloth hanging below moves only the
  // hanging end while no hand holds the garment (step_xpbd).
  std::vector<unsigned char> held_up;
  // Per vertex: how far such a limit moved it this substep beyond its own share; the move is kept
  // as position and not turned into velocity (moved the whole way as velocity, it was a kick).
  std::vector<Vec3> unkick;
  Vec3 up = Vec3::Zero();
  std::vector<Vec3> win;  // per vertex: its predicted motion over the window of the last gather

  // ---- sleeping (see SolverParams::sleep_after), reset to all awake by rebuild ----
  bool sleep_ready = false;
  std::vector<int> block_start, block_verts;  // CSR: each block's live vertices
  std::vector<std::uint64_t> block_nbrs;      // per block: the blocks it shares an edge with (<= 64)
  std::vector<unsigned char> asleep;          // per block
  std::vector<unsigned char> hold_awake;      // per block: a hand, force or open seam on it this step
  std::vector<double> calm;                   // per block: seconds its vertices stayed near their anchors
  std::vector<Vec3> anchor;                   // per vertex: where its block's calm began, or where it sleeps
  std::vector<double> im;                     // per vertex: the garment's inverse mass at the last step
  std::vector<double> settle_disp;            // per block: the farthest a vertex is from its anchor
  std::array<double, 15> physics{};           // what the motion depends on, to wake all when it changes
  std::size_t sleeping = 0;                   // vertices asleep
  std::vector<std::uint64_t> sleep_key;       // per vertex: its edges, rest lengths and mass, hashed (scratch)

  // ---- diagnostics of the last step ----
  std::size_t last_self_pairs = 0;
  StepReport report;  // what the last step did (Solver::last_step)
};

// Adds the wall-clock time from its making to its end to one of the step report's figures (ms).
class PhaseClock {
 public:
  explicit PhaseClock(double& ms) : ms_(&ms), start_(std::chrono::steady_clock::now()) {}
  ~PhaseClock() { stop(); }
  PhaseClock(const PhaseClock&) = delete;
  PhaseClock& operator=(const PhaseClock&) = delete;
  // Ends the phase before the end of the scope.
  void stop() {
    if (ms_) *ms_ += 1000 * std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    ms_ = nullptr;
  }

 private:
  double* ms_;
  std::chrono::steady_clock::time_point start_;
};

// Implemented in the model files (Solver::State derives from SolverArrays).
namespace solver_detail {
void step_xpbd(SolverArrays& s, const SolverParams& p, const Material& m, const BodyCollider* body, double dt);
void step_mass_spring(SolverArrays& s, const SolverParams& p, const Material& m, const BodyCollider* body, double dt);
void rebuild(SolverArrays& s, const Garment& g);
void set_body(SolverArrays& s, const Body* body);
// Pushes vertex i out of the body to `thickness`, on the side it came from (xp), with friction.
void resolve_body_against(SolverArrays& s, int i, double thickness, double friction, const int* tris, int count);
// A point of the body thinner than the cloth's spacing (a low-poly fingertip, the tip of a horn)
// would pass between the cloth's vertices, which alone are kept out of the body, and hold the cloth
// from inside: the body's sharp points are kept on the side of the cloth's triangles they started
// on, to the thickness, with the body's friction, and a triangle a point pushes up is held up
// (SolverArrays::held_up) as a vertex the faces push up is: a cloth resting on a point is held as
// on the body's faces (without friction, cloth on a figure's highest points slid off them).
// find_body_points on a new body; the pairs gathered each step.
void find_body_points(SolverArrays& s, const Body& body);
void gather_point_pairs(SolverArrays& s, double thickness);
void resolve_point_pairs(SolverArrays& s, double thickness, double friction);
// The body's distance field for this thickness (BodyField::of), when the body is new or the field
// does not reach as far as the thickness needs.
void prepare_body_field(SolverArrays& s, double thickness);
// The vertices `verts` against the body at the end of a substep: a vertex the field finds within
// reach of the body, against the triangles its cell lists; one that moved further than a cell in
// the substep (a flick of the pen), against what the body's tree finds along its motion, so that
// it cannot pass through a triangle its cell does not list. With `floor`, then against the floor
// through the body's lowest point (SolverParams::floor).
void resolve_body(SolverArrays& s, const BodyCollider& collider, const std::vector<int>& verts, double thickness,
                  double friction, bool floor);
// The points of the edges [b, e) of (ei, ej) between their ends against the body, after
// resolve_body (which prepares the field and each moving vertex's gap and turn): kept `clearance`
// out of it on the side they came from, with friction, each end moved by its share. Vertices alone
// let a part of the body thinner than the cloth's spacing (an ear, a finger, a wing's edge) pass
// between them and hold the cloth from inside. Points at most twice the clearance apart, at most
// kEdgePoints of them; edges far from the body or over a smooth part of it are passed over.
constexpr int kEdgePoints = 32;
// `whole`: [b, e) is every edge of the cloth, swept on this thread (a cloth of one block), and the
// pass may share its work among the threads.
void resolve_body_edges(SolverArrays& s, const BodyCollider& collider, const int* ei, const int* ej, int b, int e,
                        double thickness, double clearance, double friction, bool whole = false);
// Vertex-triangle pairs that can come within the thickness while the vertices move by `win` (from
// x), with the last step's surprise_self times surprise_scale as slack.
void gather_self_pairs(SolverArrays& s, double thickness, double surprise_scale);
// Whether gather_self_pairs makes one search of everything, each cluster culled in its own frame
// (everything moves but a few pins), rather than two in the frame of the moving part (a local
// region).
inline bool self_search_whole(const SolverArrays& s) {
  const std::size_t moving = s.act.size(), held = s.order.size() - moving;
  return 10 * held < moving;
}
void resolve_self(SolverArrays& s, double thickness);
// Orders the gathered pairs in slabs for resolve_self (after each gather).
void partition_self_pairs(SolverArrays& s);
// Fewer pairs than this are resolved in sequence as gathered; more, in this many slabs (a pen's
// local stroke at 20,000 vertices gathers 13 to 12,700 pairs, median 2,800).
constexpr std::size_t kParallelSelfPairs = 2048;
constexpr int kSelfSlabs = 4;
// Sleeping (solver_sleep.cpp). Before a step, after the mesh is mirrored: wakes every block when the
// physics changed or the arrays were rebuilt, and the blocks that `disturbed` marks; then clears
// `moving` of the vertices asleep. After the step: wakes the sleeping neighbours of cloth that moved,
// and puts to sleep the blocks calm long enough (their velocities set to zero).
// After a rebuild, the blocks every vertex of which `carried` (the garment's sleep record, or null)
// finds exactly as it slept start asleep.
void sleep_before_step(SolverArrays& s, const SolverParams& p, const Material& m, const std::vector<unsigned char>& disturbed,
                       const SleepRecord* carried);
// Returns whether a block fell asleep.
bool sleep_after_step(SolverArrays& s, const SolverParams& p, double dt);
// The garment's vertices (capacity and which are alive) and faces, hashed whatever the faces' order
// and first corner: a step record is this mesh's when its key is this.
std::uint64_t mesh_key(const Garment& g);
// Gives the garment what the solver carries to its next step (Garment::step_record), after a step.
void write_step_record(SolverArrays& s, Garment& g);
// The record of where the cloth sleeps now, for the garment (see Garment::sleep_record).
std::shared_ptr<const SleepRecord> sleep_record(SolverArrays& s);
}  // namespace solver_detail

}  // namespace kiji
