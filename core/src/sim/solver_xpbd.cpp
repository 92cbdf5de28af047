// The default model: XPBD with small steps (Macklin et al. 2019, "Small steps in physics
// simulation"): many substeps per frame, one constraint iteration each.
//
//  - stretch: a distance constraint per edge, compliance 1 / k_e with the edge stiffness
//    k_e = material.stretch_stiffness (N/m). On a regular triangulation this keeps the sheet's
//    stiffness independent of the resolution (springs in series and in parallel cancel);
//  - bending: the isometric (quadratic) bending model of Bergou et al. 2006 as a vector constraint
//    C = sqrt(1 / (A0 + A1)) * sum_i K_i x_i on the four vertices of each interior edge, with
//    energy (k_b / 2) |C|^2, k_b = material.bending_stiffness (N m): the discrete Willmore energy of
//    a flat pattern, with a constant gradient, so one projection is a handful of multiply-adds and
//    needs no trigonometry (a dihedral-angle constraint costs an acos, two cross products and
//    normalisations per edge, and is singular at flat and folded states);
//  - damping: velocities decay at material.damping (1/s);
//  - pins (inverse mass 0), gravity, external forces;
//  - body collision with the thickness and Coulomb friction, continuous (see solver_collide.cpp);
//  - self-collision: vertex against cloth triangle at the thickness.
// The constraints are solved in the ranges rebuild ordered them in (see SolverArrays): the blocks
// of the cloth in parallel, each in sequence, then the constraints across blocks colour by colour.
#include "base/parallel.h"
#include "sim/solver_state.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

namespace kiji::solver_detail {

namespace {

// The constraints a step solves: the solver's full arrays, or (when a tenth or more of the live
// vertices are held) this step's copy of those with a moving vertex (same order, same ranges).
struct Constraints {
  const int *e_i, *e_j;
  const double* e_rest;
  const std::vector<int>* e_ranges;
  int ne;
  const int *l_i, *l_j;
  const double* l_rest;
  const std::vector<int>* l_ranges;
  const SolverArrays::Bend* bends;
  const std::vector<int>* b_ranges;
  int nb;
};

// Copies of the ranges [offsets[c], offsets[c + 1]) keeping those `keep` says (0 or 1), with the
// same number of ranges (each keeps its index, and so its kind). Without a branch a constraint:
// each is copied to the next place, which moves on only if it is kept (under a local region the
// kept constraints are scattered, so a branch on each would be mispredicted often). The copies
// are sized for all the constraints; the ranges say how many are kept.
template <typename Keep, typename Put>
void select_ranges(const std::vector<int>& offsets, std::vector<int>& out_offsets, Keep keep, Put put) {
  out_offsets.assign(1, 0);
  int kept = 0;
  for (std::size_t c = 0; c + 1 < offsets.size(); ++c) {
    for (int k = offsets[c]; k < offsets[c + 1]; ++k) {
      put(kept, k);
      kept += keep(k);
    }
    out_offsets.push_back(kept);
  }
}

template <typename T>
void size_for(std::vector<T>& v, std::size_t n) {
  if (v.size() < n) v.resize(n);
}

// The same for constraints between two vertices (i, j, rest): those with a moving end.
void select_pairs(const std::vector<int>& offsets, const std::vector<int>& i, const std::vector<int>& j,
                  const std::vector<double>& rest, const unsigned char* moving, std::vector<int>& out_offsets,
                  std::vector<int>& out_i, std::vector<int>& out_j, std::vector<double>& out_rest) {
  size_for(out_i, i.size());
  size_for(out_j, i.size());
  size_for(out_rest, i.size());
  int *oi = out_i.data(), *oj = out_j.data();
  double* orest = out_rest.data();
  select_ranges(
      offsets, out_offsets, [&](int k) { return int(moving[i[k]] | moving[j[k]]); },
      [&](int q, int k) {
        oi[q] = i[k];
        oj[q] = j[k];
        orest[q] = rest[k];
      });
}

Constraints select_constraints(SolverArrays& s) {
  const unsigned char* M = s.moving.data();
  s.act.clear();
  std::size_t live = 0;
  for (std::size_t i = 0; i < s.n; ++i) {
    live += s.alive[i];
    if (M[i]) s.act.push_back(static_cast<int>(i));
  }
  // A few held vertices (pins) hold back few constraints: copying would cost more than it saves.
  if (10 * s.act.size() >= 9 * live)
    return {s.e_i.data(), s.e_j.data(), s.e_rest.data(), &s.e_ranges, static_cast<int>(s.e_i.size()),
            s.l_i.data(), s.l_j.data(), s.l_rest.data(), &s.l_ranges,
            s.bends.data(), &s.b_ranges, static_cast<int>(s.bends.size())};
  select_pairs(s.e_ranges, s.e_i, s.e_j, s.e_rest, M, s.ae_ranges, s.ae_i, s.ae_j, s.ae_rest);
  select_pairs(s.l_ranges, s.l_i, s.l_j, s.l_rest, M, s.al_ranges, s.al_i, s.al_j, s.al_rest);
  size_for(s.a_bends, s.bends.size());
  SolverArrays::Bend* ab = s.a_bends.data();
  select_ranges(
      s.b_ranges, s.ab_ranges,
      [&](int k) {
        const int* v = s.bends[k].v;
        return int(M[v[0]] | M[v[1]] | M[v[2]] | M[v[3]]);
      },
      [&](int q, int k) { ab[q] = s.bends[k]; });
  return {s.ae_i.data(), s.ae_j.data(), s.ae_rest.data(), &s.ae_ranges, s.ae_ranges.back(),
          s.al_i.data(), s.al_j.data(), s.al_rest.data(), &s.al_ranges,
          s.a_bends.data(), &s.ab_ranges, s.ab_ranges.back()};
}

constexpr int kVertexGrain = 2048, kConstraintGrain = 256;
// A plain hand's mass, in units of k h^2 (its stiffness times the substep squared).
constexpr double kHandMass = 25.0;

// A plain hand is a body of its own: each vertex it holds carries kHandMass k h^2 more mass (k the
// stiffness of the hands on it), so that one projection of its spring gives the cloth
// kHandMass / (kHandMass + 1) of the stiffness, where the vertex's own mass alone capped it at
// m / h^2 (1.8-3.5 N/m for one vertex of a fine cloth: docs/benchmarks.md, "A hand's pull"). The
// hand holds itself up (gravity pulls only the cloth's mass) and is damped critically about the
// target's motion, so it follows a moving pen without ringing.
struct Held {
  int i;
  double k = 0;            // the hands' stiffness on the vertex
  Vec3 vt = Vec3::Zero();  // the targets' velocity (stiffness-weighted)
  double own = 1;          // the cloth's share of the vertex's mass
  Vec3 v0 = Vec3::Zero();  // its velocity as the substep began
};

// The vertices the plain hands hold, one entry a vertex however many hands hold it, with the hands'
// mass added to their inverse masses in s.w for this step (the next step's mirror writes them anew).
std::vector<Held> weigh_hands(SolverArrays& s, double dt, double h) {
  std::vector<Held> held;
  for (const auto& a : s.attach)
    if (!a.firm && s.w[a.i] != 0) held.push_back({a.i, a.k, a.k * (a.target - a.from) / dt});
  std::stable_sort(held.begin(), held.end(), [](const Held& a, const Held& b) { return a.i < b.i; });
  std::size_t kept = 0;
  for (std::size_t r = 0; r < held.size(); ++r) {
    if (kept > 0 && held[kept - 1].i == held[r].i) {
      held[kept - 1].k += held[r].k;
      held[kept - 1].vt += held[r].vt;
    } else {
      held[kept++] = held[r];
    }
  }
  held.resize(kept);
  for (Held& hv : held) {
    hv.vt /= hv.k;
    const double mass = 1.0 / s.w[hv.i] + kHandMass * hv.k * h * h;
    hv.own = 1.0 / (s.w[hv.i] * mass);
    s.w[hv.i] = 1.0 / mass;
  }
  return held;
}

// Runs f(begin, end) over the ranges [offsets[k], offsets[k + 1]) one after the other, each as its
// kind says (see SolverArrays): a run of blocks together in parallel, each block in sequence; a
// colour group in parallel pieces; the overflow group in sequence. The blocks of a run (at most
// kMaxBlocks: rebuild makes no more) are handed to the threads one at a time, the largest first
// (a local region fills some blocks and leaves the others empty), so the threads end together.
template <typename F>
void run_ranges(const std::vector<int>& offsets, const std::vector<unsigned char>& kinds, F& f) {
  const int ranges = static_cast<int>(offsets.size()) - 1;
  for (int k = 0; k < ranges;) {
    const int b = offsets[k], e = offsets[k + 1];
    if (kinds[k] == SolverArrays::kFirstBlock) {
      int last = k + 1;
      while (last < ranges && kinds[last] == SolverArrays::kBlock) ++last;
      int order[SolverArrays::kMaxBlocks];
      int count = 0, total = 0;
      for (int q = k; q < last; ++q)
        if (offsets[q + 1] > offsets[q]) order[count++] = q, total += offsets[q + 1] - offsets[q];
      if (total <= kConstraintGrain) {
        for (int c = 0; c < count; ++c) f(offsets[order[c]], offsets[order[c] + 1]);
      } else {
        std::sort(order, order + count, [&](int x, int y) {
          const int sx = offsets[x + 1] - offsets[x], sy = offsets[y + 1] - offsets[y];
          return sx != sy ? sx > sy : x < y;
        });
        parallel::for_each(count, [&](int c) { f(offsets[order[c]], offsets[order[c] + 1]); });
      }
      k = last;
      continue;
    }
    if (kinds[k] == SolverArrays::kSerial)
      f(b, e);
    else
      parallel::for_range(e - b, kConstraintGrain, [&](int lo, int hi) { f(b + lo, b + hi); });
    ++k;
  }
}

// run_ranges over f(kept, begin, end), kept a std::bool_constant: whether f keeps the XPBD
// multipliers (more than one iteration) or takes them as zero and leaves them be (one: each is
// zero when its constraint is projected).
template <typename F>
void with_multipliers(bool multipliers, const std::vector<int>& offsets, const std::vector<unsigned char>& kinds,
                      F& f) {
  if (multipliers) {
    auto kept = [&](int b, int e) { f(std::true_type{}, b, e); };
    run_ranges(offsets, kinds, kept);
  } else {
    auto left = [&](int b, int e) { f(std::false_type{}, b, e); };
    run_ranges(offsets, kinds, left);
  }
}

// Projects every edge beyond (1 +- limit) x rest back to the limit (Provot 1995): Gauss-Seidel
// passes over the edges found beyond it. Fixing one edge can push a neighbour past the limit, so
// the edges are looked for again, a few rounds at most; each round costs one scan of the edges and
// the passes touch only the offending ones. Short rounds, looked for again, reach the folds and
// crowns that one long round leaves beyond the limit (docs/benchmarks.md, "Figures behind the
// solver's choices").
void limit_strain(SolverArrays& s, const Constraints& cs, double limit) {
  constexpr int kRounds = 4, kPasses = 2;
  Vec3* X = s.x.data();
  const double* W = s.w.data();
  const int ne = cs.ne;
  const double hi = 1 + limit, lo = 1 - limit, hi2 = hi * hi, lo2 = lo * lo;
  for (int round = 0; round < kRounds; ++round) {
    // The scan in contiguous pieces (in parallel), each into its own list, joined in order.
    // Without a branch an edge: in a garment pulled taut the edges beyond the limit are many and
    // scattered, so a branch on each would be mispredicted often.
    const int pieces = std::max(1, std::min(32, ne / 1024));
    s.over_pieces.resize(pieces);
    s.over_found.resize(pieces);
    parallel::for_range(pieces, 1, [&](int p0, int p1) {
      for (int piece = p0; piece < p1; ++piece) {
        const int k0 = parallel::piece_begin(ne, piece, pieces), k1 = parallel::piece_begin(ne, piece + 1, pieces);
        std::vector<int>& out = s.over_pieces[piece];
        if (out.size() < static_cast<std::size_t>(k1 - k0)) out.resize(k1 - k0);
        int* o = out.data();
        int count = 0;
        for (int k = k0; k < k1; ++k) {
          const double r = cs.e_rest[k];
          const double l2 = (X[cs.e_i[k]] - X[cs.e_j[k]]).squaredNorm();
          o[count] = k;
          count += int(l2 > hi2 * r * r) | int(l2 < lo2 * r * r);  // rounded as before: the same edges
        }
        // Each with its ends and rest length beside it: the passes read one record an edge.
        std::vector<SolverArrays::OverEdge>& found = s.over_found[piece];
        found.resize(count);
        for (int q = 0; q < count; ++q) found[q] = {o[q], cs.e_i[o[q]], cs.e_j[o[q]], cs.e_rest[o[q]]};
      }
    });
    s.over.clear();
    for (int piece = 0; piece < pieces; ++piece)
      s.over.insert(s.over.end(), s.over_found[piece].begin(), s.over_found[piece].end());
    if (round == 0) s.report.strain_limited += s.over.size();
    if (s.over.empty()) return;
    // The offending edges are in edge order: they fall in the edges' ranges, and each range's run
    // is projected as the range is (blocks in parallel, each in sequence; colour groups in
    // parallel; the overflow in sequence): the same result as one thread.
    auto project = [&](int b, int e) {
      for (int q = b; q < e; ++q) {
        const SolverArrays::OverEdge& edge = s.over[q];
        const int i = edge.i, j = edge.j;
        const double wi = W[i], wj = W[j];
        const double wsum = wi + wj;
        if (wsum == 0) continue;
        const Vec3 d = X[i] - X[j];
        const double len = d.norm();
        if (!(len > 1e-12)) continue;
        const double r = edge.rest;
        const double target = std::clamp(len, lo * r, hi * r);
        if (target == len) continue;
        const Vec3 corr = d * ((target - len) / (len * wsum));
        X[i] += wi * corr;
        X[j] -= wj * corr;
      }
    };
    const std::vector<int>& ranges = *cs.e_ranges;
    s.over_runs.assign(1, 0);
    for (std::size_t c = 0; c + 1 < ranges.size(); ++c)
      s.over_runs.push_back(static_cast<int>(
          std::lower_bound(s.over.begin() + s.over_runs.back(), s.over.end(), ranges[c + 1],
                           [](const SolverArrays::OverEdge& e, int k) { return e.k < k; }) -
          s.over.begin()));
    for (int pass = 0; pass < kPasses; ++pass) run_ranges(s.over_runs, s.e_kinds, project);
  }
}

}  // namespace

// How many substeps one gather of self-collision pairs serves. A gather finds the pairs that can
// come within the thickness while each vertex moves along its velocity for the window: about as
// many, around a vertex, as there are triangles within its reach, the thickness plus its motion
// relative to the cloth near it over the window (culling is in each cluster's moving frame, see
// gather_self_pairs); each pair found is looked at again in every substep of the window. Cloth
// dragged fast across itself moves centimetres a step relative to what it slides over, and a
// gather for the whole step finds the pairs within those centimetres. Shorter windows find fewer
// pairs but gather more often, and a gather has a cost of its own (the trees' search, most of it
// the boxes of neighbouring clusters that meet at rest). The window taken is the cheapest under
// that cost model, per step:
//   substeps / K * (gathers' own cost + pairs(K)) + substeps * 0.13 * pairs(K),
//   pairs(K) ~ sum over the moving vertices of (th + K / substeps * |motion - cluster's motion|)^2,
// with the gathers' own cost worth 1.2 spacing^2 of reach^2 a vertex and a pair looked at in a
// substep 0.13 of a pair gathered (the ratios of their measured costs: docs/benchmarks.md,
// "Figures behind the solver's choices"). Cloth at rest or moving together gets the whole step;
// cloth in a hurry a few substeps. The motion is priced against its own cluster's, not the whole
// cloth's mean, so that a finer mesh of the same cloth does not get shorter windows.
static int self_window(const SolverArrays& s, const SolverParams& p, double th) {
  const int substeps = p.substeps;
  if (!p.self_collision || substeps == 1) return substeps;
  const std::size_t nm = s.act.size();  // the moving vertices
  if (nm == 0) return substeps;
  Vec3 c = Vec3::Zero();
  for (int i : s.act) c += s.pred[i];
  c /= double(nm);
  // Sums over the moving vertices of |u| and |u|^2, u their motion less the whole cloth's mean
  // motion, and of their spacing.
  double su = 0, su2 = 0, spacing = 0;
  for (int i : s.act) {
    const double u = (s.pred[i] - c).norm();
    su += u, su2 += u * u, spacing += s.spacing[i];
  }
  if (self_search_whole(s)) {  // culled in each cluster's own frame
    // The same with u less the vertex's cluster's motion...
    double sl = 0, sl2 = 0;
    const int clusters = static_cast<int>(s.vcl_begin.size()) - 1;
    for (int k = 0; k < clusters; ++k) {
      const int b = s.vcl_begin[k], e = s.vcl_begin[k + 1];
      Vec3 mean = Vec3::Zero();
      for (int q = b; q < e; ++q) mean += s.pred[s.vcl_items[q]];  // a held vertex's: zero
      mean /= double(e - b);
      for (int q = b; q < e; ++q) {
        const int i = s.vcl_items[q];
        if (!s.moving[i]) continue;
        const double u = (s.pred[i] - mean).norm();
        sl += u, sl2 += u * u;
      }
    }
    // ...but where layers lie on each other (the last gather found pairs), one may slide across
    // the other, and the motion that counts there is relative to the other layer, which the
    // cloth's mean stands for: priced between the two by the pairs a moving vertex had (at rest on
    // itself, a layer's vertex has one or two).
    const double layered = std::min(1.0, double(s.last_self_pairs) / double(nm));
    su = sl + layered * (su - sl);
    su2 = sl2 + layered * (su2 - sl2);
  }
  spacing /= double(nm);
  const double r = std::min(th, 0.6 * spacing);
  const double own = 1.2 * spacing * spacing * double(nm);
  int best = substeps;
  double best_cost = 0;
  for (int k = substeps; k >= 1; --k) {
    const double f = double(k) / substeps;
    const double pairs = double(nm) * r * r + 2 * r * f * su + f * f * su2;
    const double cost = double(substeps) / k * (own + pairs) + substeps * 0.13 * pairs;
    if (k == substeps || cost < best_cost) best = k, best_cost = cost;
  }
  return best;
}

void step_xpbd(SolverArrays& s, const SolverParams& p, const Material& m, const BodyCollider* body,
               double dt) {
  const int substeps = p.substeps;
  const double h = dt / substeps;
  const std::size_t n = s.n;
  const double th = m.thickness;
  const Vec3 g = p.gravity;

  const Constraints cs = select_constraints(s);
  const int* act = s.act.data();
  const int na = static_cast<int>(s.act.size());

  // Predicted motion over the whole step, for collision culling. Gravity is left out: on cloth
  // resting on the body or on itself (most of a draped garment) the contacts cancel it, and it
  // would give every resting vertex g dt^2 = 2.7 mm more box (more candidates and pairs) for
  // nothing; on falling cloth the boxes' slack and the last step's surprise (|end - predicted
  // end|, which is then about g dt^2) cover it.
  parallel::for_range(static_cast<int>(n), kVertexGrain, [&](int b, int e) {
    for (int i = b; i < e; ++i) {
      s.pred[i] = s.moving[i] ? Vec3(s.v[i] * dt + (s.w[i] * s.fext[i]) * (dt * dt)) : Vec3::Zero();
      s.x0[i] = s.x[i];
    }
  });
  {
    PhaseClock clock(s.report.ms.body);
    s.up = g.squaredNorm() > 0 ? Vec3(-g.normalized()) : Vec3::Zero();
    if (body && !s.body_tris.empty()) {
      gather_point_pairs(s, th);
    } else {
      s.point_pairs.clear();
      std::fill(s.held_up.begin(), s.held_up.end(), 0);
    }
  }
  s.self_pairs.clear();
  const int window = self_window(s, p, th);
  s.path.assign(n, 0.0);
  s.reach.assign(n, 0.0);

  const double damp = std::exp(-m.damping * h);
  const double alpha_s = 1.0 / (m.stretch_stiffness * h * h);
  const bool bending = m.bending_stiffness > 0;
  const double alpha_b = bending ? 1.0 / (m.bending_stiffness * h * h) : 0.0;
  const int ne = cs.ne;
  const int nb = cs.nb;
  // The multipliers are reset every substep, so with one iteration (the default) each is zero when
  // its constraint is projected and is never read again: they are kept only for more iterations.
  // Without them a substep reads and writes 24 bytes an edge and 48 a bending edge less (at 20,000
  // vertices 5.7 MB a substep, more than the positions and constraints it otherwise touches).
  const bool multipliers = p.iterations > 1;
  if (multipliers) {
    s.lam_e.resize(ne);
    s.lam_b.resize(nb);
  }

  std::vector<Held> held_by_hand = weigh_hands(s, dt, h);
  const double hand_decay = std::exp(-2.0 / std::sqrt(kHandMass));  // critical: 2 omega h a substep

  Vec3* X = s.x.data();
  const double* W = s.w.data();
  for (int sub = 0; sub < substeps; ++sub) {
    const double along = double(sub + 1) / substeps;  // how far the plain hands' targets have moved
    if (p.self_collision && sub % window == 0) {
      PhaseClock clock(s.report.ms.self_search);
      // The pairs for the next `window` substeps (fewer at the step's end), gathered from where
      // the cloth is now along its present velocity.
      const int len = std::min(window, substeps - sub);
      const double span = len * h;
      s.win.resize(n);
      parallel::for_range(static_cast<int>(n), kVertexGrain, [&](int b, int e) {
        for (int i = b; i < e; ++i)
          s.win[i] = s.moving[i] ? Vec3(s.v[i] * span + (W[i] * s.fext[i]) * (span * span)) : Vec3::Zero();
      });
      gather_self_pairs(s, th, double(len) / substeps);
      std::fill(s.path.begin(), s.path.end(), 0.0);
    }
    PhaseClock solve_clock(s.report.ms.solve);
    for (Held& hv : held_by_hand) hv.v0 = s.v[hv.i];
    parallel::for_range(na, kVertexGrain, [&](int b, int e) {
      for (int a = b; a < e; ++a) {
        const int i = act[a];
        s.xp[i] = X[i];
        s.v[i] = (s.v[i] + h * (g + W[i] * s.fext[i])) * damp;
        X[i] += h * s.v[i];
      }
    });
    for (const Held& hv : held_by_hand) {
      const int i = hv.i;
      const Vec3 v = hv.v0 + h * (hv.own * g + W[i] * s.fext[i]);
      s.v[i] = hv.vt + (v - hv.vt) * hand_decay;
      X[i] = s.xp[i] + h * s.v[i];
    }
    if (multipliers) {
      std::fill(s.lam_e.begin(), s.lam_e.end(), 0.0);
      if (bending) std::fill(s.lam_b.begin(), s.lam_b.end(), Vec3::Zero());
    }
    // Hands: zero-length springs to a point, compliance 1 / k. The plain ones first in the sweep,
    // so that the cloth's constraints after them pull back; the firm ones at the end (below). No
    // multiplier is kept for them: with more than one iteration a hand is projected again each
    // sweep and holds a little stiffer than 1 / compliance (one iteration is the default).
    auto hands = [&](bool firm) {
      for (const auto& a : s.attach) {
        const int i = a.i;
        if (a.firm != firm || W[i] == 0) continue;
        const double alpha = 1.0 / (a.k * h * h);
        const Vec3 target = firm ? a.target : Vec3(a.from + along * (a.target - a.from));
        X[i] += (target - X[i]) * (W[i] / (W[i] + alpha));
      }
    };
    for (int it = 0; it < p.iterations; ++it) {
      hands(false);
      // Long-range limits. One between cloth the body holds up and cloth hanging below it moves
      // only the hanging end, as a long-range attachment to a pin does (Kim et al. 2012): the body
      // carries the held end against the cloth's weight. Pulled down too, the held end stretched
      // the cloth around it, and friction kept that stretch (docs/benchmarks.md, "Why the crown
      // stays stretched"). Not while a hand holds the garment: its pull must be able to drag the
      // garment off the body, as before (held regardless, the garment stayed on).
      const unsigned char* held = s.attach.empty() ? s.held_up.data() : nullptr;
      const Vec3 up = s.up;
      auto limits = [&](int b, int e) {
        for (int k = b; k < e; ++k) {
          const int i = cs.l_i[k], j = cs.l_j[k];
          const Vec3 d = X[i] - X[j];
          const double len2 = d.squaredNorm();
          const double rest = cs.l_rest[k];
          if (len2 <= rest * rest) continue;
          const double len = std::sqrt(len2);
          double wi = W[i], wj = W[j];
          const double wboth = wi + wj;
          if (wboth == 0) continue;
          if (held && held[i] != held[j]) {
            const double i_above = d.dot(up);
            if (held[i] && i_above > 0) wi = 0;
            if (held[j] && i_above < 0) wj = 0;
            if (wi == 0 || wj == 0) {
              // The hanging end alone, the whole way; what is beyond its own share is not velocity.
              const Vec3 corr = d * ((rest - len) / len);
              const double own = (wi + wj) / wboth;
              if (wi > 0) {
                X[i] += corr;
                s.unkick[i] += (1 - own) * corr;
              } else if (wj > 0) {
                X[j] -= corr;
                s.unkick[j] -= (1 - own) * corr;
              }
              continue;
            }
          }
          const Vec3 corr = d * ((rest - len) / (len * wboth));
          X[i] += wi * corr;
          X[j] -= wj * corr;
        }
      };
      run_ranges(*cs.l_ranges, s.l_kinds, limits);  // coarse to fine
      auto stretch = [&](auto kept, int b, int e) {
        for (int k = b; k < e; ++k) {
          const int i = cs.e_i[k], j = cs.e_j[k];
          const double wsum = W[i] + W[j];
          if (wsum == 0) continue;
          const Vec3 d = X[i] - X[j];
          const double len = d.norm();
          if (!(len > 1e-12)) continue;
          const double C = len - cs.e_rest[k];
          const double lam = decltype(kept)::value ? s.lam_e[k] : 0.0;
          const double dl = (-C - alpha_s * lam) / (wsum + alpha_s);
          if constexpr (decltype(kept)::value) s.lam_e[k] += dl;
          const Vec3 corr = d * (dl / len);
          X[i] += W[i] * corr;
          X[j] -= W[j] * corr;
        }
      };
      with_multipliers(multipliers, *cs.e_ranges, s.e_kinds, stretch);
      if (bending) {
        auto bend = [&](auto kept, int first, int last) {
          for (int k = first; k < last; ++k) {
            const SolverArrays::Bend& b = cs.bends[k];
            const double w0 = W[b.v[0]], w1 = W[b.v[1]], w2 = W[b.v[2]], w3 = W[b.v[3]];
            const double wg = w0 * b.g[0] * b.g[0] + w1 * b.g[1] * b.g[1] + w2 * b.g[2] * b.g[2] +
                              w3 * b.g[3] * b.g[3];
            if (wg == 0) continue;
            const Vec3 C = b.g[0] * X[b.v[0]] + b.g[1] * X[b.v[1]] + b.g[2] * X[b.v[2]] + b.g[3] * X[b.v[3]];
            const Vec3 lam = decltype(kept)::value ? s.lam_b[k] : Vec3(Vec3::Zero());
            const Vec3 dl = (-C - alpha_b * lam) / (wg + alpha_b);
            if constexpr (decltype(kept)::value) s.lam_b[k] += dl;
            X[b.v[0]] += (w0 * b.g[0]) * dl;
            X[b.v[1]] += (w1 * b.g[1]) * dl;
            X[b.v[2]] += (w2 * b.g[2]) * dl;
            X[b.v[3]] += (w3 * b.g[3]) * dl;
          }
        };
        with_multipliers(multipliers, *cs.b_ranges, s.b_kinds, bend);
      }
    }
    // Tacks: zero-length, as stiff as the cloth, but closing by at most half the thickness a
    // substep (0.6 m/s at 10 substeps of a 4 mm cloth): a seam sewn across a shoulder closes
    // around it, kept out by the body collision, instead of jumping through it in one substep.
    for (const auto& t : s.tacks) {
      const int i = t[0], j = t[1];
      const double wsum = W[i] + W[j];
      if (wsum == 0) continue;
      const Vec3 d = X[j] - X[i];
      const double gap = d.norm();
      const double close = std::min(gap * wsum / (wsum + alpha_s), 0.5 * th);
      if (!(gap > 1e-12)) continue;
      const Vec3 corr = d * (close / (gap * wsum));
      X[i] += W[i] * corr;
      X[j] -= W[j] * corr;
    }
    solve_clock.stop();
    // Self-collision, then the strain limit (a self-collision push of up to half the thickness
    // stretches the edges of a fold by as much: the limit takes it back, and what it leaves is
    // resolved in the next substep), then the firm hands, then the body last, so nothing ends a
    // substep inside it.
    if (!s.self_pairs.empty()) {
      PhaseClock clock(s.report.ms.self_resolve);
      parallel::for_range(na, kVertexGrain, [&](int b, int e) {
        for (int a = b; a < e; ++a) {
          const int i = act[a];
          s.reach[i] = s.path[i] + (X[i] - s.xp[i]).norm();
        }
      });
      resolve_self(s, th);
    }
    // The body's points before the strain limit: a cloth hanging on a point is lifted by it, and
    // the limit then takes back what the lift stretched.
    if (!s.point_pairs.empty()) resolve_point_pairs(s, th, m.friction);
    if (p.strain_limit > 0) {
      PhaseClock clock(s.report.ms.strain_limit);
      limit_strain(s, cs, p.strain_limit);
    }
    // Firm hands, after the cloth's own constraints and the strain limit so that they win ties: a
    // firm hand can stretch the cloth past the limit, and so tear it.
    hands(true);
    {
      PhaseClock clock(s.report.ms.body);
      if (body && !s.body_tris.empty()) {
        resolve_body(s, *body, s.act, th, m.friction, p.floor);
        // The edges after the vertices, half the thickness out: an edge over a smooth surface with
        // its ends at the thickness is clear of it, and is not touched.
        auto edges = [&](int b, int e) {
          resolve_body_edges(s, *body, cs.e_i, cs.e_j, b, e, th, 0.5 * th, m.friction, e - b == cs.ne);
        };
        if (s.body_edges) run_ranges(*cs.e_ranges, s.e_kinds, edges);
      }
      if (!s.point_pairs.empty())
        for (int i : s.point_held) s.held_up[i] = 1;
    }
    const double inv_h = 1.0 / h;
    parallel::for_range(na, kVertexGrain, [&](int b, int e) {
      for (int a = b; a < e; ++a) {
        const int i = act[a];
        s.v[i] = (X[i] - s.xp[i] - s.unkick[i]) * inv_h;
        s.unkick[i] = Vec3::Zero();
      }
    });
    if (!s.self_pairs.empty())
      parallel::for_range(na, kVertexGrain, [&](int b, int e) {
        for (int a = b; a < e; ++a) {
          const int i = act[a];
          s.path[i] += (X[i] - s.xp[i]).norm();
        }
      });
  }
  // How far each vertex ended from its prediction, for the next step's culling: as it is (body),
  // and less the mean of it over the cloth (self-collision, culled in the frame of the cloth's
  // common motion: a falling cloth all misses its prediction by g dt^2 together).
  Vec3 common_miss = Vec3::Zero();
  for (int i : s.act) common_miss += X[i] - s.x0[i] - s.pred[i];
  if (!s.act.empty()) common_miss /= double(s.act.size());
  s.surprise_self.resize(n);
  parallel::for_range(static_cast<int>(n), kVertexGrain, [&](int b, int e) {
    for (int i = b; i < e; ++i) {
      const Vec3 miss = s.moving[i] ? Vec3(X[i] - s.x0[i] - s.pred[i]) : Vec3::Zero();
      s.surprise[i] = miss.norm();
      s.surprise_self[i] = (miss - common_miss).norm();
    }
  });
}

}  // namespace kiji::solver_detail
