// Prints ms per step (1/60 s, default substeps) of both solver models on a hanging square cloth
// at several sizes, without and with the default body, and a drape of a 1 m x 1 m cloth on the
// default body. Figures only: nothing here is an assertion.
//   solver_bench                 the table
//   solver_bench drape [n [print_every [self_collision [substeps]]]]
//   solver_bench hash [n [steps]]   a landing's end state, hashed (compare KIJI_THREADS settings)
//   solver_bench prepare [n [reps]] building a fresh solver's arrays for a cloth landed on the body 1 s
//   solver_bench edit [n [reps]]    a slit cut in that cloth, reps times, each at another place: the
//                                   rebuild the next step makes (StepReport::ms.rebuild)
#include "kiji/body.h"
#include "kiji/pattern.h"
#include "kiji/solver.h"
#include "kiji/topology.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdint>
#include <cstring>

using namespace kiji;
using Clock = std::chrono::steady_clock;

namespace {
// A square cloth of n x n vertices, 1 m wide, laid horizontally 5 cm above the body (its head).
Garment cloth(int n, const Box3& body) {
  Garment g = make_rectangle(1.0, 1.0, n, n);
  const Vec3 c = body.center();
  const double top = body.isEmpty() ? 1.6 : body.max().y();
  for (Vertex v : g.mesh().vertices()) {
    const Vec3 q = g.position(v);
    g.set_position(v, Vec3(c.x() + q.x() - 0.5, top + 0.05, c.z() - (q.y() - 0.5)));
  }
  return g;
}

// That cloth after a second falling onto the body, stepped by `solver`.
Garment landed_cloth(int n, const Body& body, Solver& solver) {
  Garment g = cloth(n, body.bounds());
  solver.set_body(&body);
  for (int i = 0; i < 60; ++i) solver.step(g, 1.0 / 60);
  return g;
}

double ms_per_step(SolverModel model, int n, const Body* body, int warm, int steps, bool self = true) {
  Box3 box;
  if (body) box = body->bounds();
  Garment g = cloth(n, box);
  SolverParams p;
  p.model = model;
  if (model == SolverModel::MassSpring) p.spring_damping = 1.0, p.spring_k = 2000;
  p.self_collision = self;
  Solver solver(p);
  solver.set_body(body);
  for (int i = 0; i < warm; ++i) solver.step(g, 1.0 / 60);
  const auto t0 = Clock::now();
  for (int i = 0; i < steps; ++i) solver.step(g, 1.0 / 60);
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count() / steps;
}
}  // namespace

int main(int argc, char** argv) {
  const Body body = Body::load(Body::default_path());
  if (argc > 1 && std::strcmp(argv[1], "drape") == 0) {
    const int n = argc > 2 ? std::atoi(argv[2]) : 101;
    const Box3 b = body.bounds();
    // Over the head and shoulders: a 1 m square, 5 cm above the top of the head.
    Garment g = cloth(n, b);
    SolverParams p;
    if (argc > 4) p.self_collision = std::atoi(argv[4]) != 0;
    if (argc > 5) p.substeps = std::atoi(argv[5]);
    Solver solver(p);
    solver.set_body(&body);
    const auto t0 = Clock::now();
    for (int s = 1; s <= 180; ++s) {
      solver.step(g, 1.0 / 60);
      if (s % (argc > 3 ? std::atoi(argv[3]) : 30) == 0) {
        const ClothMeasures m = solver.measure(g);
        double vmax = 0;
        for (Vertex v : g.mesh().vertices()) vmax = std::max(vmax, g.velocity(v).norm());
        std::printf("t=%.2f s  KE %.3g J  max pen %.2f mm  max strain %.3f  mean strain %.4f  contacts %zu / %zu  "
                    "asleep %zu  fastest %.2f m/s  %.1f ms\n",
                    s / 60.0, m.kinetic_energy, 1e3 * m.max_penetration, m.max_strain, m.mean_strain,
                    m.contacts, m.vertices, m.sleeping, vmax, solver.last_step().ms.total);
        std::fflush(stdout);
      }
    }
    std::printf("%.1f ms per step\n",
                std::chrono::duration<double, std::milli>(Clock::now() - t0).count() / 180);
    return 0;
  }
  if (argc > 1 && std::strcmp(argv[1], "prepare") == 0) {  // solver_bench prepare [n [reps]]
    const int n = argc > 2 ? std::atoi(argv[2]) : 141, reps = argc > 3 ? std::atoi(argv[3]) : 5;
    Solver landing{SolverParams{}};
    const Garment g = landed_cloth(n, body, landing);
    for (int r = 0; r < reps; ++r) {
      Solver solver{SolverParams{}};
      solver.set_body(&body);
      const auto t0 = Clock::now();
      solver.prepare(g);
      std::printf("%d vertices: prepare %.2f ms\n", n * n, std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    }
    return 0;
  }
  if (argc > 1 && std::strcmp(argv[1], "edit") == 0) {  // solver_bench edit [n [reps]]
    const int n = argc > 2 ? std::atoi(argv[2]) : 141, reps = argc > 3 ? std::atoi(argv[3]) : 8;
    Solver solver{SolverParams{}};
    Garment g = landed_cloth(n, body, solver);
    for (int r = 0; r < reps; ++r) {
      // A slit of a tenth of the cloth across a row, each further along the cloth's diagonal.
      const int row = n / 5 + (r * 3 * n / 5) / std::max(1, reps), col = n / 5 + (r * n / 2) / std::max(1, reps);
      cut_along(g, edge_path(g, Vertex(row * n + col), Vertex(row * n + col + n / 10)));
      solver.step(g, 1.0 / 60);
      std::printf("%zu vertices: rebuild %.2f ms (step %.1f ms)\n", g.mesh().number_of_vertices(),
                  solver.last_step().ms.rebuild, solver.last_step().ms.total);
    }
    return 0;
  }
  if (argc > 1 && std::strcmp(argv[1], "hash") == 0) {  // solver_bench hash [n [steps]]
    // The cloth's positions after landing on the body and itself, hashed: the same for any
    // KIJI_THREADS (the solver's result does not depend on the thread count).
    const int n = argc > 2 ? std::atoi(argv[2]) : 141, steps = argc > 3 ? std::atoi(argv[3]) : 40;
    Garment g = cloth(n, body.bounds());
    Solver solver{SolverParams{}};
    solver.set_body(&body);
    std::size_t pairs = 0;
    for (int i = 0; i < steps; ++i) {
      solver.step(g, 1.0 / 60);
      pairs += solver.last_step().self_pairs;
    }
    std::uint64_t h = 1469598103934665603ull;  // FNV-1a over the positions' bytes
    for (Vertex v : g.mesh().vertices()) {
      const Vec3 x = g.position(v);
      const auto* b = reinterpret_cast<const unsigned char*>(x.data());
      for (std::size_t k = 0; k < sizeof(double) * 3; ++k) h = (h ^ b[k]) * 1099511628211ull;
    }
    std::printf("%d vertices, %d steps, %zu self-collision pairs: positions hash %016llx\n", n * n, steps, pairs,
                static_cast<unsigned long long>(h));
    return 0;
  }
  if (argc > 2 && std::strcmp(argv[1], "cell") == 0) {  // solver_bench cell N xpbd|mass_spring body self
    const int n = std::atoi(argv[2]);
    const SolverModel model = parse_solver_model(argv[3]);
    const bool on_body = std::atoi(argv[4]) != 0, self = std::atoi(argv[5]) != 0;
    std::printf("%d vertices, %s, body %d, self %d: %.2f ms per step\n", n * n, argv[3], on_body, self,
                ms_per_step(model, n, on_body ? &body : nullptr, 30, n > 100 ? 20 : 60, self));
    return 0;
  }
  std::printf("%8s  %14s  %14s  %14s  %14s\n", "vertices", "xpbd free", "xpbd on body", "mass_spring", "mass_spr body");
  for (int n : {23, 71, 141}) {
    const int steps = n > 100 ? 20 : 60;
    std::fflush(stdout);
    std::printf("%8d  %14.2f  %14.2f  %14.2f  %14.2f\n", n * n,
                ms_per_step(SolverModel::Xpbd, n, nullptr, 10, steps),
                ms_per_step(SolverModel::Xpbd, n, &body, 30, steps),
                ms_per_step(SolverModel::MassSpring, n, nullptr, 10, steps),
                ms_per_step(SolverModel::MassSpring, n, &body, 30, steps));
    std::fflush(stdout);
  }
}
