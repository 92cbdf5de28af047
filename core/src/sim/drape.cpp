#include "kiji/drape.h"

#include "base/parallel.h"
#include "kiji/collision.h"
#include "kiji/error.h"

#include <CGAL/Polygon_mesh_processing/remesh.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

namespace kiji {

void place_over_body(Garment& garment, const Body& body, double clearance) {
  if (garment.mesh().is_empty()) throw InputError("place_over_body: the garment has no vertices");
  const Box3 pattern = garment.bounds();
  // Pattern x -> world x, pattern y -> world -z, pattern z -> world y: the cloth lies flat, facing up.
  Eigen::Matrix3d r;
  r << 1, 0, 0,
       0, 0, 1,
       0, -1, 0;
  const Vec3 pattern_centre = pattern.center();
  // Centred over the head and shoulders (the body's top quarter), which carry the cloth: the whole
  // body's box is off centre wherever hands, feet or a pose reach further one way, and a cloth
  // centred on it hangs longer on that side.
  const Box3 box = body.bounds();
  Box3 shoulders;
  const double quarter = box.max().y() - 0.25 * box.sizes().y();
  for (const Vec3& p : body.vertices())
    if (p.y() >= quarter) shoulders.extend(p);
  const Vec3 c = shoulders.center();
  // The highest body point under the cloth's footprint.
  const double half_x = 0.5 * pattern.sizes().x(), half_z = 0.5 * pattern.sizes().y();
  double top = box.min().y();
  for (const Vec3& p : body.vertices())
    if (std::abs(p.x() - c.x()) <= half_x && std::abs(p.z() - c.z()) <= half_z) top = std::max(top, p.y());
  if (top == box.min().y()) top = box.max().y();
  const Vec3 target(c.x(), top + clearance + garment.material().thickness, c.z());
  Eigen::Affine3d t = Eigen::Translation3d(target) * Eigen::Affine3d(r) * Eigen::Translation3d(-pattern_centre);
  garment.transform(t);
  for (Vertex v : garment.mesh().vertices()) garment.velocity(v) = Vec3::Zero();
}

void DrapeOptions::validate() const {
  if (!std::isfinite(seconds) || seconds <= 0 || seconds > 3600) {
    std::ostringstream msg;
    msg << "drape seconds is " << seconds << ": give a simulated time between 0 and 3600 seconds";
    throw InputError(msg.str());
  }
  if (!std::isfinite(frame_rate) || frame_rate < 1 || frame_rate > 10000) {
    std::ostringstream msg;
    msg << "drape frame rate is " << frame_rate << ": give 1 to 10000 steps a second";
    throw InputError(msg.str());
  }
  if (!std::isfinite(coarse_ratio) || coarse_ratio < 1 || coarse_ratio > 8) {
    std::ostringstream msg;
    msg << "drape coarse_ratio is " << coarse_ratio
        << ": give 1 (drape the garment itself throughout) to 8 (a coarse copy's edges that many times as long)";
    throw InputError(msg.str());
  }
  if (coarse_substeps < 1 || coarse_substeps > 1000)
    throw InputError("drape coarse_substeps is " + std::to_string(coarse_substeps) + ": give 1 to 1000");
  if (!std::isfinite(fine_damping) || fine_damping < 0 || fine_damping > 1000) {
    std::ostringstream msg;
    msg << "drape fine_damping is " << fine_damping << ": give 0 (the material's own) to 1000 per second";
    throw InputError(msg.str());
  }
  if (!std::isfinite(fine_seconds) || fine_seconds < 0 || fine_seconds > 3600) {
    std::ostringstream msg;
    msg << "drape fine_seconds is " << fine_seconds << ": give 0 to 3600 seconds";
    throw InputError(msg.str());
  }
  solver.validate();
}

namespace {

using Clock = std::chrono::steady_clock;

// The drape itself: `steps` steps of the garment in one solver; progress from `done` to `done + share`.
// body_edges: whether the body keeps the garment's edges out as well as its vertices.
std::size_t step_garment(Garment& garment, const Body& body, const SolverParams& params, double dt, std::size_t steps,
                         const DrapeProgress& progress, double done, double share, bool& stopped,
                         ClothMeasures* measures, bool body_edges = true) {
  Solver solver(params);
  solver.set_body(&body);
  solver_detail::set_body_edges(solver, body_edges);
  std::size_t taken = 0;
  for (std::size_t i = 0; i < steps && !stopped; ++i) {
    solver.step(garment, dt);
    ++taken;
    if (progress && !progress(done + share * double(i + 1) / double(steps))) stopped = true;
  }
  if (measures) *measures = solver.measure(garment);
  return taken;
}

// The garment's plane where it is flat and at rest (every vertex on one plane, every edge at its rest
// length), without pins or tacks and all triangles: what a coarse copy can stand in for. Its normal,
// or zero where it is not so.
Vec3 flat_at_rest(const Garment& g) {
  const Mesh& m = g.mesh();
  if (!g.tacks.empty() || !CGAL::is_triangle_mesh(m)) return Vec3::Zero();
  for (Vertex v : m.vertices())
    if (g.pinned(v)) return Vec3::Zero();
  for (Edge e : m.edges())
    if (std::abs(g.length(e) - g.rest_length(e)) > 1e-6 * g.rest_length(e) + 1e-12) return Vec3::Zero();
  Vec3 normal = Vec3::Zero();
  for (Face f : m.faces()) {  // the largest face's normal
    std::array<Vec3, 3> p;
    int k = 0;
    for (Vertex v : CGAL::vertices_around_face(m.halfedge(f), m)) p[k++] = g.position(v);
    const Vec3 n = (p[1] - p[0]).cross(p[2] - p[0]);
    if (n.squaredNorm() > normal.squaredNorm()) normal = n;
  }
  if (normal.squaredNorm() == 0) return Vec3::Zero();
  normal.normalize();
  const Vec3 o = g.position(*m.vertices().begin());
  const double tolerance = 1e-6 * std::max(1e-3, g.bounds().sizes().norm());
  for (Vertex v : m.vertices())
    if (std::abs((g.position(v) - o).dot(normal)) > tolerance) return Vec3::Zero();
  return normal;
}

// The garment remeshed as a flat garment of the same outline with edges about `edge` long: the
// points and triangles alone, the garment's maps made afresh from them.
Garment coarse_copy(const Garment& g, double edge) {
  Mesh m;
  std::vector<Vertex> to(g.vertex_capacity());
  for (Vertex v : g.mesh().vertices()) to[v.idx()] = m.add_vertex(g.mesh().point(v));
  for (Face f : g.mesh().faces()) {
    std::array<Vertex, 3> t;
    int k = 0;
    for (Vertex v : CGAL::vertices_around_face(g.mesh().halfedge(f), g.mesh())) t[k++] = to[v.idx()];
    m.add_face(t[0], t[1], t[2]);
  }
  CGAL::Polygon_mesh_processing::isotropic_remeshing(faces(m), edge, m,
                                                     CGAL::parameters::number_of_iterations(3));
  m.collect_garbage();
  Garment copy(std::move(m), g.material());
  copy.name = g.name;
  return copy;
}

// Where each of the fine garment's vertices lies in the coarse copy's flat triangles: a triangle and
// barycentric weights (outside every triangle, the nearest, its weights extended past its sides), in
// 2D coordinates of the common plane. Empty where the copy has no triangles to lie in.
struct Embedding {
  std::vector<std::array<Vertex, 3>> corners;  // per fine vertex index
  std::vector<std::array<double, 3>> weights;
};

Embedding embed(const Garment& fine, const Garment& coarse, const Vec3& normal) {
  const Vec3 u = normal.unitOrthogonal(), w = normal.cross(u);
  auto flat = [&](const Vec3& p) { return Eigen::Vector2d(p.dot(u), p.dot(w)); };
  const Mesh& cm = coarse.mesh();
  std::vector<std::array<Vertex, 3>> tris;
  std::vector<std::array<Eigen::Vector2d, 3>> at;
  Eigen::AlignedBox2d box;
  double edge = 0;
  for (Face f : cm.faces()) {
    std::array<Vertex, 3> t;
    std::array<Eigen::Vector2d, 3> q;
    int k = 0;
    for (Vertex v : CGAL::vertices_around_face(cm.halfedge(f), cm)) {
      t[k] = v;
      q[k] = flat(coarse.position(v));
      box.extend(q[k]);
      ++k;
    }
    for (int a = 0; a < 3; ++a) edge = std::max(edge, (q[(a + 1) % 3] - q[a]).norm());
    tris.push_back(t);
    at.push_back(q);
  }
  // A grid of cells about two edges wide, each listing the triangles whose boxes meet it.
  const double cell = std::max(2 * edge, 1e-9);
  const Eigen::Vector2d lo = box.min();
  const int nx = std::max(1, int(std::ceil(box.sizes().x() / cell)) + 1);
  const int ny = std::max(1, int(std::ceil(box.sizes().y() / cell)) + 1);
  auto cell_of = [&](const Eigen::Vector2d& p, int& cx, int& cy) {
    cx = std::clamp(int((p.x() - lo.x()) / cell), 0, nx - 1);
    cy = std::clamp(int((p.y() - lo.y()) / cell), 0, ny - 1);
  };
  std::vector<std::vector<int>> cells(std::size_t(nx) * ny);
  for (std::size_t t = 0; t < tris.size(); ++t) {
    Eigen::AlignedBox2d b;
    for (const auto& q : at[t]) b.extend(q);
    int x0, y0, x1, y1;
    cell_of(b.min(), x0, y0);
    cell_of(b.max(), x1, y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) cells[std::size_t(y) * nx + x].push_back(int(t));
  }
  auto weights_in = [&](int t, const Eigen::Vector2d& p) {
    const auto& q = at[t];
    const Eigen::Vector2d e1 = q[1] - q[0], e2 = q[2] - q[0], d = p - q[0];
    const double det = e1.x() * e2.y() - e1.y() * e2.x();
    const double b1 = (d.x() * e2.y() - d.y() * e2.x()) / det, b2 = (e1.x() * d.y() - e1.y() * d.x()) / det;
    return std::array<double, 3>{1 - b1 - b2, b1, b2};
  };
  Embedding out;
  if (tris.empty()) return out;
  out.corners.resize(fine.vertex_capacity());
  out.weights.resize(fine.vertex_capacity());
  for (Vertex v : fine.mesh().vertices()) {
    const Eigen::Vector2d p = flat(fine.position(v));
    int cx, cy;
    cell_of(p, cx, cy);
    int best = -1;
    double best_min = -std::numeric_limits<double>::infinity();
    std::array<double, 3> best_w{};
    // The triangle the vertex is most inside of (its smallest weight the largest), in rings of cells
    // until one holds it: a vertex beyond the copy's outline takes the nearest.
    for (int ring = 0; ring < std::max(nx, ny) && best_min < -1e-9; ++ring) {
      for (int y = cy - ring; y <= cy + ring; ++y)
        for (int x = cx - ring; x <= cx + ring; ++x) {
          if (x < 0 || y < 0 || x >= nx || y >= ny) continue;
          if (std::max(std::abs(x - cx), std::abs(y - cy)) != ring) continue;
          for (int t : cells[std::size_t(y) * nx + x]) {
            const std::array<double, 3> b = weights_in(t, p);
            const double least = std::min({b[0], b[1], b[2]});
            if (least > best_min) best_min = least, best = t, best_w = b;
          }
        }
      if (best >= 0 && ring >= 1) break;  // the nearest is within the first two rings
    }
    out.corners[v.idx()] = tris[best];
    out.weights[v.idx()] = best_w;
  }
  return out;
}

// The coarse copy's edge length for this garment and these options, and the garment's plane's
// normal; 0 where the garment falls itself throughout.
double coarse_edge(const Garment& garment, const DrapeOptions& options, Vec3& normal) {
  normal = Vec3::Zero();
  const auto steps = std::llround(options.seconds * options.frame_rate);
  const auto fine_steps = std::min(steps, std::llround(options.fine_seconds * options.frame_rate));
  // A coarse copy only where it is worth its remeshing: some thousands of vertices to stand for.
  constexpr std::size_t kCoarseFrom = 2000;
  if (options.coarse_ratio <= 1 || fine_steps >= steps || garment.mesh().number_of_vertices() < kCoarseFrom)
    return 0;
  normal = flat_at_rest(garment);
  if (normal == Vec3::Zero()) return 0;
  // The copy's edges: coarse_ratio times the garment's, at most 4 cm. Coarser, a copy misses the
  // shape of the head and shoulders it lands on, and the garment comes out of it still moving (a 2 cm
  // cloth from a 6 cm copy kept seven times the kinetic energy it kept from a 4 cm one).
  constexpr double kCoarsestEdge = 0.04;
  double mean = 0;
  for (Edge e : garment.mesh().edges()) mean += garment.rest_length(e);
  mean /= double(std::max<std::size_t>(1, garment.mesh().number_of_edges()));
  const double edge = std::min(options.coarse_ratio * mean, kCoarsestEdge);
  return edge >= 1.5 * mean ? edge : 0;
}

DrapeOptions itself(DrapeOptions options) {
  options.coarse_ratio = 1;
  return options;
}

// A drape lets a garment fall onto the body from outside it. One that starts through the body (not
// placed over it: a new rectangle stands upright at the origin, through the legs) is held there by
// its edges and torn apart. A vertex deeper in than the cloth's thickness went through the surface
// (the solver keeps the cloth within it); a few such, snagged by a tool's pull, are let be.
void require_outside(const Garment& garment, const Body& body) {
  std::vector<Vertex> vertices(garment.mesh().vertices().begin(), garment.mesh().vertices().end());
  const Box3 box = body.bounds();
  const double depth = garment.material().thickness;
  const BodyCollider collider(body);
  std::vector<char> deep(vertices.size(), 0);
  parallel::for_range(static_cast<int>(vertices.size()), 256, [&](int b, int e) {
    for (int k = b; k < e; ++k) {
      const Vec3 p = garment.position(vertices[k]);
      deep[k] = box.contains(p) && collider.inside(p) && !collider.closest(p, depth).hit;
    }
  });
  const auto inside = static_cast<std::size_t>(std::count(deep.begin(), deep.end(), 1));
  if (inside * 1000 <= vertices.size()) return;
  const Vec3 first = garment.position(vertices[std::find(deep.begin(), deep.end(), 1) - deep.begin()]);
  std::ostringstream msg;
  msg << "drape: " << inside << " of the garment's " << vertices.size()
      << " vertices start inside the body, deeper than the cloth's thickness (the first at " << first.x() << ", "
      << first.y() << ", " << first.z()
      << " m): a drape lets a garment fall onto the body from outside it; place it over the body first "
         "(place_over_body, kiji.place_over_body)";
  throw InputError(msg.str());
}

// The drape of a garment and options already checked (drape, below).
DrapeResult drape_checked(Garment& garment, const Body& body, const DrapeOptions& options,
                          const DrapeProgress& progress) {
  const double dt = 1.0 / options.frame_rate;
  const auto steps = static_cast<std::size_t>(std::llround(options.seconds * options.frame_rate));
  auto fine_steps = std::min(steps, static_cast<std::size_t>(std::llround(options.fine_seconds * options.frame_rate)));
  DrapeResult result;
  const auto start = Clock::now();
  bool stopped = false;
  double done = 0;
  Vec3 normal;
  const double edge = coarse_edge(garment, options, normal);
  if (edge > 0) {
    Garment coarse = coarse_copy(garment, edge);
    // The copy falls kept off the body by its vertices alone, further out than its thickness:
    // testing points along its long edges was three quarters of its time. An edge of length l sags
    // l^2 / 8R below its chord over a surface of radius R, so with its ends that much further out its
    // middle stays clear of the head's sides and the upper arms (R about 5 cm). It lands for its last
    // kCopyLanding seconds at its own thickness, its edges kept out too: a copy left further out
    // wraps the head in 3 % more cloth than the garment can lie in, and the garment's settle pressed
    // that into folds (docs/benchmarks.md, "The copy kept off by its vertices").
    constexpr double kCopyRadius = 0.05, kCopyLanding = 0.25;
    const Material own_material = coarse.material();
    Material raised = own_material;
    raised.thickness += edge * edge / (8 * kCopyRadius);
    coarse.set_material(raised);
    const Embedding at = embed(garment, coarse, normal);
    if (at.corners.empty()) return drape_checked(garment, body, itself(options), progress);
    SolverParams params = options.solver;
    params.substeps = options.coarse_substeps;
    const std::size_t coarse_steps = steps - fine_steps;
    // The shares of the progress bar: each stage's vertices times its substeps and steps.
    const double coarse_work = double(coarse.mesh().number_of_vertices()) * params.substeps * coarse_steps;
    const double fine_work = double(garment.mesh().number_of_vertices()) * options.solver.substeps * fine_steps;
    done = coarse_work / (coarse_work + fine_work);
    const std::size_t landing =
        std::min(coarse_steps, static_cast<std::size_t>(std::llround(kCopyLanding * options.frame_rate)));
    const double falling = done * double(coarse_steps - landing) / double(coarse_steps);
    result.coarse_steps = step_garment(coarse, body, params, dt, coarse_steps - landing, progress, 0, falling,
                                       stopped, nullptr, false);
    if (!stopped) {
      coarse.set_material(own_material);
      result.coarse_steps +=
          step_garment(coarse, body, params, dt, landing, progress, falling, done - falling, stopped, nullptr);
    }
    result.coarse_vertices = coarse.mesh().number_of_vertices();
    for (Vertex v : garment.mesh().vertices()) {
      const auto& c = at.corners[v.idx()];
      const auto& b = at.weights[v.idx()];
      Vec3 p = Vec3::Zero(), vel = Vec3::Zero();
      for (int k = 0; k < 3; ++k) {
        p += b[k] * coarse.position(c[k]);
        vel += b[k] * coarse.velocity(c[k]);
      }
      garment.set_position(v, p);
      garment.velocity(v) = vel;
    }
    result.seconds_simulated = double(result.coarse_steps) * dt;
    result.coarse_wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
    if (stopped) fine_steps = 0;
  } else {
    fine_steps = steps;
  }
  // The garment's own stage settles what the copy's fall left: with its damping raised, as a
  // designer waits for a draped garment to come to rest.
  const Material own = garment.material();
  if (result.coarse_vertices && options.fine_damping > own.damping) {
    Material settling = own;
    settling.damping = options.fine_damping;
    garment.set_material(settling);
  }
  try {
    result.steps = step_garment(garment, body, options.solver, dt, fine_steps, progress, done, 1 - done, stopped,
                                &result.measures);
  } catch (...) {
    garment.set_material(own);
    throw;
  }
  garment.set_material(own);
  result.seconds_simulated += double(result.steps) * dt;
  result.wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return result;
}

}  // namespace

bool drapes_coarse(const Garment& garment, const DrapeOptions& options) {
  options.validate();
  Vec3 normal;
  return coarse_edge(garment, options, normal) > 0;
}

DrapeResult drape(Garment& garment, const Body& body, const DrapeOptions& options,
                  const DrapeProgress& progress) {
  options.validate();
  garment.validate();
  require_outside(garment, body);
  return drape_checked(garment, body, options, progress);
}

}  // namespace kiji
