// The exact Jacobians of many equilibria (for the static stability test), their residuals (to check that a batch
// to continue holds equilibria) and the unknowns' derivative by the tensions (for the tip gradients): the C++
// twin of src/pytdcr/statics/kernels/stiffness.py, for any packed model with the solver's interface (evaluate,
// make_work, with_tension, tip_jacobian_of; see pcc.hpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "linalg.hpp"

namespace pytdcr {

// For k in [start, stop): the residual's exact Jacobian (m, m) at the equilibrium q[rows[k]] (B, m) of model at
// the actuator tensions tensions[rows[k]] (B, nt) [N], at full load, into out[k - start] (stop - start, m, m).
template <class Model>
void jacobian_range(const double* q, std::size_t m, const Model& model, const double* tensions,
                    const long* rows, std::size_t start, std::size_t stop, double* out) {
  auto work = make_work(model);
  Model at = model;
  std::vector<double> r(m);
  const std::size_t nt = model.n_tendons;
  for (std::size_t k = start; k < stop; ++k) {
    const std::size_t b = static_cast<std::size_t>(rows[k]);
    with_tension(model, tensions + b * nt, at);
    evaluate(q + b * m, 1.0, at, true, r.data(), out + (k - start) * m * m, work);
  }
}

// For each k of count: max |residual| [N m] at q[rows[k]] (B, m) of model at the actuator tensions
// tensions[rows[k]] (B, nt) [N], at full load, into out[k] (NaN where a residual is NaN).
template <class Model>
void largest_residuals(const double* q, std::size_t m, const Model& model, const double* tensions,
                       const long* rows, std::size_t count, double* out) {
  auto work = make_work(model);
  Model at = model;
  std::vector<double> r(m);
  const std::size_t nt = model.n_tendons;
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t b = static_cast<std::size_t>(rows[k]);
    with_tension(model, tensions + b * nt, at);
    evaluate(q + b * m, 1.0, at, false, r.data(), nullptr, work);
    double big = 0.0;
    for (std::size_t u = 0; u < m; ++u) {
      const double a = std::fabs(r[u]);
      if (a != a) {  // NaN: not an equilibrium, whatever else
        big = a;
        break;
      }
      big = std::max(big, a);
    }
    out[k] = big;
  }
}

// Scratch of tip_gradient_range for m unknowns and nt tendons.
struct GradientWork {
  std::vector<double> r0, r1, J, dr, lu, col, tip, tension;
  std::vector<std::size_t> piv;
  GradientWork(std::size_t m, std::size_t nt)
      : r0(m), r1(m), J(m * m), dr(m * nt), lu(m * m), col(m), tip(3 * m), tension(nt), piv(m) {}
};

// J^-1 dr/dT into g.dr (m, nt) at the equilibrium q (m,) of model at the actuator tensions tension (nt,) [N]:
// minus the unknowns' derivative by the tensions (implicit function theorem, dq/dT = -J^-1 dr/dT), with
// dr/dT_c = r(q, T + e_c) - r(q, T) exactly (the residual is affine in the actuator tensions at fixed q).
// work then holds the evaluation with the Jacobian at (q, tension). False where J is singular or not finite.
template <class Model, class Work>
bool unknowns_by_tensions(const double* q, const Model& model, const double* tension, Model& at, Work& work,
                          GradientWork& g) {
  const std::size_t m = model.n_unknowns();
  const std::size_t nt = model.n_tendons;
  with_tension(model, tension, at);
  evaluate(q, 1.0, at, true, g.r0.data(), g.J.data(), work);
  for (std::size_t c = 0; c < nt; ++c) {
    for (std::size_t j = 0; j < nt; ++j) g.tension[j] = tension[j];
    g.tension[c] += 1.0;
    with_tension(model, g.tension.data(), at);
    evaluate(q, 1.0, at, false, g.r1.data(), nullptr, work);
    for (std::size_t u = 0; u < m; ++u) g.dr[u * nt + c] = g.r1[u] - g.r0[u];
  }
  if (!all_finite(g.J.data(), m * m) || !all_finite(g.dr.data(), m * nt)) return false;
  double sign;
  if (!lu_factor(g.J.data(), m, g.lu.data(), g.piv.data(), sign)) return false;
  for (std::size_t c = 0; c < nt; ++c) {
    for (std::size_t u = 0; u < m; ++u) g.col[u] = g.dr[u * nt + c];
    lu_solve(g.lu.data(), g.piv.data(), m, g.col.data());
    for (std::size_t u = 0; u < m; ++u) g.dr[u * nt + c] = g.col[u];
  }
  return true;
}

// Rows start <= b < stop: the tip's exact derivative by the tensions (3, nt) [m/N] at the equilibrium q[b] (B, m)
// of model at the actuator tensions tensions[b] (B, nt) [N], into out[b] (B, 3, nt): the tip's derivative by the
// unknowns (tip_jacobian_of) times dq/dT (unknowns_by_tensions). Rows whose q[b] is not finite, or whose
// Jacobian is singular, are left as they are.
template <class Model>
void tip_gradient_range(const double* q, const Model& model, const double* tensions, std::size_t start,
                        std::size_t stop, double* out) {
  const std::size_t m = model.n_unknowns();
  const std::size_t nt = model.n_tendons;
  auto work = make_work(model);
  Model at = model;
  GradientWork g(m, nt);
  for (std::size_t b = start; b < stop; ++b) {
    const double* qb = q + b * m;
    if (!all_finite(qb, m)) continue;
    if (!unknowns_by_tensions(qb, model, tensions + b * nt, at, work, g)) continue;
    tip_jacobian_of(qb, at, work, g.tip.data());
    for (std::size_t u = 0; u < 3; ++u)
      for (std::size_t c = 0; c < nt; ++c) {
        double acc = 0.0;
        for (std::size_t j = 0; j < m; ++j) acc += g.tip[u * m + j] * g.dr[j * nt + c];
        out[(b * 3 + u) * nt + c] = -acc;
      }
  }
}

}  // namespace pytdcr
