// Dense linear algebra of the compiled solver: LU factorisation with partial pivoting (Doolittle, row-major),
// and from it the solution of A x = b (also by the factors of A^T, which the solver uses: cheap where A is block
// lower Hessenberg) and the sign and log of the determinant. The C++ stand-in for the LAPACK calls behind numba's
// np.linalg.solve (gesv) and np.linalg.slogdet (getrf), standard library only (the solver keeps no explicit
// inverse: loading_path.hpp's InverseJacobian).
//
// Like numba's np.linalg, a matrix (or right-hand side) with an infinite or NaN entry is refused, and so is an
// exactly singular one (a pivot that is exactly zero: LAPACK's info > 0); a nearly singular matrix is factored and
// its solutions may then hold huge or infinite entries, as LAPACK's do. The pivot of column k is the first entry
// of largest magnitude on or below the diagonal (LAPACK's idamax). Results agree with LAPACK's to round-off, not
// bit for bit (LAPACK blocks its elimination and scales by the pivot's reciprocal).
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>

namespace pytdcr {

// True when every one of the n entries of a is finite.
inline bool all_finite(const double* a, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(a[i])) return false;
  return true;
}

// LU factorisation P A = L U of the (n, n) row-major matrix a, into lu (n, n) (L below the diagonal, its unit
// diagonal implied; U on and above) with the row interchanges piv (n): row k was swapped with row piv[k] at step
// k. sign (+1 or -1) is that of the permutation. Returns false where a pivot is exactly zero (a singular matrix;
// lu then holds the partial factorisation). a may be lu itself (factor in place). Does not check finiteness.
inline bool lu_factor(const double* a, std::size_t n, double* lu, std::size_t* piv, double& sign) {
  if (a != lu)
    for (std::size_t i = 0; i < n * n; ++i) lu[i] = a[i];
  sign = 1.0;
  for (std::size_t k = 0; k < n; ++k) {
    // pivot: the first entry of largest magnitude in column k, rows k..n-1
    std::size_t p = k;
    double big = std::fabs(lu[k * n + k]);
    for (std::size_t i = k + 1; i < n; ++i) {
      const double v = std::fabs(lu[i * n + k]);
      if (v > big) {
        big = v;
        p = i;
      }
    }
    piv[k] = p;
    if (big == 0.0) return false;
    if (p != k) {
      sign = -sign;
      for (std::size_t j = 0; j < n; ++j) {
        const double t = lu[k * n + j];
        lu[k * n + j] = lu[p * n + j];
        lu[p * n + j] = t;
      }
    }
    const double pivot = lu[k * n + k];
    for (std::size_t i = k + 1; i < n; ++i) {
      double* row = lu + i * n;
      const double l = row[k] / pivot;  // multiplier L[i, k]
      row[k] = l;
      if (l == 0.0) continue;
      const double* prow = lu + k * n;
      for (std::size_t j = k + 1; j < n; ++j) row[j] -= l * prow[j];
    }
  }
  return true;
}

// Solve A x = b in place (b becomes x, length n) from lu_factor's lu and piv: forward substitution with L (unit
// diagonal) after the row interchanges, then back substitution with U.
inline void lu_solve(const double* lu, const std::size_t* piv, std::size_t n, double* b) {
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t p = piv[k];
    if (p != k) {
      const double t = b[k];
      b[k] = b[p];
      b[p] = t;
    }
  }
  for (std::size_t i = 1; i < n; ++i) {
    const double* row = lu + i * n;
    double acc = b[i];
    for (std::size_t j = 0; j < i; ++j) acc -= row[j] * b[j];
    b[i] = acc;
  }
  for (std::size_t i = n; i-- > 0;) {
    const double* row = lu + i * n;
    double acc = b[i];
    for (std::size_t j = i + 1; j < n; ++j) acc -= row[j] * b[j];
    b[i] = acc / row[i];
  }
}

// Solve A^T x = b in place (b becomes x, length n) from lu_factor's lu and piv of A: from P A = L U,
// A^T = U^T L^T P, so forward substitution with U^T, back substitution with L^T (unit diagonal), then the row
// interchanges undone, last first.
inline void lu_solve_transposed(const double* lu, const std::size_t* piv, std::size_t n, double* b) {
  for (std::size_t i = 0; i < n; ++i) {  // U^T v = b: column i of U is row i of U^T
    double acc = b[i];
    for (std::size_t j = 0; j < i; ++j) acc -= lu[j * n + i] * b[j];
    b[i] = acc / lu[i * n + i];
  }
  for (std::size_t i = n; i-- > 0;) {  // L^T w = v
    double acc = b[i];
    for (std::size_t j = i + 1; j < n; ++j) acc -= lu[j * n + i] * b[j];
    b[i] = acc;
  }
  for (std::size_t k = n; k-- > 0;) {
    const std::size_t p = piv[k];
    if (p != k) {
      const double t = b[k];
      b[k] = b[p];
      b[p] = t;
    }
  }
}

// lu (n, n) = the transpose of the (n, n) row-major a (lu must not be a).
inline void transpose_into(const double* a, std::size_t n, double* lu) {
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j) lu[j * n + i] = a[i * n + j];
}

// x (n) = A^-1 b for the (n, n) row-major A by the LU factors of A^T (lu_solve_transposed): false (x untouched)
// where A or b has a non-finite entry or A is exactly singular. Where A is block lower Hessenberg (the subsegment
// rod's Jacobian: zero above its first superdiagonal block), A^T is block upper Hessenberg, and its elimination
// touches only the rows of the diagonal and next block in each column (lu_factor skips a zero multiplier): O(b n^2)
// for blocks of b in place of n^3 / 3. Scratch: lu (n, n), piv (n). x may be b.
inline bool solve_by_transpose(const double* a, const double* b, std::size_t n, double* x, double* lu,
                               std::size_t* piv) {
  if (!all_finite(a, n * n) || !all_finite(b, n)) return false;
  transpose_into(a, n, lu);
  double sign;
  if (!lu_factor(lu, n, lu, piv, sign)) return false;
  if (x != b)
    for (std::size_t i = 0; i < n; ++i) x[i] = b[i];
  lu_solve_transposed(lu, piv, n, x);
  return true;
}

// x (n) = A^-1 b for the (n, n) row-major A, as np.linalg.solve: false (x untouched) where A or b has a
// non-finite entry or A is exactly singular. Scratch: lu (n, n), piv (n). x may be b.
inline bool solve(const double* a, const double* b, std::size_t n, double* x, double* lu, std::size_t* piv) {
  if (!all_finite(a, n * n) || !all_finite(b, n)) return false;
  double sign;
  if (!lu_factor(a, n, lu, piv, sign)) return false;
  if (x != b)
    for (std::size_t i = 0; i < n; ++i) x[i] = b[i];
  lu_solve(lu, piv, n, x);
  return true;
}

// The sign (+1, -1; 0 where singular) and the log of the magnitude (-inf where singular) of det A, A (n, n)
// row-major, as np.linalg.slogdet (which numba refuses for a non-finite A: the caller checks). Scratch: lu (n, n),
// piv (n).
inline void slogdet(const double* a, std::size_t n, double* lu, std::size_t* piv, double& sign, double& logdet) {
  if (!lu_factor(a, n, lu, piv, sign)) {
    sign = 0.0;
    logdet = -std::numeric_limits<double>::infinity();
    return;
  }
  logdet = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double d = lu[i * n + i];
    if (d < 0.0) sign = -sign;
    logdet += std::log(std::fabs(d));
  }
}

}  // namespace pytdcr
