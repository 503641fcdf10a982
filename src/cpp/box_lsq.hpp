// The workspace's boundary-search step inside the tension bounds (src/pytdcr/workspace/_frontier.py,
// tension_step): a damped least-squares problem with box constraints in a few unknowns, solved by a primal
// active-set method. The C++ of the numba kernel it replaces (its operations in its order; its dense solve is
// linalg.hpp's LU where numba called LAPACK, and A^T A is summed in order: round-off apart).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "linalg.hpp"

namespace pytdcr {
namespace box_lsq {

// active-set iterations at most, per unknown (each adds or drops one bound; the method ends far sooner)
inline constexpr std::size_t ITER_PER_UNKNOWN = 8;

// Scratch of one call for k unknowns.
struct Work {
  std::vector<double> Q, c, z, g, Qf, rhs, sol, lu;
  std::vector<std::size_t> idx, piv;
  std::vector<char> fixed;
  explicit Work(std::size_t k)
      : Q(k * k), c(k), z(k), g(k), Qf(k * k), rhs(k), sol(k), lu(k * k), idx(k), piv(k), fixed(k, 0) {}
};

// out (k,): the minimiser of 1/2 x'Qx + c'x over the unknowns not fixed (the fixed ones held at x). False where
// the free block is singular or not finite (numba's np.linalg.solve raised there).
inline bool free_solve(std::size_t k, const double* x, Work& w, double* out) {
  std::size_t nf = 0;
  for (std::size_t i = 0; i < k; ++i) {
    out[i] = x[i];
    if (!w.fixed[i]) w.idx[nf++] = i;
  }
  if (nf == 0) return true;
  for (std::size_t a = 0; a < nf; ++a) {
    double s = -w.c[w.idx[a]];
    for (std::size_t j = 0; j < k; ++j)
      if (w.fixed[j]) s -= w.Q[w.idx[a] * k + j] * x[j];
    w.rhs[a] = s;
    for (std::size_t b = 0; b < nf; ++b) w.Qf[a * nf + b] = w.Q[w.idx[a] * k + w.idx[b]];
  }
  if (!solve(w.Qf.data(), w.rhs.data(), nf, w.sol.data(), w.lu.data(), w.piv.data())) return false;
  for (std::size_t a = 0; a < nf; ++a) out[w.idx[a]] = w.sol[a];
  return true;
}

// x (k,) minimising |A x - y|^2 + damp^2 |x|^2 with lower <= x <= upper (lower <= 0 <= upper, so that x = 0 is
// feasible); A (m, k) row-major, damp > 0 (strictly convex: one minimiser). The primal active-set method from
// x = 0: solve on the unknowns not held at a bound, step as far towards that solution as the bounds allow
// (holding the bound that stops it), and where the step is complete release the held bound whose multiplier has
// the wrong sign, until none has (an unknown with lower == upper stays held at it). False where a free block
// could not be solved (x then the last iterate).
inline bool solve_box(const double* A, std::size_t m, std::size_t k, const double* y, double damp,
                      const double* lower, const double* upper, double* x) {
  Work w(k);
  for (std::size_t i = 0; i < k; ++i) {
    for (std::size_t j = 0; j < k; ++j) {
      double s = 0.0;
      for (std::size_t r = 0; r < m; ++r) s += A[r * k + i] * A[r * k + j];
      w.Q[i * k + j] = s;
    }
    double s = 0.0;
    for (std::size_t r = 0; r < m; ++r) s += A[r * k + i] * y[r];
    w.c[i] = -s;
  }
  for (std::size_t i = 0; i < k; ++i) w.Q[i * k + i] += damp * damp;
  double scale = 0.0;
  for (std::size_t i = 0; i < k; ++i) {
    x[i] = 0.0;
    scale = std::max(scale, upper[i] - lower[i]);
  }
  const double eps = 1e-14 * std::max(scale, 1e-300);
  for (std::size_t it = 0; it < ITER_PER_UNKNOWN * k + 8; ++it) {
    if (!free_solve(k, x, w, w.z.data())) return false;
    double alpha = 1.0;
    long block = -1;
    for (std::size_t i = 0; i < k; ++i) {
      if (w.fixed[i]) continue;
      const double p = w.z[i] - x[i];
      if (p > 0.0 && x[i] + p > upper[i]) {
        const double a = (upper[i] - x[i]) / p;
        if (a < alpha) alpha = a, block = static_cast<long>(i);
      } else if (p < 0.0 && x[i] + p < lower[i]) {
        const double a = (lower[i] - x[i]) / p;
        if (a < alpha) alpha = a, block = static_cast<long>(i);
      }
    }
    if (block >= 0) {
      const std::size_t bl = static_cast<std::size_t>(block);
      for (std::size_t i = 0; i < k; ++i)
        if (!w.fixed[i]) x[i] += alpha * (w.z[i] - x[i]);
      x[bl] = w.z[bl] > x[bl] ? upper[bl] : lower[bl];
      w.fixed[bl] = 1;
      continue;
    }
    for (std::size_t i = 0; i < k; ++i) x[i] = w.z[i];
    for (std::size_t i = 0; i < k; ++i) {
      double s = 0.0;
      for (std::size_t j = 0; j < k; ++j) s += w.Q[i * k + j] * x[j];
      w.g[i] = s + w.c[i];
    }
    long worst = -1;
    double worst_val = 0.0;
    for (std::size_t i = 0; i < k; ++i) {
      // an unknown pinned by lower == upper stays held whatever its multiplier (releasing it would cycle)
      if (!w.fixed[i] || !(upper[i] > lower[i])) continue;
      // the multiplier of a held bound: the gradient must push into it
      const double mult = std::fabs(x[i] - lower[i]) <= eps ? w.g[i] : -w.g[i];
      if (mult < worst_val) worst = static_cast<long>(i), worst_val = mult;
    }
    if (worst < 0) return true;
    w.fixed[static_cast<std::size_t>(worst)] = 0;
  }
  return true;
}

}  // namespace box_lsq
}  // namespace pytdcr
