// The paper's model (Miyahara, Okada, Niijima 2006, eqs. 1-3), exactly:
//   m_i x_i'' = -gamma x_i' + sum_j g_ij + f_i,   m_i = 1,
//   g_ij = k (1 - l_ij / l'_ij) d_ij,
// with l_ij the rest length, l'_ij the current length and d_ij the unit vector from i to j;
// f_i is gravity (on the unit mass) plus the tools' forces. Integrated with symplectic Euler over
// the substeps. With the local region, only vertices within the radius of the centre are computed
// (their springs to outside vertices included); the others are not touched at all.
// Body collision (the paper's section 5 collides the cloth with the character) uses the same
// continuous projection as the default model.
#include "sim/solver_state.h"

#include <cmath>

namespace kiji::solver_detail {

void step_mass_spring(SolverArrays& s, const SolverParams& p, const Material& m,
                      const BodyCollider* body, double dt) {
  const int substeps = p.substeps;
  const double h = dt / substeps;
  const std::size_t n = s.n;
  const double k = p.spring_k, gamma = p.spring_damping;
  const Vec3 g = p.gravity;
  s.force.resize(n);

  for (std::size_t i = 0; i < n; ++i)
    s.pred[i] = s.moving[i] ? Vec3(s.v[i] * dt + (g + s.fext[i]) * (dt * dt)) : Vec3::Zero();
  const bool collide = body && !s.body_tris.empty();
  std::vector<int> moving;
  std::vector<Vec3> before;  // where the moving vertices were before the body's push
  if (collide)
    for (std::size_t i = 0; i < n; ++i)
      if (s.moving[i]) moving.push_back(static_cast<int>(i));

  const int ne = static_cast<int>(s.e_i.size());
  Vec3* X = s.x.data();
  Vec3* F = s.force.data();
  for (int sub = 0; sub < substeps; ++sub) {
    for (std::size_t i = 0; i < n; ++i)
      if (s.moving[i]) F[i].setZero();
    for (int e = 0; e < ne; ++e) {
      const int i = s.e_i[e], j = s.e_j[e];
      if (!s.moving[i] && !s.moving[j]) continue;
      const Vec3 dij = X[j] - X[i];
      const double lc = dij.norm();
      if (!(lc > 0)) continue;
      const Vec3 gij = (k * (1.0 - s.e_rest[e] / lc) / lc) * dij;
      F[i] += gij;
      F[j] -= gij;
    }
    for (const auto& a : s.attach)  // a hand's spring is one more force of eq. 2
      if (s.moving[a.i]) F[a.i] += a.k * (a.target - X[a.i]);
    for (const auto& t : s.tacks) {
      const Vec3 f = k * (X[t[1]] - X[t[0]]);
      F[t[0]] += f;
      F[t[1]] -= f;
    }
    for (std::size_t i = 0; i < n; ++i) {
      if (!s.moving[i]) continue;
      s.xp[i] = X[i];
      s.v[i] += h * (F[i] - gamma * s.v[i] + s.fext[i] + g);  // unit mass
      X[i] += h * s.v[i];
    }
    if (collide) {
      before.clear();
      for (int i : moving) before.push_back(X[i]);
      resolve_body(s, *body, moving, m.thickness, m.friction, p.floor);
      for (std::size_t q = 0; q < moving.size(); ++q)
        if (X[moving[q]] != before[q]) s.v[moving[q]] = (X[moving[q]] - s.xp[moving[q]]) / h;
    }
  }
}

}  // namespace kiji::solver_detail
