// Solver: parameters, input checking, the flat arrays mirrored from the mesh, measures.
// The two models are in solver_xpbd.cpp and solver_mass_spring.cpp, collisions in
// solver_collide.cpp.
#include "kiji/solver.h"

#include "kiji/error.h"
#include "base/parallel.h"
#include "sim/solver_state.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <thread>

namespace kiji {

struct Solver::State : SolverArrays {};

SolverModel parse_solver_model(const std::string& name) {
  if (name == "xpbd") return SolverModel::Xpbd;
  if (name == "mass_spring" || name == "mass-spring") return SolverModel::MassSpring;
  throw InputError("unknown solver model '" + name + "': use 'xpbd' or 'mass_spring'");
}

std::string solver_model_name(SolverModel model) {
  return model == SolverModel::MassSpring ? "mass_spring" : "xpbd";
}

int solver_threads() { return parallel::thread_count(); }

namespace {
template <typename T>
void require(bool ok, const char* field, const T& value, const char* what) {
  if (ok) return;
  std::ostringstream msg;
  msg << "solver parameter '" << field << "' is " << value << ": it must be " << what;
  throw InputError(msg.str());
}
std::string vec_text(const Vec3& v) {
  std::ostringstream s;
  s << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return s.str();
}
Vertex vtx(int i) { return Vertex(static_cast<Mesh::size_type>(i)); }

// The garment's own state, checked before the solver reads it.
// The first index in [0, n) where bad(i) holds, or -1: in parallel pieces, the first piece's
// first (what one loop in order would find).
template <typename F>
int first_where(int n, F bad) {
  const int pieces = parallel::piece_count(n, 4096);
  std::vector<int> first(pieces, -1);
  parallel::for_each(pieces, [&](int piece) {
    for (int i = parallel::piece_begin(n, piece, pieces), e = parallel::piece_begin(n, piece + 1, pieces); i < e; ++i)
      if (bad(i)) {
        first[piece] = i;
        return;
      }
  });
  for (int f : first)
    if (f >= 0) return f;
  return -1;
}

void check_garment(const Garment& garment) {
  const Mesh& m = garment.mesh();
  const int bad_vertex = first_where(static_cast<int>(garment.vertex_capacity()), [&](int i) {
    const Vertex v(i);
    return !m.is_removed(v) && (!all_finite(garment.position(v)) || !all_finite(garment.velocity(v)) ||
                                !std::isfinite(garment.inverse_mass(v)) || garment.inverse_mass(v) < 0);
  });
  if (bad_vertex >= 0)
    throw InputError("garment '" + garment.name + "' has a non-finite position, velocity or mass at vertex " +
                     std::to_string(bad_vertex) + ": reset or reload the garment");
  const int bad_edge = first_where(static_cast<int>(m.number_of_edges() + m.number_of_removed_edges()), [&](int k) {
    const Edge e(k);
    if (m.is_removed(e)) return false;
    const double r = garment.rest_length(e);
    return !std::isfinite(r) || r <= 0;
  });
  if (bad_edge >= 0)
    throw InputError("garment '" + garment.name + "' has a rest length of " +
                     std::to_string(garment.rest_length(Edge(bad_edge))) + " on edge " + std::to_string(bad_edge) +
                     ": rest lengths must be positive");
}

// The lightest a vertex is in the xpbd solve, as a share of the garment's median vertex.
constexpr double kLightestShare = 0.5;

// Whether it built them.
bool build_if_needed(SolverArrays& s, const Garment& garment) {
  if (s.built && s.garment == &garment && s.topology == garment.topology_version() && s.n == garment.vertex_capacity())
    return false;
  solver_detail::rebuild(s, garment);
  return true;
}
}  // namespace

void SolverParams::validate() const {
  require(model == SolverModel::Xpbd || model == SolverModel::MassSpring, "model",
          static_cast<int>(model), "xpbd or mass_spring");
  require(all_finite(gravity), "gravity", vec_text(gravity), "a finite vector in m/s^2");
  require(substeps >= 1 && substeps <= 1000, "substeps", substeps, "between 1 and 1000");
  require(held_substeps >= 0 && held_substeps <= 1000, "held_substeps", held_substeps,
          "0 (as substeps) or up to 1000 substeps while a plain hand holds the garment");
  require(iterations >= 1 && iterations <= 100, "iterations", iterations, "between 1 and 100");
  require(std::isfinite(spring_k) && spring_k > 0, "spring_k", spring_k,
          "a positive finite spring constant (eq. 3 of the paper)");
  require(std::isfinite(spring_damping) && spring_damping >= 0, "spring_damping", spring_damping,
          "zero or a positive finite damping (gamma of eq. 1)");
  require(std::isfinite(strain_limit) && strain_limit >= 0 && strain_limit < 1, "strain_limit", strain_limit,
          "between 0 (off) and 1 (a fraction of the rest length)");
  require(std::isfinite(local_radius) && local_radius >= 0, "local_radius", local_radius,
          "zero (no local region) or a positive finite radius in metres");
  require(all_finite(local_center), "local_center", vec_text(local_center), "a finite point");
  require(std::isfinite(sleep_after) && sleep_after >= 0, "sleep_after", sleep_after,
          "zero (never sleep) or a positive finite time in seconds");
  require(std::isfinite(sleep_distance) && sleep_distance > 0 && sleep_distance < 1, "sleep_distance", sleep_distance,
          "a positive distance in metres, under 1 (cloth moving less than this is at rest)");
}

void solver_detail::set_body_edges(Solver& solver, bool on) { solver.state_->body_edges = on; }

Solver::Solver(SolverParams params) : state_(std::make_unique<State>()) {
  params.validate();
  params_ = params;
}

Solver::~Solver() = default;

void Solver::set_params(const SolverParams& params) {
  params.validate();
  params_ = params;
}

void Solver::set_body(const Body* body) {
  if (body == body_ && (body == nullptr || collider_)) return;
  body_ = body;
  collider_ = body ? std::make_unique<BodyCollider>(*body) : nullptr;
  solver_detail::set_body(*state_, body);
}

void Solver::add_external_force(Vertex v, const Vec3& force) { forces_.push_back({v, force}); }

int Solver::add_attachment(Vertex v, const Vec3& target, double stiffness, bool firm) {
  if (!all_finite(target)) throw InputError("an attachment's target point is not finite");
  if (!std::isfinite(stiffness) || stiffness <= 0)
    throw InputError("an attachment's stiffness is " + std::to_string(stiffness) + ": it must be positive, in N/m");
  attachments_.push_back({next_attachment_, v, target, target, stiffness, firm});
  return next_attachment_++;
}

void Solver::move_attachment(int id, const Vec3& target) {
  if (!all_finite(target)) throw InputError("an attachment's target point is not finite");
  for (auto& a : attachments_)
    if (a.id == id) a.target = target;
}

void Solver::remove_attachment(int id) {
  attachments_.erase(std::remove_if(attachments_.begin(), attachments_.end(), [&](const Attachment& a) { return a.id == id; }),
                     attachments_.end());
}

namespace solver_detail {

namespace {
std::uint32_t spread_bits(std::uint32_t x) {  // 10 bits -> every third bit
  x &= 0x3ff;
  x = (x | (x << 16)) & 0x030000ff;
  x = (x | (x << 8)) & 0x0300f00f;
  x = (x | (x << 4)) & 0x030c30c3;
  x = (x | (x << 2)) & 0x09249249;
  return x;
}

// Sorts (code, index) pairs listed in increasing index by code, ties in index order: what
// std::sort of the pairs gives, by a stable radix sort of the 30-bit Morton codes (three passes
// of 10 bits), a quarter of the sort's time on a garment's 40,000 triangles.
void sort_by_code(std::vector<std::pair<std::uint32_t, int>>& keyed) {
  std::vector<std::pair<std::uint32_t, int>> other(keyed.size());
  for (int shift = 0; shift < 30; shift += 10) {
    std::array<int, 1025> start{};
    for (const auto& k : keyed) ++start[((k.first >> shift) & 1023) + 1];
    for (int b = 0; b < 1024; ++b) start[b + 1] += start[b];
    for (const auto& k : keyed) other[start[(k.first >> shift) & 1023]++] = k;
    keyed.swap(other);
  }
}

// A min-heap of (distance, vertex) pairs for the long-range searches, with a vertex in it once
// (its distance lowered in place): it pops the vertices in the order a heap of every improvement
// (std::priority_queue) pops them, without that heap's stale entries.
class VertexHeap {
 public:
  void resize(std::size_t n) { pos_.assign(n, -1); }
  bool empty() const { return heap_.empty(); }
  // Puts v in at d, or lowers it to d (less than it has).
  void push_or_lower(double d, int v) {
    int i = pos_[v];
    if (i < 0) {
      i = static_cast<int>(heap_.size());
      heap_.emplace_back(d, v);
    }
    const Entry e{d, v};
    while (i > 0) {
      const int parent = (i - 1) / 2;
      if (!(e < heap_[parent])) break;
      place(i, heap_[parent]);
      i = parent;
    }
    place(i, e);
  }
  std::pair<double, int> pop() {
    const Entry top = heap_[0];
    pos_[top.second] = -1;
    const Entry e = heap_.back();
    heap_.pop_back();
    const int size = static_cast<int>(heap_.size());
    if (size > 0) {
      int i = 0;
      for (;;) {
        int child = 2 * i + 1;
        if (child >= size) break;
        if (child + 1 < size && heap_[child + 1] < heap_[child]) ++child;
        if (!(heap_[child] < e)) break;
        place(i, heap_[child]);
        i = child;
      }
      place(i, e);
    }
    return top;
  }

 private:
  using Entry = std::pair<double, int>;
  void place(int i, const Entry& e) {
    heap_[i] = e;
    pos_[e.second] = i;
  }
  std::vector<Entry> heap_;
  std::vector<int> pos_;  // per vertex: its place in heap_, or -1
};

// Greedy colouring: a constraint gets the smallest colour none of its vertices has yet, so the
// constraints of one colour share no vertex (they can be solved in parallel, Gauss-Seidel between
// colours). Each constraint's colour in `col`; returns the number of colours.
template <int K, typename GetVerts>
int greedy_colours(std::size_t count, std::size_t n, GetVerts verts, std::vector<int>& col) {
  std::vector<std::uint64_t> used(n, 0);
  col.assign(count, 0);
  int ncol = 0;
  for (std::size_t c = 0; c < count; ++c) {
    std::array<int, K> vs = verts(c);
    std::uint64_t mask = 0;
    for (int k = 0; k < K; ++k) mask |= used[vs[k]];
    const std::uint64_t free = ~mask & ~(std::uint64_t(1) << 63);
    const int colour_id = free ? __builtin_ctzll(free) : 63;  // 63 = overflow bucket
    col[c] = colour_id;
    if (colour_id < 63)
      for (int k = 0; k < K; ++k) used[vs[k]] |= (std::uint64_t(1) << colour_id);
    ncol = std::max(ncol, colour_id + 1);
  }
  return ncol;
}

// The constraints [0, count) sorted by key (in [0, keys)), in their order within a key: the
// permutation, and where each key's run begins (keys + 1 entries).
void sort_by_key(const std::vector<int>& key, int keys, std::vector<int>& perm, std::vector<int>& begin) {
  begin.assign(keys + 1, 0);
  for (int k : key) ++begin[k + 1];
  for (int k = 0; k < keys; ++k) begin[k + 1] += begin[k];
  std::vector<int> fill(begin.begin(), begin.end() - 1);
  perm.assign(key.size(), 0);
  for (std::size_t c = 0; c < key.size(); ++c) perm[fill[key[c]]++] = static_cast<int>(c);
}

// The order in which a set of constraints is solved, and its ranges (see SolverArrays): first each
// block's own constraints (all their vertices in that block), block by block, each in colour
// order; then the constraints across blocks, coloured among themselves. The blocks are solved
// in parallel, each by one thread in sequence (no vertex is in two blocks), so a substep meets a
// barrier between blocks and the rest, not between every two colours, and each block's vertices
// stay in the core's cache while its constraints are solved. With one block, the constraints
// within it are solved in sequence; a garment too small for two blocks is too small to share.
// Both sorts are counting sorts over the constraints read in their own order (read in colour
// order, the bending constraints' 64 bytes each were a cache miss apiece).
template <int K, typename GetVerts>
void schedule(std::size_t count, std::size_t n, const std::vector<int>& block, int blocks, GetVerts verts,
              std::vector<int>& perm, std::vector<int>& offsets, std::vector<unsigned char>& kinds) {
  std::vector<int> col, key(count), sorted, begin;
  const int ncol = std::max(1, greedy_colours<K>(count, n, verts, col));
  for (std::size_t c = 0; c < count; ++c) {  // by block (the last: across blocks), then colour
    const std::array<int, K> vs = verts(c);
    const int b = block[vs[0]];
    bool inside = true;
    for (int k = 1; k < K; ++k) inside = inside && block[vs[k]] == b;
    key[c] = (inside ? b : blocks) * ncol + col[c];
  }
  sort_by_key(key, (blocks + 1) * ncol, sorted, begin);
  const int own = begin[blocks * ncol];
  perm.assign(sorted.begin(), sorted.begin() + own);
  offsets.assign(1, 0);
  kinds.clear();
  for (int b = 0; b < blocks; ++b) {
    offsets.push_back(begin[(b + 1) * ncol]);
    kinds.push_back(b == 0 ? SolverArrays::kFirstBlock : SolverArrays::kBlock);
  }
  // Across blocks, in colour order, coloured again among themselves.
  const std::vector<int> across(sorted.begin() + own, sorted.end());
  const int across_colours = greedy_colours<K>(across.size(), n, [&](std::size_t q) { return verts(across[q]); }, col);
  sort_by_key(col, across_colours, sorted, begin);
  for (int c = 0; c < across_colours; ++c) {
    for (int q = begin[c]; q < begin[c + 1]; ++q) perm.push_back(across[sorted[q]]);
    offsets.push_back(static_cast<int>(perm.size()));
    kinds.push_back(c == 63 ? SolverArrays::kSerial : SolverArrays::kGroup);  // 63: the overflow colour
  }
}

// The long-range limits, level by level: anchors at least S edges apart, each joined to the
// anchors within 2 S edges by the shortest rest-length path that the level searches.
//
// The two finest levels (S = 2, 4) take their anchors greedily in Morton order and search the
// cloth's edges. The anchor taken at an unmarked vertex is the one of it and its unmarked
// neighbours (on the same side of the outline: inside, or on it) with the most edges, the one that
// reaches the most cloth within S - 1 edges: so the anchors, and the limits every substep pays
// for, do not follow the triangulation's pattern of diagonals (on a grid, every second vertex
// instead of every fourth).
//
// Each coarser level takes its anchors from the finer level's, in their order, and searches the
// finer level's limits instead of the cloth (each a step of its path's edges, the path no longer
// than 2 S edges): a search then meets a few dozen anchors where it met thousands of vertices, and
// the four coarse levels cost less than one fine one. A coarse limit's length is a path through
// finer anchors, a little longer than the cloth's shortest where that passes between them.
//
// The anchors of `was` (a build before: each level's, in the order it took them) are taken first,
// then the sweep fills what they leave.
//
// With `reuse` (s.searched holds the last build's searches and the graphs they read), a search
// runs again only from an anchor within 2 S edges of a vertex whose neighbours or rest lengths (at
// a coarse level: whose finer limits) changed or whose being an anchor did; the others' limits are
// as they were, bit for bit.
void build_long_range(SolverArrays& s, bool reuse, const std::vector<std::vector<int>>* was) {
  s.l_i.clear();
  s.l_j.clear();
  s.l_rest.clear();
  s.searches = 0;
  const std::size_t n = s.n;
  // The vertices whose neighbours (in order) or rest lengths are not those the last build read.
  std::vector<char> changed(n, 1);
  if (reuse) {
    const std::size_t old_n = s.searched_nbr_begin.empty() ? 0 : s.searched_nbr_begin.size() - 1;
    for (std::size_t v = 0; v < std::min(n, old_n); ++v) {
      const int b = s.nbr_begin[v], e = s.nbr_begin[v + 1], ob = s.searched_nbr_begin[v];
      if (e - b != s.searched_nbr_begin[v + 1] - ob) continue;
      bool same = true;
      for (int k = 0; k < e - b && same; ++k)
        same = s.nbr[b + k] == s.searched_nbr[ob + k] && s.nbr_rest[b + k] == s.searched_nbr_rest[ob + k];
      changed[v] = !same;
    }
  }
  std::vector<int> hop(n, 0), mark(n, 0);
  std::vector<char> anchor(n, 0);
  std::vector<int> queue, anchors, finer;
  std::vector<std::array<int, 2>> li;
  std::vector<double> lr;
  std::vector<int> lh;  // each limit's path, in edges
  std::vector<std::vector<std::size_t>> levels;
  std::vector<int> tri_count(n, 0);  // fewer triangles than edges: a vertex on the outline
  for (const auto& t : s.tris)
    for (int k = 0; k < 3; ++k) ++tri_count[t[k]];
  auto degree = [&](int v) { return s.nbr_begin[v + 1] - s.nbr_begin[v]; };
  auto outline = [&](int v) { return tri_count[v] < degree(v); };
  // The graph a level searches: for each vertex, its neighbours, the rest length to each and how
  // many of the cloth's edges that is.
  std::vector<int> g_begin = s.nbr_begin, g_to = s.nbr, g_edges(s.nbr.size(), 1);
  std::vector<double> g_len = s.nbr_rest;
  auto taken = std::make_shared<std::vector<std::vector<int>>>();
  std::vector<char> in_sweep(n, 0);
  for (int S = 2, level_index = 0; S <= 64; S *= 2, ++level_index) {
    const bool fine = S <= 4;
    // Anchors: no two closer than S edges; every vertex (every finer anchor) within S - 1 of one.
    std::fill(anchor.begin(), anchor.end(), 0);
    std::fill(mark.begin(), mark.end(), 0);
    finer.swap(anchors);
    anchors.clear();
    const std::vector<int>& sweep = fine ? s.order : finer;
    // A vertex is marked within S - 1 edges of an anchor taken. Each anchor's search goes on only
    // where it comes nearer than the anchors before it came (`hop`: the nearest one's edges away),
    // so the level's searches cover the cloth about once, not once an anchor; the same marks.
    std::fill(hop.begin(), hop.end(), S);
    auto take = [&](int a) {
      anchor[a] = 1;
      anchors.push_back(a);
      queue.assign(1, a);
      hop[a] = 0;
      mark[a] = 1;
      for (std::size_t q = 0; q < queue.size(); ++q) {
        const int u = queue[q];
        if (hop[u] >= S - 1) continue;
        for (int k = s.nbr_begin[u]; k < s.nbr_begin[u + 1]; ++k) {
          const int w = s.nbr[k];
          if (hop[w] <= hop[u] + 1) continue;
          hop[w] = hop[u] + 1;
          mark[w] = 1;
          queue.push_back(w);
        }
      }
    };
    // The last build's anchors first, in the order it took them (those an edit left S apart), so
    // that an edit moves the anchors only around itself: a sweep from scratch finds others
    // everywhere, and carried a change on through the rest of the sweep even in the same order (a
    // cut moved a third of a level's anchors), and every limit from them. On the mesh they were
    // taken on, they are taken all and in the same order: the arrays of the solver that took them.
    if (was && static_cast<std::size_t>(level_index) < was->size()) {
      for (int a : sweep) in_sweep[a] = 1;
      for (int a : (*was)[level_index])
        if (a >= 0 && static_cast<std::size_t>(a) < n && in_sweep[a] && !mark[a]) take(a);
      for (int a : sweep) in_sweep[a] = 0;
    }
    for (int a : sweep) {
      if (mark[a]) continue;
      const int first = a;
      if (fine)
        for (int k = s.nbr_begin[first]; k < s.nbr_begin[first + 1]; ++k) {
          const int w = s.nbr[k];
          if (!mark[w] && outline(w) == outline(first) && degree(w) > degree(a)) a = w;
        }
      take(a);
    }
    taken->push_back(anchors);
    if (anchors.size() < 2) {
      for (std::size_t L = level_index; L < s.searched.size(); ++L) s.searched[L] = {};
      break;
    }
    if (!fine) {  // the finer level's limits, both ways
      const std::vector<std::size_t>& level = levels.back();
      g_begin.assign(n + 1, 0);
      for (std::size_t k : level) {
        ++g_begin[li[k][0] + 1];
        ++g_begin[li[k][1] + 1];
      }
      for (std::size_t i = 0; i < n; ++i) g_begin[i + 1] += g_begin[i];
      g_to.resize(g_begin[n]);
      g_len.resize(g_begin[n]);
      g_edges.resize(g_begin[n]);
      std::vector<int> fill(g_begin.begin(), g_begin.end() - 1);
      for (std::size_t k : level)
        for (int e = 0; e < 2; ++e) {
          const int f = fill[li[k][e]]++;
          g_to[f] = li[k][1 - e];
          g_len[f] = lr[k];
          g_edges[f] = lh[k];
        }
    }
    // Which anchors' searches must run again (all, without `reuse`): a search reads the graph
    // no further than 2 S edges of the cloth from its anchor.
    // Above S = 16 a level's few dozen searches cost less than finding which to run.
    std::vector<char> again(n, 1);
    SolverArrays::LimitSearch* kept = S <= 16 ? &s.searched[level_index] : nullptr;
    if (reuse && kept && kept->anchor.size() <= n) {
      // A coarse level's graph is the finer level's limits: a vertex whose limits are not those
      // the last build's search read has changed.
      std::vector<char> limits_changed;
      if (!fine) {
        limits_changed.assign(n, 1);
        const std::size_t old_n = kept->g_begin.empty() ? 0 : kept->g_begin.size() - 1;
        for (std::size_t v = 0; v < std::min(n, old_n); ++v) {
          const int b = g_begin[v], e = g_begin[v + 1], ob = kept->g_begin[v];
          if (e - b != kept->g_begin[v + 1] - ob) continue;
          bool same = true;
          for (int k = 0; k < e - b && same; ++k)
            same = g_to[b + k] == kept->g_to[ob + k] && g_len[b + k] == kept->g_len[ob + k] &&
                   g_edges[b + k] == kept->g_edges[ob + k];
          limits_changed[v] = !same;
        }
      }
      const std::vector<char>& read_changed = fine ? changed : limits_changed;
      std::vector<int> depth(n, -1);
      queue.clear();
      for (std::size_t v = 0; v < n; ++v)
        if (read_changed[v] || anchor[v] != (v < kept->anchor.size() ? kept->anchor[v] : 0)) {
          depth[v] = 0;
          queue.push_back(static_cast<int>(v));
        }
      for (std::size_t q = 0; q < queue.size(); ++q) {
        const int u = queue[q];
        if (depth[u] >= 2 * S) continue;
        for (int k = s.nbr_begin[u]; k < s.nbr_begin[u + 1]; ++k)
          if (depth[s.nbr[k]] < 0) {
            depth[s.nbr[k]] = depth[u] + 1;
            queue.push_back(s.nbr[k]);
          }
      }
      for (std::size_t v = 0; v < n; ++v) again[v] = depth[v] >= 0;
    }
    std::size_t before = li.size();
    // Join anchors: Dijkstra on rest lengths, no further than 2 S edges. The anchors in contiguous
    // pieces, in parallel, each piece with its own scratch and its own list, joined in anchor order
    // (the same limits in the same order as one thread would find).
    const int na = static_cast<int>(anchors.size());
    const int pieces = std::min(na, 4 * std::max(1, parallel::thread_count()));
    std::vector<std::vector<std::array<int, 2>>> piece_li(pieces);
    std::vector<std::vector<double>> piece_lr(pieces);
    std::vector<std::vector<int>> piece_lh(pieces);
    std::vector<int> piece_searches(pieces, 0);
    parallel::for_range(pieces, 1, [&](int p0, int p1) {
      std::vector<double> dist;  // sized at the first search: after an edit most anchors keep theirs
      std::vector<int> hops, reached;
      VertexHeap heap;
      for (int piece = p0; piece < p1; ++piece) {
        const int a0 = parallel::piece_begin(na, piece, pieces), a1 = parallel::piece_begin(na, piece + 1, pieces);
        for (int q = a0; q < a1; ++q) {
          const int a = anchors[q];
          if (!again[a]) {
            const int k0 = kept->first[a], k1 = k0 + kept->count[a];
            for (int k = k0; k < k1; ++k) piece_li[piece].push_back({a, kept->to[k]});
            piece_lr[piece].insert(piece_lr[piece].end(), kept->rest.begin() + k0, kept->rest.begin() + k1);
            piece_lh[piece].insert(piece_lh[piece].end(), kept->edges.begin() + k0, kept->edges.begin() + k1);
            continue;
          }
          if (dist.empty()) {
            dist.assign(n, std::numeric_limits<double>::infinity());
            hops.assign(n, -1);
            heap.resize(n);
          }
          ++piece_searches[piece];
          reached.assign(1, a);
          dist[a] = 0;
          hops[a] = 0;
          heap.push_or_lower(0.0, a);
          while (!heap.empty()) {
            const auto [d, u] = heap.pop();
            if (u != a && anchor[u] && u > a) {
              piece_li[piece].push_back({a, u});
              piece_lr[piece].push_back(d);
              piece_lh[piece].push_back(hops[u]);
            }
            for (int k = g_begin[u]; k < g_begin[u + 1]; ++k) {
              if (hops[u] + g_edges[k] > 2 * S) continue;
              const int w = g_to[k];
              const double nd = d + g_len[k];
              if (nd < dist[w]) {
                if (!std::isfinite(dist[w])) reached.push_back(w);
                dist[w] = nd;
                hops[w] = hops[u] + g_edges[k];
                heap.push_or_lower(nd, w);
              }
            }
          }
          for (int u : reached) {
            dist[u] = std::numeric_limits<double>::infinity();
            hops[u] = -1;
          }
        }
      }
    });
    for (int piece = 0; piece < pieces; ++piece) {
      li.insert(li.end(), piece_li[piece].begin(), piece_li[piece].end());
      lr.insert(lr.end(), piece_lr[piece].begin(), piece_lr[piece].end());
      lh.insert(lh.end(), piece_lh[piece].begin(), piece_lh[piece].end());
    }
    std::vector<std::size_t> idx;
    for (std::size_t k = before; k < li.size(); ++k) idx.push_back(k);
    levels.push_back(idx);
    for (int c : piece_searches) s.searches += c;
    if (kept) {  // kept for the next rebuild: each anchor's limits are consecutive
      SolverArrays::LimitSearch found;
      found.anchor = anchor;
      if (!fine) {
        found.g_begin = g_begin;
        found.g_to = g_to;
        found.g_len = g_len;
        found.g_edges = g_edges;
      }
      found.first.assign(n, 0);
      found.count.assign(n, 0);
      found.to.resize(li.size() - before);
      for (std::size_t k = before; k < li.size(); ++k) {
        const int a = li[k][0];
        if (found.count[a]++ == 0) found.first[a] = static_cast<int>(k - before);
        found.to[k - before] = li[k][1];
      }
      found.rest.assign(lr.begin() + before, lr.end());
      found.edges.assign(lh.begin() + before, lh.end());
      *kept = std::move(found);
    }
  }
  s.anchors = std::move(taken);
  // Coarse to fine, each level scheduled on its own (its blocks, then the limits across blocks).
  s.l_ranges.assign(1, 0);
  s.l_kinds.clear();
  std::vector<int> perm, offsets;
  std::vector<unsigned char> kinds;
  for (auto it = levels.rbegin(); it != levels.rend(); ++it) {
    const std::vector<std::size_t>& level = *it;
    schedule<2>(level.size(), n, s.block, s.blocks, [&](std::size_t c) { return li[level[c]]; }, perm, offsets, kinds);
    for (int q : perm) {
      const std::size_t k = level[q];
      s.l_i.push_back(li[k][0]);
      s.l_j.push_back(li[k][1]);
      s.l_rest.push_back(lr[k]);
    }
    const int base = s.l_ranges.back();
    for (std::size_t c = 1; c < offsets.size(); ++c) s.l_ranges.push_back(base + offsets[c]);
    s.l_kinds.insert(s.l_kinds.end(), kinds.begin(), kinds.end());
  }
}

// A Bullet tree (btDbvt) over leaves in Morton order, split where the codes' highest differing
// bit changes (a linear BVH, Karras 2012; halves where codes are equal): O(n) after the sort, and
// on cloth its self-collision queries are as fast as btDbvt::optimizeTopDown's tree, whose
// bottom-up pass over blocks of 128 leaves (and the one-by-one insertion before it) made a rebuild
// cost more than the queries it serves (docs/benchmarks.md). The nodes lie in one block, `pool`
// (SolverArrays::tri_nodes), which the tree never frees: only refitted and searched, it never
// inserts or removes a node.
btDbvtNode* build_node(const std::vector<std::pair<std::uint32_t, int>>& keys, int b, int e,
                       const std::vector<btDbvtVolume>& volumes, btDbvtNode* parent,
                       std::vector<btDbvtNode*>& leaf_of, std::vector<btDbvtNode>& pool) {
  btDbvtNode* node = &pool.emplace_back();
  node->parent = parent;
  if (e - b == 1) {
    const int id = keys[b].second;
    node->childs[1] = nullptr;
    node->data = reinterpret_cast<void*>(static_cast<std::intptr_t>(id));
    node->volume = volumes[id];
    leaf_of[id] = node;
    return node;
  }
  int mid = b + (e - b) / 2;
  const std::uint32_t diff = keys[b].first ^ keys[e - 1].first;
  if (diff != 0) {
    const std::uint32_t bit = std::uint32_t(1) << (31 - __builtin_clz(diff));
    mid = static_cast<int>(std::partition_point(keys.begin() + b, keys.begin() + e,
                                                [&](const auto& k) { return !(k.first & bit); }) -
                           keys.begin());
  }
  node->childs[0] = build_node(keys, b, mid, volumes, node, leaf_of, pool);
  node->childs[1] = build_node(keys, mid, e, volumes, node, leaf_of, pool);
  Merge(node->childs[0]->volume, node->childs[1]->volume, node->volume);
  return node;
}

void build_tree(btDbvt& tree, const std::vector<std::pair<std::uint32_t, int>>& keys,
                const std::vector<btDbvtVolume>& volumes, std::vector<btDbvtNode*>& leaf_of,
                std::vector<btDbvtNode>& pool) {
  tree.m_root = nullptr;  // its nodes are the pool's
  tree.m_leaves = 0;
  tree.clear();
  pool.clear();
  if (keys.empty()) return;
  pool.reserve(2 * keys.size() - 1);  // a binary tree's nodes: no reallocation moves them
  tree.m_root = build_node(keys, 0, static_cast<int>(keys.size()), volumes, nullptr, leaf_of, pool);
  tree.m_leaves = static_cast<int>(keys.size());
}

// The triangles each vertex is never paired with in self-collision (those with a corner at it or
// at a neighbour), as masks over their clusters (SolverArrays::excl_*).
void build_self_exclusions(SolverArrays& s) {
  static_assert(SolverArrays::kTriCluster <= 8, "a cluster's triangles are bits of one byte");
  const std::size_t n = s.n;
  // Each vertex's triangles, by their places in the cluster order.
  std::vector<int> tri_slot(s.tris.size()), inc_begin(n + 1, 0), inc;
  for (std::size_t q = 0; q < s.tcl_items.size(); ++q) tri_slot[s.tcl_items[q]] = static_cast<int>(q);
  for (const auto& t : s.tris)
    for (int u : t) ++inc_begin[u + 1];
  for (std::size_t i = 0; i < n; ++i) inc_begin[i + 1] += inc_begin[i];
  inc.resize(inc_begin[n]);
  std::vector<int> fill(inc_begin.begin(), inc_begin.end() - 1);
  for (std::size_t t = 0; t < s.tris.size(); ++t)
    for (int u : s.tris[t]) inc[fill[u]++] = tri_slot[t];
  // Each vertex's clusters in pieces of the vertex clusters' order, in parallel, joined in order
  // (the same lists whatever the thread count): a cluster's bits gathered in a mask per cluster,
  // the clusters met sorted (a dozen a vertex, where sorting every corner met cost six times as much).
  // A vertex's own triangles are its neighbours' too (their other corners are its neighbours).
  const int nv = static_cast<int>(s.vcl_items.size());
  const int clusters = static_cast<int>((s.tcl_items.size() + SolverArrays::kTriCluster - 1) / SolverArrays::kTriCluster);
  const int pieces = std::max(1, std::min(nv, 4 * parallel::thread_count()));
  std::vector<std::vector<int>> piece_cluster(pieces), piece_count(pieces);
  std::vector<std::vector<std::uint8_t>> piece_mask(pieces);
  parallel::for_range(pieces, 1, [&](int p0, int p1) {
    std::vector<std::uint8_t> acc(clusters, 0);
    std::vector<int> met;
    for (int piece = p0; piece < p1; ++piece) {
      std::vector<int>& out_cluster = piece_cluster[piece];
      std::vector<std::uint8_t>& out_mask = piece_mask[piece];
      std::vector<int>& out_count = piece_count[piece];
      const int b = parallel::piece_begin(nv, piece, pieces), e = parallel::piece_begin(nv, piece + 1, pieces);
      out_count.reserve(e - b);
      out_cluster.reserve(14 * (e - b));
      out_mask.reserve(14 * (e - b));
      for (int p = b; p < e; ++p) {
        const int v = s.vcl_items[p];
        int count = 0;
        for (int k = s.nbr_begin[v]; k < s.nbr_begin[v + 1]; ++k) {
          const int u = s.nbr[k];
          const std::size_t most = count + inc_begin[u + 1] - inc_begin[u];
          if (met.size() < most) met.resize(std::max(2 * met.size(), most));
          for (int j = inc_begin[u]; j < inc_begin[u + 1]; ++j) {
            const int q = inc[j], c = q / SolverArrays::kTriCluster;
            met[count] = c;  // kept where it is first met (without a branch: whether it is, is a coin toss)
            count += !acc[c];
            acc[c] |= std::uint8_t(1u << (q % SolverArrays::kTriCluster));
          }
        }
        for (int i = 1; i < count; ++i) {  // a dozen: insertion
          const int c = met[i];
          int j = i;
          for (; j > 0 && met[j - 1] > c; --j) met[j] = met[j - 1];
          met[j] = c;
        }
        for (int i = 0; i < count; ++i) {
          const int c = met[i];
          out_cluster.push_back(c);
          out_mask.push_back(acc[c]);
          acc[c] = 0;
        }
        out_count.push_back(count);
      }
    }
  });
  s.excl_begin.assign(1, 0);
  s.excl_cluster.clear();
  s.excl_mask.clear();
  for (int piece = 0; piece < pieces; ++piece) {
    s.excl_cluster.insert(s.excl_cluster.end(), piece_cluster[piece].begin(), piece_cluster[piece].end());
    s.excl_mask.insert(s.excl_mask.end(), piece_mask[piece].begin(), piece_mask[piece].end());
    for (int c : piece_count[piece]) s.excl_begin.push_back(s.excl_begin.back() + c);
  }
}

// Where the vertices lay for the build before an edit, kept for those it had, so that the order,
// the blocks and the collision clusters change only around the edit (a sleeping block sleeps on).
// A vertex the edit made lies at the mean of its neighbours' places, round by round out from the
// kept ones; one with none (a new piece) where it lies now.
std::shared_ptr<const std::vector<Vec3>> kept_places(const Mesh& m, std::size_t n, const std::vector<Vec3>& was,
                                                     const std::vector<unsigned char>& was_alive) {
  auto at = std::make_shared<std::vector<Vec3>>(n, Vec3::Zero());
  std::vector<char> known(n, 0);
  std::vector<int> fresh, left;
  for (Vertex v : m.vertices()) {
    const std::size_t i = v.idx();
    if (i < was.size() && was_alive[i]) {
      (*at)[i] = was[i];
      known[i] = 1;
    } else {
      fresh.push_back(static_cast<int>(i));
    }
  }
  std::vector<std::pair<int, Vec3>> placed;
  while (!fresh.empty()) {
    placed.clear();
    left.clear();
    for (int i : fresh) {
      const Vertex v = vtx(i);
      Vec3 sum = Vec3::Zero();
      int count = 0;
      if (m.halfedge(v) != Mesh::null_halfedge())
        for (Vertex u : CGAL::vertices_around_target(m.halfedge(v), m))
          if (known[u.idx()]) {
            sum += (*at)[u.idx()];
            ++count;
          }
      if (count > 0)
        placed.emplace_back(i, sum / count);
      else
        left.push_back(i);
    }
    if (placed.empty()) {
      for (int i : left) (*at)[i] = to_vec(m.point(vtx(i)));
      break;
    }
    for (const auto& [i, p] : placed) {
      (*at)[i] = p;
      known[i] = 1;
    }
    fresh.swap(left);
  }
  return at;
}

double heron(double a, double b, double c) {
  const double s = 0.5 * (a + b + c);
  const double q = s * (s - a) * (s - b) * (s - c);
  return q > 0 ? std::sqrt(q) : 0.0;
}

// The bending constraints, in the blocks' order (see schedule).
void build_bending(SolverArrays& s, const Garment& g) {
  const Mesh& m = g.mesh();
  const std::size_t n = s.n;
  // Isometric bending (Bergou et al. 2006, "A quadratic bending model for inextensible surfaces")
  // on every interior edge, from the rest lengths (the pattern is flat at rest).
  std::vector<SolverArrays::Bend> bends;
  for (Edge e : m.edges()) {
    if (m.is_border(e)) continue;
    const Halfedge h = m.halfedge(e), o = m.opposite(h);
    const int a = static_cast<int>(m.source(h).idx()), b = static_cast<int>(m.target(h).idx());
    const int c = static_cast<int>(m.target(m.next(h)).idx());
    const int d = static_cast<int>(m.target(m.next(o)).idx());
    if (c == d) continue;
    const double lab = g.rest_length(e);
    const double lbc = g.rest_length(m.edge(m.next(h))), lca = g.rest_length(m.edge(m.prev(h)));
    const double lad = g.rest_length(m.edge(m.next(o))), ldb = g.rest_length(m.edge(m.prev(o)));
    const double A0 = heron(lab, lbc, lca), A1 = heron(lab, lad, ldb);
    if (!(A0 > 1e-14) || !(A1 > 1e-14)) continue;
    const double c01 = (lab * lab + lca * lca - lbc * lbc) / (4 * A0);  // angle at a, triangle abc
    const double c02 = (lab * lab + lad * lad - ldb * ldb) / (4 * A1);  // angle at a, triangle abd
    const double c03 = (lab * lab + lbc * lbc - lca * lca) / (4 * A0);  // angle at b, triangle abc
    const double c04 = (lab * lab + ldb * ldb - lad * lad) / (4 * A1);  // angle at b, triangle abd
    // Bergou's weight is 3 / (A0 + A1) for the integral of the squared mean-curvature normal; with
    // 1 / (A0 + A1) the energy (k_b / 2) |C|^2 summed over edges matches (k_b / 2) kappa^2 per unit
    // area on a cylinder (checked on this triangulation to within the border edges' share), so
    // k_b is the fabric's bending rigidity in N m.
    const double sc = std::sqrt(1.0 / (A0 + A1));
    SolverArrays::Bend bd{{a, b, c, d},
                          {sc * (c03 + c04), sc * (c01 + c02), sc * (-c01 - c03), sc * (-c02 - c04)}};
    bends.push_back(bd);
  }
  std::vector<int> perm;
  schedule<4>(bends.size(), n, s.block, s.blocks,
              [&](std::size_t c) {
                return std::array<int, 4>{bends[c].v[0], bends[c].v[1], bends[c].v[2], bends[c].v[3]};
              },
              perm, s.b_ranges, s.b_kinds);
  s.bends.resize(perm.size());
  for (std::size_t k = 0; k < perm.size(); ++k) s.bends[k] = bends[perm[k]];
}

}  // namespace

void rebuild(SolverArrays& s, const Garment& g) {
  const Mesh& m = g.mesh();
  const std::size_t n = g.vertex_capacity();
  const bool had_searches = s.built;  // the last build's searches are whole
  s.built = false;
  s.garment = &g;
  s.topology = g.topology_version();
  s.n = n;
  s.alive.assign(n, 0);
  s.moving.assign(n, 0);
  // The step fills these from the garment; nothing below reads them (reset beside the work below).
  auto reset_state = [&] {
    s.x.assign(n, Vec3::Zero());
    s.xp = s.x0 = s.v = s.fext = s.pred = s.unkick = s.x;
  };
  s.w.assign(n, 0.0);
  s.surprise.assign(n, 0.0);
  s.surprise_self.assign(n, 0.0);
  s.held_up.assign(n, 0);
  for (Vertex v : m.vertices()) s.alive[v.idx()] = 1;

  // A solver that stepped this mesh before left its record (a session opened from its file, a peer
  // after a checkpoint, an undo): the arrays are built from where the cloth lay when that solver
  // built its own, and take up its state, so that this one steps on as that one would have.
  s.mesh_key = mesh_key(g);
  s.carried = g.step_record();
  const std::shared_ptr<const StepRecord> before = s.carried;
  // Its long-range anchors, even where the record is of the mesh before an edit (build_long_range).
  const std::shared_ptr<const std::vector<std::vector<int>>> before_anchors = s.carried ? s.carried->anchors : nullptr;
  if (s.carried && (s.carried->mesh != s.mesh_key || !s.carried->built_at || s.carried->built_at->size() != n ||
                    s.carried->surprise.size() != n || s.carried->surprise_self.size() != n || s.carried->held_up.size() != n))
    s.carried.reset();
  if (s.carried) {
    s.built_at = s.carried->built_at;
    s.surprise = s.carried->surprise;
    s.surprise_self = s.carried->surprise_self;
    s.held_up = s.carried->held_up;
  } else if (before && before->built_at && before->built_alive &&
             before->built_alive->size() == before->built_at->size() && before->built_at->size() <= n) {
    s.built_at = kept_places(m, n, *before->built_at, *before->built_alive);
  } else {
    auto at = std::make_shared<std::vector<Vec3>>(n, Vec3::Zero());
    for (Vertex v : m.vertices()) (*at)[v.idx()] = to_vec(m.point(v));
    s.built_at = std::move(at);
  }
  s.built_alive = std::make_shared<const std::vector<unsigned char>>(s.alive);
  const std::vector<Vec3>& built_at = *s.built_at;

  // Spatial order of the vertices (for collision clusters): Morton code of where they lay for it.
  Box3 box;
  for (Vertex v : m.vertices()) box.extend(built_at[v.idx()]);
  std::vector<std::pair<std::uint32_t, int>> keyed;
  keyed.reserve(m.number_of_vertices());
  const Vec3 ext = box.isEmpty() ? Vec3::Ones() : Vec3(box.sizes().cwiseMax(1e-9));
  auto morton = [&](const Vec3& p) {
    const Vec3 q = ((p - box.min()).cwiseQuotient(ext) * 1023.0).cwiseMax(0.0).cwiseMin(1023.0);
    return spread_bits(std::uint32_t(q.x())) | (spread_bits(std::uint32_t(q.y())) << 1) |
           (spread_bits(std::uint32_t(q.z())) << 2);
  };
  for (Vertex v : m.vertices()) keyed.emplace_back(morton(built_at[v.idx()]), static_cast<int>(v.idx()));
  sort_by_code(keyed);
  s.order.clear();
  for (const auto& k : keyed) s.order.push_back(k.second);
  const std::vector<std::pair<std::uint32_t, int>> vertex_keys = keyed;

  // The edges, for the stretch constraints (coloured) and the neighbours.
  std::vector<int> ei, ej;
  std::vector<Edge> eh;
  auto list_edges = [&] {
    ei.reserve(m.number_of_edges());
    ej.reserve(m.number_of_edges());
    eh.reserve(m.number_of_edges());
    for (Edge e : m.edges()) {
      const Halfedge h = m.halfedge(e);
      ei.push_back(static_cast<int>(m.source(h).idx()));
      ej.push_back(static_cast<int>(m.target(h).idx()));
      eh.push_back(e);
    }
  };
  // Blocks of about kBlockVertices vertices each, consecutive in the spatial order: compact patches
  // of the cloth.
  constexpr int kBlockVertices = 1024;
  const int live = static_cast<int>(s.order.size());
  s.blocks = std::clamp(live / kBlockVertices, 1, SolverArrays::kMaxBlocks);
  s.block.assign(n, 0);
  for (int r = 0; r < live; ++r) s.block[s.order[r]] = static_cast<int>(std::int64_t(r) * s.blocks / live);
  auto stretch = [&] {
    std::vector<int> perm;
    schedule<2>(ei.size(), n, s.block, s.blocks, [&](std::size_t c) { return std::array<int, 2>{ei[c], ej[c]}; }, perm,
                s.e_ranges, s.e_kinds);
    s.e_i.resize(perm.size());
    s.e_j.resize(perm.size());
    s.e_handle.resize(perm.size());
    s.e_rest.assign(perm.size(), 0.0);
    for (std::size_t k = 0; k < perm.size(); ++k) {
      s.e_i[k] = ei[perm[k]];
      s.e_j[k] = ej[perm[k]];
      s.e_handle[k] = eh[perm[k]];
    }
  };
  // Triangles and neighbours.
  auto neighbours = [&] {
    s.tris.clear();
    for (Face f : m.faces()) {
      std::array<int, 3> t{};
      int k = 0;
      for (Vertex v : CGAL::vertices_around_face(m.halfedge(f), m)) {
        if (k < 3) t[k] = static_cast<int>(v.idx());
        ++k;
      }
      if (k == 3) s.tris.push_back(t);
    }
    if (had_searches) {
      s.searched_nbr_begin.swap(s.nbr_begin);
      s.searched_nbr.swap(s.nbr);
      s.searched_nbr_rest.swap(s.nbr_rest);
    }
    s.nbr_begin.assign(n + 1, 0);
    for (std::size_t k = 0; k < ei.size(); ++k) {
      ++s.nbr_begin[ei[k] + 1];
      ++s.nbr_begin[ej[k] + 1];
    }
    for (std::size_t i = 0; i < n; ++i) s.nbr_begin[i + 1] += s.nbr_begin[i];
    s.nbr.assign(s.nbr_begin[n], 0);
    s.nbr_rest.assign(s.nbr_begin[n], 0.0);
    s.spacing.assign(n, 0.0);
    {
      std::vector<int> fill(s.nbr_begin.begin(), s.nbr_begin.end() - 1);
      for (std::size_t k = 0; k < ei.size(); ++k) {
        const double r = g.rest_length(eh[k]);
        s.nbr_rest[fill[ei[k]]] = r;
        s.nbr[fill[ei[k]]++] = ej[k];
        s.nbr_rest[fill[ej[k]]] = r;
        s.nbr[fill[ej[k]]++] = ei[k];
        for (int u : {ei[k], ej[k]}) s.spacing[u] = s.spacing[u] > 0 ? std::min(s.spacing[u], r) : r;
      }
    }
  };

  // Self-collision trees: a leaf per cluster of nearby triangles and of nearby vertices (runs in
  // Morton order), built once, refitted at each gather.
  auto collision_structures = [&] {
    auto cluster_tree = [&](const std::vector<std::pair<std::uint32_t, int>>& sorted, int size,
                            const std::vector<Box3>& item_box, btDbvt& tree, std::vector<btDbvtNode>& pool,
                            std::vector<int>& begin, std::vector<int>& items, std::vector<btDbvtNode*>& leaf_of) {
      const int count = static_cast<int>(sorted.size()), clusters = (count + size - 1) / size;
      begin.assign(1, 0);
      items.clear();
      std::vector<std::pair<std::uint32_t, int>> keys;
      std::vector<btDbvtVolume> volumes;
      for (int c = 0; c < clusters; ++c) {
        Box3 b;
        for (int k = c * size; k < std::min(count, (c + 1) * size); ++k) {
          items.push_back(sorted[k].second);
          b.extend(item_box[sorted[k].second]);
        }
        begin.push_back(static_cast<int>(items.size()));
        keys.emplace_back(sorted[c * size].first, c);
        volumes.push_back(btDbvtVolume::FromMM(btVector3(b.min().x(), b.min().y(), b.min().z()),
                                               btVector3(b.max().x(), b.max().y(), b.max().z())));
      }
      leaf_of.assign(clusters, nullptr);
      build_tree(tree, keys, volumes, leaf_of, pool);
    };
    std::vector<Box3> item_box(s.tris.size());
    keyed.clear();
    for (std::size_t t = 0; t < s.tris.size(); ++t) {
      for (int k = 0; k < 3; ++k) item_box[t].extend(built_at[s.tris[t][k]]);
      keyed.emplace_back(morton(item_box[t].center()), static_cast<int>(t));
    }
    sort_by_code(keyed);
    cluster_tree(keyed, SolverArrays::kTriCluster, item_box, s.tri_tree, s.tri_nodes, s.tcl_begin, s.tcl_items, s.tcl_leaf);
    item_box.assign(n, Box3());
    for (Vertex v : m.vertices()) item_box[v.idx()].extend(built_at[v.idx()]);
    cluster_tree(vertex_keys, SolverArrays::kVertCluster, item_box, s.vert_tree, s.vert_nodes, s.vcl_begin, s.vcl_items, s.vcl_leaf);
    build_self_exclusions(s);
  };
  // After an edit, two lines of work, one a thread: the edges, triangles and neighbours, then the
  // long-range limits (they read those); beside them the state's reset, then the collision's
  // structures (once the triangles and neighbours are there). The bending constraints, which read
  // nothing of the first line's, fill the wait for the neighbours; what is left of them and of the
  // stretch constraints (which read the edges) goes to the first thread done. They write apart; a
  // loop within any runs on its own thread. A first build, whose long-range searches are most of
  // it, shares those between the threads instead.
  if (had_searches) {
    enum : int { kPending, kDone, kFailed };
    std::atomic<int> neighboured{kPending};
    std::atomic<bool> bending_taken{false}, stretch_taken{false};
    auto bend_once = [&] {
      if (!bending_taken.exchange(true)) build_bending(s, g);
    };
    auto stretch_once = [&] {
      if (!stretch_taken.exchange(true)) stretch();
    };
    parallel::for_each(2, [&](int task) {
      if (task == 0) {
        try {
          list_edges();
          neighbours();
        } catch (...) {
          neighboured.store(kFailed, std::memory_order_release);
          throw;
        }
        neighboured.store(kDone, std::memory_order_release);
        build_long_range(s, had_searches, before_anchors.get());
      } else {
        reset_state();
        // Task 0 is claimed first: it runs on another thread, or ran to its end on this one.
        if (neighboured.load(std::memory_order_acquire) == kPending) bend_once();
        int state;
        while ((state = neighboured.load(std::memory_order_acquire)) == kPending) std::this_thread::yield();
        if (state != kDone) return;
        collision_structures();
      }
      bend_once();
      stretch_once();
    });
  } else {
    list_edges();
    parallel::for_each(2, [&](int task) {
      if (task == 0) {
        stretch();
        neighbours();
      } else {
        build_bending(s, g);
      }
    });
    reset_state();
    build_long_range(s, had_searches, before_anchors.get());
    collision_structures();
  }

  s.self_pairs.clear();
  s.sleep_ready = false;  // everything awake, but what the garment's sleep record finds as it slept
  s.built = true;
}

}  // namespace solver_detail

void Solver::step(Garment& garment, double dt) {
  if (!std::isfinite(dt) || dt <= 0) {
    forces_.clear();
    std::ostringstream msg;
    msg << "time step dt is " << dt << ": it must be a positive finite number of seconds (e.g. 1/60)";
    throw InputError(msg.str());
  }
  params_.validate();
  const Material& mat = garment.material();
  mat.validate();
  const Mesh& m = garment.mesh();
  const std::size_t n = garment.vertex_capacity();

  // Check the input state before touching anything.
  try {
    check_garment(garment);
  } catch (const InputError&) {
    forces_.clear();
    throw;
  }
  for (const auto& f : forces_) {
    if (f.vertex.idx() >= n || m.is_removed(f.vertex) || !all_finite(f.force)) {
      forces_.clear();
      throw InputError("an external force is on a vertex that does not exist or is not finite: "
                       "apply finite forces to vertices of this garment");
    }
  }

  State& s = *state_;
  const auto started = std::chrono::steady_clock::now();
  const double shared_before = parallel::shared_seconds();
  const bool rebuilt = build_if_needed(s, garment);
  const double rebuild_ms = 1000 * std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();

  // Mirror the mesh into the flat arrays.
  const bool mass_spring = params_.model == SolverModel::MassSpring;
  const bool local = params_.local_radius > 0;
  const double r2 = params_.local_radius * params_.local_radius;
  // Sleeping blocks that anything has disturbed since the last step: an edit of a vertex (its
  // position, velocity or pin) or of a rest length, a hand, a force, an open seam.
  const bool sleeping = params_.sleep_after > 0 && s.sleep_ready;
  s.im.resize(n, 0.0);
  // In parallel pieces, each marking the blocks it finds disturbed in its own flags.
  std::vector<unsigned char> disturbed(s.blocks, 0);
  const int pieces = parallel::piece_count(static_cast<int>(n), 4096);
  std::vector<std::array<unsigned char, SolverArrays::kMaxBlocks>> piece_disturbed(pieces);
  for (auto& d : piece_disturbed) d.fill(0);
  parallel::for_each(pieces, [&](int piece) {
    unsigned char* dist = piece_disturbed[piece].data();
    const int i1 = parallel::piece_begin(static_cast<int>(n), piece + 1, pieces);
    for (int i = parallel::piece_begin(static_cast<int>(n), piece, pieces); i < i1; ++i) {
      if (!s.alive[i]) {
        s.moving[i] = 0;
        s.w[i] = 0;
        continue;
      }
      const Vertex v = vtx(i);
      const Vec3 x = garment.position(v);
      const double im = garment.inverse_mass(v);
      // An edit since the last step: of any vertex's position or pin (the step wrote every vertex
      // it moved exactly; a block calm but awake when a pin is let go must not fall asleep with the
      // cloth hanging in the air), or of a sleeping vertex's velocity.
      if (sleeping && (x != s.x[i] || im != s.im[i] || (s.asleep[s.block[i]] && garment.velocity(v) != Vec3::Zero())))
        dist[s.block[i]] = 1;
      s.x[i] = x;
      s.v[i] = garment.velocity(v);
      s.fext[i].setZero();
      s.im[i] = im;
      bool in = im > 0;
      if (local && (s.x[i] - params_.local_center).squaredNorm() > r2) in = false;
      s.moving[i] = in;
      s.w[i] = in ? (mass_spring ? 1.0 : im) : 0.0;
    }
    const int ne = static_cast<int>(s.e_handle.size());
    const int k1 = parallel::piece_begin(ne, piece + 1, pieces);
    for (int k = parallel::piece_begin(ne, piece, pieces); k < k1; ++k) {
      const double rest = garment.rest_length(s.e_handle[k]);
      // (After a rebuild, which leaves e_rest zero, all differ: nothing sleeps yet to disturb.)
      if (sleeping && rest != s.e_rest[k]) dist[s.block[s.e_i[k]]] = dist[s.block[s.e_j[k]]] = 1;
      s.e_rest[k] = rest;
    }
  });
  for (const auto& d : piece_disturbed)
    for (int b = 0; b < s.blocks; ++b) disturbed[b] |= d[b];
  // No vertex lighter than half the garment's median vertex in the solve. A knife's small triangles
  // leave vertices a tenth to a fortieth as heavy as their neighbours; each projection of an edge
  // beside one moved it nearly the whole way, so the strain limit did not converge around it and a
  // cut border hung stretched (docs/benchmarks.md, "The border's stretch"). A border vertex of an
  // even mesh weighs half an inner one and is left as it is.
  if (!mass_spring) {
    s.im_median.clear();
    for (std::size_t i = 0; i < n; ++i)
      if (s.alive[i] && s.im[i] > 0) s.im_median.push_back(s.im[i]);
    if (!s.im_median.empty()) {
      const auto mid = s.im_median.begin() + s.im_median.size() / 2;
      std::nth_element(s.im_median.begin(), mid, s.im_median.end());
      const double cap = *mid / kLightestShare;
      for (std::size_t i = 0; i < n; ++i) s.w[i] = std::min(s.w[i], cap);
    }
  }
  for (const auto& f : forces_) {
    s.fext[f.vertex.idx()] += f.force;
    disturbed[s.block[f.vertex.idx()]] = 1;
  }
  forces_.clear();
  // Hands on the cloth (dropping those whose vertex is gone) and tacks.
  attachments_.erase(std::remove_if(attachments_.begin(), attachments_.end(),
                                    [&](const Attachment& a) { return a.vertex.idx() >= n || !s.alive[a.vertex.idx()]; }),
                     attachments_.end());
  s.attach.clear();
  for (const auto& a : attachments_)
    s.attach.push_back({static_cast<int>(a.vertex.idx()), a.target, a.from, a.stiffness, a.firm});
  s.tacks.clear();
  for (const auto& [a, b] : garment.tacks)
    if (a.idx() < n && b.idx() < n && s.alive[a.idx()] && s.alive[b.idx()])
      s.tacks.push_back({static_cast<int>(a.idx()), static_cast<int>(b.idx())});
  for (const auto& a : s.attach) disturbed[s.block[a.i]] = 1;
  for (const auto& [a, b] : s.tacks)
    if ((s.x[a] - s.x[b]).squaredNorm() > params_.sleep_distance * params_.sleep_distance)
      disturbed[s.block[a]] = disturbed[s.block[b]] = 1;
  const auto sleep_started = std::chrono::steady_clock::now();
  solver_detail::sleep_before_step(s, params_, mat, disturbed, garment.sleep_record().get());
  // A rebuild's cost includes finding which of the cloth sleeps on as it slept.
  const double sleep_ms = 1000 * std::chrono::duration<double>(std::chrono::steady_clock::now() - sleep_started).count();

  const BodyCollider* body = (params_.body_collision && collider_) ? collider_.get() : nullptr;
  s.report = StepReport{};
  s.report.ms.rebuild = rebuilt ? rebuild_ms + sleep_ms : 0.0;
  // The report's times (the rest of the step's, below, once it is written back).
  auto finish_times = [&] {
    s.report.ms.total = 1000 * std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    s.report.ms.shared = 1000 * (parallel::shared_seconds() - shared_before);
  };
  // Xpbd takes more substeps while a plain hand holds a moving vertex (SolverParams::held_substeps):
  // the hand's pull then reaches further into the cloth within the step (docs/benchmarks.md, "A
  // hand's drag at more substeps").
  SolverParams step_params = params_;
  if (!mass_spring && std::any_of(s.attach.begin(), s.attach.end(), [&](const auto& a) { return !a.firm && s.w[a.i] != 0; }))
    step_params.substeps = std::max(step_params.substeps, step_params.held_substeps);
  s.report.substeps = step_params.substeps;
  if (mass_spring)
    solver_detail::step_mass_spring(s, step_params, mat, body, dt);
  else
    solver_detail::step_xpbd(s, step_params, mat, body, dt);

  // A diverged state is never written back: the step is undone (the garment keeps the state it
  // had, and the arrays, whose collision margins the step left non-finite, are built again from it).
  const int diverged = first_where(static_cast<int>(n), [&](int i) {
    return s.moving[i] && (!all_finite(s.x[i]) || !all_finite(s.v[i]));
  });
  if (diverged >= 0) {
    s.built = false;
    finish_times();
    std::ostringstream msg;
    msg << "the simulation of garment '" << garment.name << "' diverged at vertex " << diverged
        << " (its position or velocity would have become infinite or NaN): the step was undone and the garment is as "
           "it was; lower the forces or the hands' stiffness, ";
    msg << (mass_spring ? "lower spring_k or spring_damping, " : "") << "or raise substeps (now " << params_.substeps << ")";
    throw SimulationError(msg.str());
  }
  const bool fell_asleep = solver_detail::sleep_after_step(s, params_, dt);
  parallel::for_range(static_cast<int>(n), 4096, [&](int b, int e) {
    for (int i = b; i < e; ++i) {
      if (!s.alive[i]) continue;
      const Vertex v = vtx(i);
      if (s.moving[i]) {
        garment.set_position(v, s.x[i]);
        garment.velocity(v) = s.v[i];
      } else if (local) {
        // Held still by the local region this step: it has no motion to resume with when the region
        // moves on or the tool lets go.
        garment.velocity(v) = Vec3::Zero();
      }
    }
  });
  if (fell_asleep) garment.set_sleep_record(solver_detail::sleep_record(s));
  solver_detail::write_step_record(s, garment);
  for (auto& a : attachments_) a.from = a.target;
  finish_times();
}

StepReport Solver::last_step() const { return state_->report; }

void Solver::prepare(const Garment& garment) {
  garment.material().validate();
  check_garment(garment);
  build_if_needed(*state_, garment);
}

std::vector<Vec3> Solver::spring_forces(const Garment& garment) const {
  const Mesh& m = garment.mesh();
  std::vector<Vec3> f(garment.vertex_capacity(), Vec3::Zero());
  const double k = params_.spring_k;
  for (Edge e : m.edges()) {
    const Halfedge h = m.halfedge(e);
    const Vertex i = m.source(h), j = m.target(h);
    const Vec3 dij = garment.position(j) - garment.position(i);
    const double lc = dij.norm();  // l'_ij, the current length
    if (!(lc > 0)) continue;
    const Vec3 g = k * (1.0 - garment.rest_length(e) / lc) * (dij / lc);  // eq. 3: g_ij
    f[i.idx()] += g;
    f[j.idx()] -= g;  // g_ji = -g_ij
  }
  return f;
}

ClothMeasures Solver::measure(const Garment& garment) const {
  ClothMeasures r;
  const Mesh& m = garment.mesh();
  r.vertices = m.number_of_vertices();
  double sum = 0;
  std::size_t ne = 0;
  for (Edge e : m.edges()) {
    const double rest = garment.rest_length(e);
    if (!(rest > 0)) continue;
    const double strain = std::abs(garment.length(e) / rest - 1.0);
    r.max_strain = std::max(r.max_strain, strain);
    sum += strain;
    ++ne;
  }
  r.mean_strain = ne ? sum / ne : 0.0;
  r.kinetic_energy = garment.kinetic_energy();
  if (state_->garment == &garment && state_->sleep_ready) r.sleeping = state_->sleeping;
  if (collider_) {
    const double th = garment.material().thickness;
    const double radius = std::max(0.05, 10 * th);
    for (Vertex v : m.vertices()) {
      const BodyContact c = collider_->closest(garment.position(v), radius);
      if (!c.hit) continue;
      // Inside by the body's volume, not by the side of the closest face, which a game model's
      // fins of no thickness and inverted faces get wrong (see BodyCollider::inside).
      if (collider_->inside(garment.position(v))) r.max_penetration = std::max(r.max_penetration, std::abs(c.distance));
      if (c.distance < 1.5 * th) ++r.contacts;
    }
  }
  return r;
}

}  // namespace kiji
