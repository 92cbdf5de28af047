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
//
// Where the cloth sleeps is kept with the garment (Garment::sleep_record): when the arrays are
// rebuilt (a new solver, an undo, a topology edit), a block every vertex of which is exactly as it
// slept (position, zero velocity, inverse mass, and the same edges with the same rest lengths)
// starts asleep. Without it, each rebuild woke the whole garment, and a garment put to sleep while
// it still crept (less than sleep_distance in sleep_after) crept on for seconds, every step
// costing what the whole garment costs.
#include "base/parallel.h"
#include "cloth/sleep_record_io.h"
#include "sim/solver_state.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <limits>

namespace kiji::solver_detail {

namespace {

// What the resting shape depends on. Not the damping: cloth at rest stays at rest whatever it is.
std::array<double, 15> physics_of(const SolverParams& p, const Material& m) {
  return {static_cast<double>(p.model), p.gravity.x(), p.gravity.y(), p.gravity.z(),
          static_cast<double>(p.body_collision) + (p.floor ? 2.0 : 0.0), static_cast<double>(p.self_collision), p.strain_limit,
          p.spring_k, p.sleep_distance, m.density, m.stretch_stiffness, m.bending_stiffness, m.friction,
          m.thickness, m.tear_ratio};
}

std::uint64_t mix(std::uint64_t x) {  // splitmix64's finaliser
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

std::uint64_t bits_of(double d) {
  std::uint64_t u;
  std::memcpy(&u, &d, sizeof u);
  return u;
}

// Each vertex's edges (the other end, the rest length) summed, the same whatever their order, and
// its inverse mass: what must be as it was for the vertex to sleep on. Hashed when a record is read
// or written (a rebuild, a block falling asleep, the garment's bytes), never in between.
std::vector<std::uint64_t> keys_of(const Garment& g) {
  const Mesh& m = g.mesh();
  std::vector<std::uint64_t> key(g.vertex_capacity(), 0);
  for (Edge e : m.edges()) {
    const Halfedge h = m.halfedge(e);
    const std::uint64_t i = m.source(h).idx(), j = m.target(h).idx();
    const std::uint64_t r = mix(bits_of(g.rest_length(e)));
    key[i] += mix(j ^ r);
    key[j] += mix(i ^ r);
  }
  for (Vertex v : m.vertices()) key[v.idx()] ^= mix(bits_of(g.inverse_mass(v)) + 1);
  return key;
}

// Everything awake, each vertex's anchor where it is now; but the blocks that `carried` finds
// exactly as they slept asleep.
void reset(SolverArrays& s, const SleepRecord* carried, const std::array<double, 15>& physics) {
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
  if (!carried || carried->physics != physics) return;
  s.sleep_key = keys_of(*s.garment);
  const std::size_t known = std::min(carried->at.size(), carried->key.size());
  for (int b = 0; b < blocks; ++b) {
    bool still = s.block_start[b + 1] > s.block_start[b];
    for (int k = s.block_start[b]; still && k < s.block_start[b + 1]; ++k) {
      const int i = s.block_verts[k];
      still = static_cast<std::size_t>(i) < known && carried->at[i] == s.x[i] && s.v[i] == Vec3::Zero() &&
              carried->key[i] == s.sleep_key[i];
    }
    s.asleep[b] = still;
  }
}

void wake(SolverArrays& s, int b) {
  s.calm[b] = 0;
  if (!s.asleep[b]) return;
  s.asleep[b] = 0;
  for (int k = s.block_start[b]; k < s.block_start[b + 1]; ++k) s.anchor[s.block_verts[k]] = s.x[s.block_verts[k]];
}

}  // namespace

void sleep_before_step(SolverArrays& s, const SolverParams& p, const Material& m,
                       const std::vector<unsigned char>& disturbed, const SleepRecord* carried) {
  s.sleeping = 0;
  if (p.sleep_after <= 0) {
    s.sleep_ready = false;
    return;
  }
  const std::array<double, 15> physics = physics_of(p, m);
  if (!s.sleep_ready || physics != s.physics) {
    reset(s, s.sleep_ready ? nullptr : carried, physics);
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

bool sleep_after_step(SolverArrays& s, const SolverParams& p, double dt) {
  if (!s.sleep_ready) return false;
  bool fell_asleep = false;
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
    fell_asleep = true;
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
  return fell_asleep;
}

std::shared_ptr<const SleepRecord> sleep_record(SolverArrays& s) {
  s.sleep_key = keys_of(*s.garment);
  auto r = std::make_shared<SleepRecord>();
  r->physics = s.physics;
  r->at.assign(s.n, Vec3::Constant(std::numeric_limits<double>::quiet_NaN()));
  r->key.assign(s.n, 0);
  for (int b = 0; b < s.blocks; ++b) {
    if (!s.asleep[b]) continue;
    for (int k = s.block_start[b]; k < s.block_start[b + 1]; ++k) {
      const int i = s.block_verts[k];
      r->at[i] = s.x[i];
      r->key[i] = s.sleep_key[i];
    }
  }
  return r;
}

}  // namespace kiji::solver_detail

namespace kiji::detail {

SleepingVertices sleeping_vertices(const Garment& g) {
  SleepingVertices out;
  const SleepRecord* r = g.sleep_record().get();
  if (!r) return out;
  out.physics = r->physics;
  const std::size_t known = std::min(r->at.size(), r->key.size());
  std::vector<std::uint64_t> key;
  for (Vertex v : g.mesh().vertices()) {
    const std::size_t i = v.idx();
    if (i >= known || !(r->at[i] == g.position(v)) || g.velocity(v) != Vec3::Zero()) continue;
    if (key.empty()) key = solver_detail::keys_of(g);
    if (r->key[i] == key[i]) out.vertices.push_back(static_cast<std::uint32_t>(i));
  }
  std::sort(out.vertices.begin(), out.vertices.end());
  return out;
}

void restore_sleep_record(Garment& g, const SleepingVertices& asleep) {
  if (asleep.vertices.empty()) {
    g.set_sleep_record(nullptr);
    return;
  }
  auto r = std::make_shared<SleepRecord>();
  r->physics = asleep.physics;
  r->at.assign(g.vertex_capacity(), Vec3::Constant(std::numeric_limits<double>::quiet_NaN()));
  r->key.assign(g.vertex_capacity(), 0);
  const std::vector<std::uint64_t> key = solver_detail::keys_of(g);
  for (std::uint32_t i : asleep.vertices) {
    r->at[i] = g.position(Vertex(i));
    r->key[i] = key[i];
  }
  g.set_sleep_record(std::move(r));
}

}  // namespace kiji::detail
