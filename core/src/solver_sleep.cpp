// Sleeping: blocks of cloth at rest are held still and cost nothing until something disturbs them
// (see SolverParams::sleep_after). The blocks are those the constraints are scheduled in (about a
// thousand live vertices each, consecutive in the spatial order: compact patches).
//
// A block is calm while every vertex stays within sleep_distance of its anchor (where it was when
// the calm began); a vertex going farther restarts the block's calm from where its vertices are.
// Calm for sleep_after seconds, the block falls asleep where it is, with velocity zero. Measuring
// the distance from an anchor and not the speed lets a block sleep whose contacts still tremble
// (a vertex between the body and a fold moves back and forth by a fraction of a millimetre each
// step, at up to half a metre a second within a substep) and keeps awake one that creeps.
#include "parallel.h"
#include "solver_state.h"

#include <algorithm>
#include <cstdint>

namespace kiji::solver_detail {

namespace {

// What the resting shape depends on. Not the damping: cloth at rest stays at rest whatever it is.
std::array<double, 15> physics_of(const SolverParams& p, const Material& m) {
  return {static_cast<double>(p.model), p.gravity.x(), p.gravity.y(), p.gravity.z(),
          static_cast<double>(p.body_collision), static_cast<double>(p.self_collision), p.strain_limit,
          p.spring_k, p.sleep_distance, m.density, m.stretch_stiffness, m.bending_stiffness, m.friction,
          m.thickness, m.tear_ratio};
}

// Everything awake, each vertex's anchor where it is now.
void reset(SolverArrays& s) {
  const int blocks = s.blocks;
  s.block_start.assign(blocks + 1, 0);
  for (int i : s.order)
    if (s.alive[i]) ++s.block_start[s.block[i] + 1];
  for (int b = 0; b < blocks; ++b) s.block_start[b + 1] += s.block_start[b];
  s.block_verts.assign(s.block_start[blocks], 0);
  std::vector<int> fill(s.block_start.begin(), s.block_start.end() - 1);
  for (int i : s.order)
    if (s.alive[i]) s.block_verts[fill[s.block[i]]++] = i;
  s.block_nbrs.assign(blocks, 0);
  for (std::size_t k = 0; k < s.e_i.size(); ++k) {
    const int a = s.block[s.e_i[k]], b = s.block[s.e_j[k]];
    if (a == b) continue;
    s.block_nbrs[a] |= std::uint64_t(1) << b;
    s.block_nbrs[b] |= std::uint64_t(1) << a;
  }
  s.asleep.assign(blocks, 0);
  s.calm.assign(blocks, 0.0);
  s.settle_disp.assign(blocks, 0.0);
  s.anchor = s.x;
}

void wake(SolverArrays& s, int b) {
  s.calm[b] = 0;
  if (!s.asleep[b]) return;
  s.asleep[b] = 0;
  for (int k = s.block_start[b]; k < s.block_start[b + 1]; ++k) s.anchor[s.block_verts[k]] = s.x[s.block_verts[k]];
}

}  // namespace

void sleep_before_step(SolverArrays& s, const SolverParams& p, const Material& m,
                       const std::vector<unsigned char>& disturbed) {
  s.sleeping = 0;
  if (p.sleep_after <= 0) {
    s.sleep_ready = false;
    return;
  }
  const std::array<double, 15> physics = physics_of(p, m);
  if (!s.sleep_ready || physics != s.physics) {
    reset(s);
    s.physics = physics;
    s.sleep_ready = true;
  }
  s.hold_awake.assign(s.blocks, 0);
  for (int b = 0; b < s.blocks; ++b)
    if (disturbed[b]) {
      wake(s, b);
      s.hold_awake[b] = 1;
    }
  for (int b = 0; b < s.blocks; ++b) {
    if (!s.asleep[b]) continue;
    for (int k = s.block_start[b]; k < s.block_start[b + 1]; ++k) {
      const int i = s.block_verts[k];
      s.moving[i] = 0;
      s.w[i] = 0;
    }
    s.sleeping += s.block_start[b + 1] - s.block_start[b];
  }
}

void sleep_after_step(SolverArrays& s, const SolverParams& p, double dt) {
  if (!s.sleep_ready) return;
  const double d2 = p.sleep_distance * p.sleep_distance;
  const int blocks = s.blocks;
  parallel::for_range(blocks, 1, [&](int b0, int b1) {
    for (int b = b0; b < b1; ++b) {
      double far = 0;
      if (!s.asleep[b])
        for (int k = s.block_start[b]; k < s.block_start[b + 1]; ++k) {
          const int i = s.block_verts[k];
          far = std::max(far, (s.x[i] - s.anchor[i]).squaredNorm());
        }
      s.settle_disp[b] = far;
    }
  });
  // Sleeping cloth next to cloth that moved wakes for the next step: a block sharing an edge with
  // an awake block that moved (cloth pulled against a sleeping block is held by it: its own
  // vertices barely move, the cloth behind them stretches), and cloth in contact with a vertex or
  // a triangle that moved.
  auto moved = [&](int i) { return !s.asleep[s.block[i]] && (s.x[i] - s.anchor[i]).squaredNorm() > d2; };
  std::vector<int> woken;
  for (int b = 0; b < blocks; ++b)
    if (!s.asleep[b] && s.settle_disp[b] > d2)
      for (int c = 0; c < blocks; ++c)
        if (s.asleep[c] && ((s.block_nbrs[b] >> c) & 1u)) woken.push_back(c);
  for (const SolverArrays::SelfPair& pair : s.self_pairs) {
    const std::array<int, 3>& t = s.tris[pair.t];
    const bool tri_moved = moved(t[0]) || moved(t[1]) || moved(t[2]);
    if (s.asleep[s.block[pair.v]] && tri_moved) woken.push_back(s.block[pair.v]);
    if (moved(pair.v))
      for (int c : t)
        if (s.asleep[s.block[c]]) woken.push_back(s.block[c]);
  }
  // The awake blocks: calm on, or calm again from where they are; asleep when calm long enough.
  for (int b = 0; b < blocks; ++b) {
    if (s.asleep[b]) continue;
    const int* verts = s.block_verts.data();
    if (s.settle_disp[b] > d2 || s.hold_awake[b]) {
      s.calm[b] = 0;
      for (int k = s.block_start[b]; k < s.block_start[b + 1]; ++k) s.anchor[verts[k]] = s.x[verts[k]];
      continue;
    }
    s.calm[b] += dt;
    if (s.calm[b] < p.sleep_after) continue;
    s.asleep[b] = 1;
    for (int k = s.block_start[b]; k < s.block_start[b + 1]; ++k) {
      const int i = verts[k];
      s.anchor[i] = s.x[i];  // where it is written to the mesh, exactly: an edit is any change
      s.v[i].setZero();
    }
  }
  for (int b : woken) wake(s, b);
  s.sleeping = 0;
  for (int b = 0; b < blocks; ++b)
    if (s.asleep[b]) s.sleeping += s.block_start[b + 1] - s.block_start[b];
}

}  // namespace kiji::solver_detail
