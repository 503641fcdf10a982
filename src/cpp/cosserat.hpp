// The Cosserat-rod model's shooting integration (Rucker & Webster 2011): the C++ of the numba kernel
// src/pytdcr/statics/kernels/cosserat.py, operation for operation and in its order (see that module for the
// formulation). State y (18,): p (3), R row-major (9), total moment M (3), total force N (3), base frame.
// The 3x3 products of the re-orthonormalisation are summed in order where numba called BLAS: round-off apart.
#pragma once

#include <cmath>
#include <cstddef>
#include <vector>

namespace pytdcr {
namespace cosserat {

inline constexpr double NEWTON_TOL = 1e-13;
inline constexpr int NEWTON_MAX = 30;

// The packed rod and its loads (the numba kernel's Rod): arrays row-major, owned.
struct Rod {
  std::size_t n = 0, nt = 0;
  std::vector<double> lengths;  // (N,) subsegment lengths [m]
  double stiff[4] = {0, 0, 0, 0};  // EI, GJ [N m^2], GA, EA [N]
  double mpl = 0.0;               // backbone mass per length [kg/m]
  std::vector<double> dmass;      // (N,) disk masses [kg]
  std::vector<double> holes;      // (nt, 3) tendon holes, body frame [m]
  std::vector<long> anchor;       // (nt,) 1-based anchor disk
  std::vector<double> tension;    // (nt,) [N]
  double grav[3] = {0, 0, 0};     // gravity, base frame [m/s^2]
  std::vector<double> pforce, pmoment;  // (N, 3) point force [N] and moment [N m] per disk, base frame
  bool ext = false;               // shear and extension
  long nsub = 1;                  // RK4 steps per subsegment
};

// Solve A[:n, :n] x = b[:n] in place (b becomes x) by partial pivoting (A 6x6 row-major); false if singular.
inline bool gauss_solve(double* A, double* b, int n) {
  for (int k = 0; k < n; ++k) {
    int piv = k;
    double big = std::fabs(A[k * 6 + k]);
    for (int i = k + 1; i < n; ++i)
      if (std::fabs(A[i * 6 + k]) > big) {
        big = std::fabs(A[i * 6 + k]);
        piv = i;
      }
    if (big == 0.0 || !std::isfinite(big)) return false;
    if (piv != k) {
      for (int j = 0; j < n; ++j) {
        const double t = A[k * 6 + j];
        A[k * 6 + j] = A[piv * 6 + j];
        A[piv * 6 + j] = t;
      }
      const double t = b[k];
      b[k] = b[piv];
      b[piv] = t;
    }
    for (int i = k + 1; i < n; ++i) {
      const double f = A[i * 6 + k] / A[k * 6 + k];
      for (int j = k; j < n; ++j) A[i * 6 + j] -= f * A[k * 6 + j];
      b[i] -= f * b[k];
    }
  }
  for (int k = n - 1; k >= 0; --k) {
    double acc = b[k];
    for (int j = k + 1; j < n; ++j) acc -= A[k * 6 + j] * b[j];
    b[k] = acc / A[k * 6 + k];
  }
  return true;
}

// The body-frame balance solved for x = (u, v) in place from its current value (the numba kernel's
// constitutive): mb, nb (3,) total moment and force in the body frame; tau (nt,) tensions, active (nt,) whether
// each runs past s. True when Newton converged to a physical strain (with extension: v3 > 0).
inline bool constitutive(const double* mb, const double* nb, const Rod& rod, const double* tau, const char* active,
                         double* x) {
  const int n = rod.ext ? 6 : 3;
  const double EI = rod.stiff[0], GJ = rod.stiff[1], GA = rod.stiff[2], EA = rod.stiff[3];
  if (!rod.ext) {
    x[3] = 0.0;
    x[4] = 0.0;
    x[5] = 1.0;
  }
  double A[36], F[6];
  for (int it = 0; it < NEWTON_MAX; ++it) {
    const double u0 = x[0], u1 = x[1], u2 = x[2], v0 = x[3], v1 = x[4], v2 = x[5];
    for (int i = 0; i < 6; ++i) {
      F[i] = 0.0;
      for (int j = 0; j < 6; ++j) A[i * 6 + j] = 0.0;
    }
    F[0] = EI * u0 - mb[0];
    F[1] = EI * u1 - mb[1];
    F[2] = GJ * u2 - mb[2];
    A[0] = EI;
    A[7] = EI;
    A[14] = GJ;
    if (rod.ext) {
      F[3] = GA * v0 - nb[0];
      F[4] = GA * v1 - nb[1];
      F[5] = EA * (v2 - 1.0) - nb[2];
      A[21] = GA;
      A[28] = GA;
      A[35] = EA;
    }
    for (std::size_t c = 0; c < rod.nt; ++c) {
      const double tc = tau[c];
      if (!active[c] || tc == 0.0) continue;
      const double r0 = rod.holes[3 * c], r1 = rod.holes[3 * c + 1], r2 = rod.holes[3 * c + 2];
      const double w0 = v0 + u1 * r2 - u2 * r1;
      const double w1 = v1 + u2 * r0 - u0 * r2;
      const double w2 = v2 + u0 * r1 - u1 * r0;
      const double nw = std::sqrt(w0 * w0 + w1 * w1 + w2 * w2);
      const double t0 = w0 / nw, t1 = w1 / nw, t2 = w2 / nw;
      F[0] += tc * (r1 * t2 - r2 * t1);
      F[1] += tc * (r2 * t0 - r0 * t2);
      F[2] += tc * (r0 * t1 - r1 * t0);
      if (rod.ext) {
        F[3] += tc * t0;
        F[4] += tc * t1;
        F[5] += tc * t2;
      }
      const double c0 = r1 * t2 - r2 * t1;
      const double c1 = r2 * t0 - r0 * t2;
      const double c2 = r0 * t1 - r1 * t0;
      const double rv[3] = {r0, r1, r2}, tv[3] = {t0, t1, t2}, cv[3] = {c0, c1, c2};
      const double rr = r0 * r0 + r1 * r1 + r2 * r2;
      const double s = tc / nw;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          const double dij = i == j ? 1.0 : 0.0;
          A[i * 6 + j] -= s * (rv[i] * rv[j] - rr * dij + cv[i] * cv[j]);
        }
      if (rod.ext) {
        const double hr[3][3] = {{0.0, -r2, r1}, {r2, 0.0, -r0}, {-r1, r0, 0.0}};
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) {
            const double dij = i == j ? 1.0 : 0.0;
            A[i * 6 + 3 + j] += s * (hr[i][j] - cv[i] * tv[j]);
            A[(3 + i) * 6 + j] -= s * (hr[i][j] + tv[i] * cv[j]);
            A[(3 + i) * 6 + 3 + j] += s * (dij - tv[i] * tv[j]);
          }
      }
    }
    double big = 0.0;
    for (int i = 0; i < n; ++i) F[i] = -F[i];
    if (!gauss_solve(A, F, n)) return false;
    for (int i = 0; i < n; ++i) {
      x[i] += F[i];
      big = std::fmax(big, std::fabs(F[i]) / (1.0 + std::fabs(x[i])));
    }
    if (!std::isfinite(big)) return false;
    // an axial strain of -1 or less (v3 <= 0) crushes the rod through itself: no equilibrium of this rod law
    if (big <= NEWTON_TOL) return !(rod.ext && x[5] <= 0.0);
  }
  return false;
}

// dy (18,) of the state y at a point of a subsegment; fw (3,) is N'; x (6,) carries (u, v) from the last call.
inline bool rhs(const double* y, const Rod& rod, const double* tau, const char* active, const double* fw, double* x,
                double* dy) {
  double mb[3], nb[3];
  for (int i = 0; i < 3; ++i) {
    mb[i] = y[3 + i] * y[12] + y[6 + i] * y[13] + y[9 + i] * y[14];
    nb[i] = y[3 + i] * y[15] + y[6 + i] * y[16] + y[9 + i] * y[17];
  }
  if (!constitutive(mb, nb, rod, tau, active, x)) return false;
  const double u0 = x[0], u1 = x[1], u2 = x[2], v0 = x[3], v1 = x[4], v2 = x[5];
  for (int i = 0; i < 3; ++i) dy[i] = y[3 + 3 * i] * v0 + y[4 + 3 * i] * v1 + y[5 + 3 * i] * v2;
  for (int i = 0; i < 3; ++i) {
    const double a = y[3 + 3 * i], b = y[4 + 3 * i], c = y[5 + 3 * i];
    dy[3 + 3 * i] = b * u2 - c * u1;
    dy[4 + 3 * i] = -a * u2 + c * u0;
    dy[5 + 3 * i] = a * u1 - b * u0;
  }
  const double n0 = y[15], n1 = y[16], n2 = y[17];
  dy[12] = -(dy[1] * n2 - dy[2] * n1);
  dy[13] = -(dy[2] * n0 - dy[0] * n2);
  dy[14] = -(dy[0] * n1 - dy[1] * n0);
  dy[15] = fw[0];
  dy[16] = fw[1];
  dy[17] = fw[2];
  return true;
}

// R = y[3:12] pulled back onto SO(3): one Newton-Schulz step R <- R (3 I - R^T R) / 2.
inline void reorthonormalize(double* y) {
  const double* R = y + 3;
  double S[9], Rn[9];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double s = 0.0;
      for (int k = 0; k < 3; ++k) s += R[k * 3 + i] * R[k * 3 + j];
      S[i * 3 + j] = (i == j ? 3.0 : 0.0) - s;
    }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double s = 0.0;
      for (int k = 0; k < 3; ++k) s += R[i * 3 + k] * S[k * 3 + j];
      Rn[i * 3 + j] = s;
    }
  for (int i = 0; i < 9; ++i) y[3 + i] = 0.5 * Rn[i];
}

// Integrate from the base with M(0) = m0 (3,) [N m] and every load scaled by lam. With record, fills pos
// (N+1, 3), rot (N+1, 3, 3) at the disks and curve (N nsub + 1, 3). res (6,): M just past the tip [N m] (the
// shooting residual), then the tip position [m]. False (res NaN) where the integration could not be carried out.
inline bool shoot(const double* m0, double lam, const Rod& rod, bool record, double* pos, double* rot, double* curve,
                  double* res) {
  const std::size_t n = rod.n, nt = rod.nt;
  double y[18] = {0};
  y[3] = 1.0;
  y[7] = 1.0;
  y[11] = 1.0;
  double total_len = 0.0;
  for (std::size_t i = 0; i < n; ++i) total_len += rod.lengths[i];
  for (int k = 0; k < 3; ++k) {
    double acc = rod.mpl * total_len * rod.grav[k];
    for (std::size_t i = 0; i < n; ++i) acc += rod.pforce[3 * i + k] + rod.dmass[i] * rod.grav[k];
    y[12 + k] = m0[k];
    y[15 + k] = lam * acc;
  }
  std::vector<double> tau(nt);
  for (std::size_t c = 0; c < nt; ++c) tau[c] = lam * rod.tension[c];
  std::vector<char> active(nt);
  double x[6] = {0, 0, 0, 0, 0, 1.0};
  double K[4][18], yt[18], fw[3];
  for (int k = 0; k < 3; ++k) fw[k] = -lam * rod.mpl * rod.grav[k];
  if (record) {
    for (int k = 0; k < 3; ++k) pos[k] = 0.0, curve[k] = 0.0;
    for (int a = 0; a < 9; ++a) rot[a] = (a % 4 == 0) ? 1.0 : 0.0;
  }
  std::size_t ic = 1;
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t c = 0; c < nt; ++c) active[c] = rod.anchor[c] >= static_cast<long>(i) + 1;
    const double h = rod.lengths[i] / static_cast<double>(rod.nsub);
    for (long step = 0; step < rod.nsub; ++step) {
      for (int st = 0; st < 4; ++st) {  // classical Runge-Kutta stages
        if (!rhs(st == 0 ? y : yt, rod, tau.data(), active.data(), fw, x, K[st])) {
          for (int k = 0; k < 6; ++k) res[k] = NAN;
          return false;
        }
        if (st < 3) {
          const double c = st == 2 ? h : 0.5 * h;
          for (int k = 0; k < 18; ++k) yt[k] = y[k] + c * K[st][k];
        }
      }
      for (int k = 0; k < 18; ++k) y[k] += h / 6.0 * (K[0][k] + 2.0 * K[1][k] + 2.0 * K[2][k] + K[3][k]);
      reorthonormalize(y);
      if (record) {
        for (int k = 0; k < 3; ++k) curve[3 * ic + k] = y[k];
        ++ic;
      }
    }
    // disk i+1: its weight and point wrench act here (jump of N and M)
    for (int k = 0; k < 3; ++k) {
      y[15 + k] -= lam * (rod.pforce[3 * i + k] + rod.dmass[i] * rod.grav[k]);
      y[12 + k] -= lam * rod.pmoment[3 * i + k];
    }
    if (record) {
      for (int k = 0; k < 3; ++k) pos[3 * (i + 1) + k] = y[k];
      for (int a = 0; a < 9; ++a) rot[9 * (i + 1) + a] = y[3 + a];
    }
  }
  for (int k = 0; k < 3; ++k) {
    res[k] = y[12 + k];
    res[3 + k] = y[k];
  }
  return std::isfinite(res[0]) && std::isfinite(res[1]) && std::isfinite(res[2]);
}

}  // namespace cosserat
}  // namespace pytdcr
