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
//
// The step record (Garment::step_record) is written here too, after every step: most of it is the
// sleep a solver built anew for the same mesh takes up (which blocks sleep, how long the others have
// been calm, each block's key); the rest is the order and the margins solver.cpp builds with.
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

// The blocks asleep in the solver's last record `last` (null: none) and still asleep: unchanged
// since (an edit would have woken them), so what the record has of them stands.
std::vector<unsigned char> slept_through(const SolverArrays& s, const StepRecord* last) {
  const std::size_t blocks = static_cast<std::size_t>(s.blocks);
  std::vector<unsigned char> same(blocks, 0);
  if (last && last->sleep_ready && last->asleep.size() == blocks && last->block_key.size() == blocks &&
      last->anchor.size() == s.n)
    for (std::size_t b = 0; b < blocks; ++b) same[b] = last->asleep[b] && s.asleep[b];
  return same;
}

// Per block: its vertices' positions and inverse masses and its edges' rest lengths, as the arrays
// have them, hashed: what the step after compares to find the blocks an edit disturbed. Sums of the
// values' bits times odd constants (any one value changed changes its block's key, at a few
// multiplications a vertex: each step writes them). The blocks `same` marks keep `last`'s key.
std::vector<std::uint64_t> block_keys(const SolverArrays& s, const std::vector<unsigned char>& same, const StepRecord* last) {
  const std::size_t blocks = static_cast<std::size_t>(s.blocks);
  std::vector<std::uint64_t> key(blocks, 0);
  parallel::for_range(s.blocks, 1, [&](int b0, int b1) {
    for (int b = b0; b < b1; ++b) {
      if (same[b]) continue;
      std::uint64_t sum = 0;
      for (int k = s.block_start[b]; k < s.block_start[b + 1]; ++k) {
        const int i = s.block_verts[k];
        const std::uint64_t at = 2 * std::uint64_t(i) + 1;
        sum += at * (bits_of(s.x[i].x()) * 0x9e3779b97f4a7c15ull + bits_of(s.x[i].y()) * 0xc2b2ae3d27d4eb4full +
                     bits_of(s.x[i].z()) * 0x165667b19e3779f9ull + bits_of(s.im[i]) * 0xd6e8feb86659fd93ull);
      }
      key[b] = sum;
    }
  });
  if (std::find(same.begin(), same.end(), 0) != same.end())
    for (std::size_t k = 0; k < s.e_i.size() && k < s.e_rest.size(); ++k) {
      const std::uint64_t r = (2 * std::uint64_t(k) + 1) * bits_of(s.e_rest[k]) * 0xff51afd7ed558ccdull;
      key[s.block[s.e_i[k]]] += r;
      key[s.block[s.e_j[k]]] += r;
    }
  for (std::size_t b = 0; b < blocks; ++b) key[b] = same[b] ? last->block_key[b] : mix(key[b]);
  return key;
}

// Sleeping as the solver that wrote `r` left it; `edited` marks the blocks changed since its step
// (a vertex moved, its mass or an edge's rest length changed, a sleeping vertex given a velocity),
// which that solver would have found disturbed. False, changing nothing, where `r` is not of these
// blocks.
bool take_up(SolverArrays& s, const StepRecord& r, std::vector<unsigned char>& edited) {
  const std::size_t blocks = static_cast<std::size_t>(s.blocks);
  if (r.asleep.size() != blocks || r.calm.size() != blocks || r.block_key.size() != blocks || r.anchor.size() != s.n)
    return false;
  s.asleep = r.asleep;
  s.calm = r.calm;
  s.anchor = r.anchor;
  const std::vector<std::uint64_t> now = block_keys(s, std::vector<unsigned char>(blocks, 0), nullptr);
  edited.assign(blocks, 0);
  for (std::size_t b = 0; b < blocks; ++b) {
    edited[b] = now[b] != r.block_key[b];
    if (s.asleep[b])
      for (int k = s.block_start[b]; k < s.block_start[b + 1] && !edited[b]; ++k)
        edited[b] = s.v[s.block_verts[k]] != Vec3::Zero();
  }
  return true;
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
  // The step record a rebuild took up is for this first step only.
  const std::shared_ptr<const StepRecord> record = std::move(s.carried);
  s.carried.reset();
  if (p.sleep_after <= 0) {
    s.sleep_ready = false;
    return;
  }
  const std::array<double, 15> physics = physics_of(p, m);
  std::vector<unsigned char> edited;
  if (!s.sleep_ready || physics != s.physics) {
    if (!s.sleep_ready && record && record->sleep_ready) {
      // The solver that wrote the record had its blocks: its sleep goes on, unless the physics
      // changed since (that solver would then have woken every block).
      reset(s, nullptr, physics);
      if (record->physics == physics) take_up(s, *record, edited);
    } else {
      reset(s, s.sleep_ready ? nullptr : carried, physics);
    }
    s.physics = physics;
    s.sleep_ready = true;
  }
  s.hold_awake.assign(s.blocks, 0);
  for (int b = 0; b < s.blocks; ++b)
    if (disturbed[b] || (!edited.empty() && edited[b])) {
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

std::uint64_t mesh_key(const Garment& g) {
  const Mesh& m = g.mesh();
  std::uint64_t key = mix(g.vertex_capacity());
  for (Vertex v : m.vertices()) key += mix(v.idx() + 0x51ed27ull);
  for (Face f : m.faces()) {
    std::array<std::uint64_t, 3> c{};
    int k = 0;
    for (Vertex v : CGAL::vertices_around_face(m.halfedge(f), m))
      if (k < 3) c[k++] = v.idx();
    const int first = static_cast<int>(std::min_element(c.begin(), c.end()) - c.begin());
    std::rotate(c.begin(), c.begin() + first, c.end());
    key += mix(mix(mix(c[0]) ^ c[1]) ^ c[2]);
  }
  return key;
}

void write_step_record(SolverArrays& s, Garment& g) {
  // The record written last, where only this solver and the garment hold it (no copy of the
  // garment kept it), is written over: a step of a small region of a large garment would
  // otherwise spend a good part of its time making a new one.
  // Not one of the mesh before an edit, which the garment keeps until this write (its blocks are
  // not this build's).
  const bool reuse = s.written && s.written.use_count() == 2 && g.step_record() == s.written &&
                     s.written->mesh == s.mesh_key;
  if (!reuse) s.written = std::make_shared<StepRecord>();
  StepRecord* r = s.written.get();
  r->mesh = s.mesh_key;
  r->built_at = s.built_at;
  r->built_alive = s.built_alive;
  r->anchors = s.anchors;
  r->surprise = s.surprise;
  r->surprise_self = s.surprise_self;
  r->held_up = s.held_up;
  if (s.sleep_ready) {
    r->sleep_ready = true;
    r->physics = s.physics;
    const std::vector<unsigned char> same = slept_through(s, reuse ? r : nullptr);
    r->block_key = block_keys(s, same, r);
    if (std::find(same.begin(), same.end(), 1) == same.end()) {
      r->anchor = s.anchor;
    } else {
      for (int b = 0; b < s.blocks; ++b)
        if (!same[b])
          for (int k = s.block_start[b]; k < s.block_start[b + 1]; ++k) r->anchor[s.block_verts[k]] = s.anchor[s.block_verts[k]];
    }
    r->asleep = s.asleep;
    r->calm = s.calm;
  } else {
    r->sleep_ready = false;
  }
  if (!reuse) g.set_step_record(s.written);
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
