// Kinematics of piecewise-constant-curvature subsegments (MODEL.md, paper Eqs. 1-4, 27-28): the C++ twin of
// src/pytdcr/kinematics.py, operation for operation, so that both round alike.
//
// Frame naming: R and d of subsegment i give frame i in frame i-1 (x_{i-1} = R x_i + d). Everything is written
// through (beta, gamma) and functions of theta^2, so it is smooth and exact at zero curvature.
#pragma once

#include <cmath>
#include <complex>
#include <cstddef>

namespace pytdcr {

inline constexpr double kSeriesT2 = 1e-2;  // series for theta^2 below this

inline double real_part(double x) { return x; }
inline double real_part(const std::complex<double>& x) { return x.real(); }

// A = sin(th)/th, B = (1 - cos th)/th^2, C = (1 - A)/th^2 as functions of th^2 (real or complex).
template <class T>
inline void abc(const T& t2, T& a, T& b, T& c) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  if (real_part(t2) < kSeriesT2) {
    a = 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0)));
    b = 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0 * (1.0 - t2 / 56.0 * (1.0 - t2 / 90.0)));
    c = 1.0 / 6.0 - t2 / 120.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0 * (1.0 - t2 / 110.0)));
  } else {
    const T th = sqrt(t2);
    a = sin(th) / th;
    b = (1.0 - cos(th)) / t2;
    c = (1.0 - a) / t2;
  }
}

// Transform of one subsegment (frame i in frame i-1) and its backbone centroid: R (3x3, row-major), d (3),
// pg (3) [m], from the bending (beta, gamma) [1/m], the twist eps [rad] and the length l [m].
template <class T>
inline void subsegment(const T& beta, const T& gamma, const T& eps, double l, T* R, T* d, T* pg) {
  using std::cos;
  using std::sin;
  const T wx = -gamma * l;
  const T wy = beta * l;
  const T t2 = wx * wx + wy * wy;
  T a, b, c;
  abc(t2, a, b, c);
  // E = I + A K + B K^2, K = [w]x with w = (wx, wy, 0)
  const T e00 = 1.0 - b * wy * wy;
  const T e01 = b * wx * wy;
  const T e02 = a * wy;
  const T e10 = b * wx * wy;
  const T e11 = 1.0 - b * wx * wx;
  const T e12 = -a * wx;
  const T e20 = -a * wy;
  const T e21 = a * wx;
  const T e22 = 1.0 - b * t2;
  const T ce = cos(eps);
  const T se = sin(eps);
  R[0] = e00 * ce + e01 * se;
  R[1] = -e00 * se + e01 * ce;
  R[2] = e02;
  R[3] = e10 * ce + e11 * se;
  R[4] = -e10 * se + e11 * ce;
  R[5] = e12;
  R[6] = e20 * ce + e21 * se;
  R[7] = -e20 * se + e21 * ce;
  R[8] = e22;
  const double ll = l * l;
  d[0] = ll * b * beta;
  d[1] = ll * b * gamma;
  d[2] = l * a;
  pg[0] = ll * c * beta;
  pg[1] = ll * c * gamma;
  pg[2] = l * b;
}

// Disk frames in the base frame: pos (N+1, 3) [m] and rot (N+1, 3, 3), row-major, from q (3N) and the
// subsegment lengths, read as sub[5 i] (the packed model's (N, 5) rows).
inline void frames(const double* q, const double* sub, std::size_t n, double* pos, double* rot) {
  double R[9], d[3], pg[3];
  for (int u = 0; u < 3; ++u) pos[u] = 0.0;
  for (int u = 0; u < 9; ++u) rot[u] = (u % 4 == 0) ? 1.0 : 0.0;
  for (std::size_t i = 1; i <= n; ++i) {
    const std::size_t k = 3 * (i - 1);
    subsegment(q[k], q[k + 1], q[k + 2], sub[5 * (i - 1)], R, d, pg);
    const double* P = rot + 9 * (i - 1);
    double* Q = rot + 9 * i;
    for (int u = 0; u < 3; ++u) {
      pos[3 * i + u] = pos[3 * (i - 1) + u] + P[3 * u] * d[0] + P[3 * u + 1] * d[1] + P[3 * u + 2] * d[2];
      for (int v = 0; v < 3; ++v) Q[3 * u + v] = P[3 * u] * R[v] + P[3 * u + 1] * R[3 + v] + P[3 * u + 2] * R[6 + v];
    }
  }
}

}  // namespace pytdcr
