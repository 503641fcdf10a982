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

// The complex step's arithmetic, as numba's (numba/cpython/numbers.py complex_div_impl; cmathimpl.py sqrt_impl,
// sin_impl, cos_impl, cosh_impl, sinh_impl), inline, so that it rounds as the numba kernels' does by construction
// (libstdc++ would call libgcc's __divdc3, which takes another branch for a subnormal ratio, and libm's csqrt,
// csin, ccos, which only happen to agree). The real overloads are the plain operations.
using cplx = std::complex<double>;

inline double k_div(double a, double b) { return a / b; }
inline double k_sqrt(double x) { return std::sqrt(x); }
inline double k_sin(double x) { return std::sin(x); }
inline double k_cos(double x) { return std::cos(x); }

// a / b, Smith's algorithm (CPython's _Py_c_quot, numba's complex division); b = 0 gives NaNs (numba raises)
inline cplx k_div(const cplx& a, const cplx& b) {
  const double ar = a.real(), ai = a.imag(), br = b.real(), bi = b.imag();
  const double abr = std::fabs(br), abi = std::fabs(bi);
  if (abr >= abi) {
    if (abr == 0.0) return cplx(std::nan(""), std::nan(""));
    const double ratio = bi / br;
    const double denom = br + bi * ratio;
    return cplx((ar + ai * ratio) / denom, (ai - ar * ratio) / denom);
  }
  if (abi >= abr) {
    const double ratio = br / bi;
    const double denom = br * ratio + bi;
    return cplx((ar * ratio + ai) / denom, (ai * ratio - ar) / denom);
  }
  return cplx(std::nan(""), std::nan(""));  // b.real or b.imag is NaN
}

// cosh(y), sinh(y) of the complex step's imaginary parts: for |y| < 2^-28 they round to 1 and y (cosh y - 1 and
// sinh y - y are below y^2 < 2^-56, under half an ulp; glibc returns these too), which spares two libm calls
inline double k_cosh(double y) { return std::fabs(y) < 0x1p-28 ? 1.0 : std::cosh(y); }
inline double k_sinh(double y) { return std::fabs(y) < 0x1p-28 ? y : std::sinh(y); }

// sinh(x + iy) and cosh(x + iy) as numba's cmath (its special cases for infinite x included)
inline cplx k_csinh(double x, double y) {
  if (std::isinf(x)) {
    if (std::isnan(y)) return cplx(x, y);
    double re = std::cos(y), im = std::sin(y);
    if (re != 0.0) re *= x;
    if (im != 0.0) im *= std::fabs(x);
    return cplx(re, im);
  }
  return cplx(std::cos(y) * k_sinh(x), std::sin(y) * k_cosh(x));
}
inline cplx k_ccosh(double x, double y) {
  if (std::isinf(x)) {
    double re, im;
    if (std::isnan(y) || y == 0.0) {
      re = std::fabs(x);
      im = y;
    } else {
      re = std::copysign(x, std::cos(y));
      im = std::copysign(x, std::sin(y));
    }
    if (x < 0.0) im = -im;
    return cplx(re, im);
  }
  return cplx(std::cos(y) * k_cosh(x), std::sin(y) * k_sinh(x));
}
// sin z = -i sinh(iz), cos z = cosh(iz)
inline cplx k_sin(const cplx& z) {
  const cplx r = k_csinh(-z.imag(), z.real());
  return cplx(r.imag(), -r.real());
}
inline cplx k_cos(const cplx& z) { return k_ccosh(-z.imag(), z.real()); }

// sqrt z (NumPy's npy_csqrt, Algorithm 312 of CACM vol 10, as numba's)
inline cplx k_sqrt(const cplx& z) {
  constexpr double kThres = 1.7976931348623157e308 / (1.0 + 1.414213562373095048801688724209698079);
  double a = z.real(), b = z.imag();
  if (a == 0.0 && b == 0.0) return cplx(std::fabs(b), b);
  if (std::isinf(b)) return cplx(std::fabs(b), b);
  if (std::isnan(a)) return cplx(a, a);
  if (std::isinf(a)) {
    if (a < 0.0) return cplx(std::fabs(b - b), std::copysign(a, b));
    return cplx(a, std::copysign(b - b, b));
  }
  bool scale = false;
  if (std::fabs(a) >= kThres || std::fabs(b) >= kThres) {
    a *= 0.25;
    b *= 0.25;
    scale = true;
  }
  double re, im;
  if (a >= 0) {
    const double t = std::sqrt((a + std::hypot(a, b)) * 0.5);
    re = t;
    im = b / (2 * t);
  } else {
    const double t = std::sqrt((-a + std::hypot(a, b)) * 0.5);
    re = std::fabs(b) / (2 * t);
    im = std::copysign(t, b);
  }
  return scale ? cplx(re * 2, im) : cplx(re, im);
}

// A = sin(th)/th, B = (1 - cos th)/th^2, C = (1 - A)/th^2 as functions of th^2 (real or complex).
template <class T>
inline void abc(const T& t2, T& a, T& b, T& c) {
  if (real_part(t2) < kSeriesT2) {
    a = 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0)));
    b = 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0 * (1.0 - t2 / 56.0 * (1.0 - t2 / 90.0)));
    c = 1.0 / 6.0 - t2 / 120.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0 * (1.0 - t2 / 110.0)));
  } else {
    const T th = k_sqrt(t2);
    a = k_div(k_sin(th), th);
    b = k_div(1.0 - k_cos(th), t2);
    c = k_div(1.0 - a, t2);
  }
}

// Transform of one subsegment (frame i in frame i-1) and its backbone centroid: R (3x3, row-major), d (3),
// pg (3) [m], from the bending (beta, gamma) [1/m], the twist eps [rad] and the length l [m].
template <class T>
inline void subsegment(const T& beta, const T& gamma, const T& eps, double l, T* R, T* d, T* pg) {
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
  const T ce = k_cos(eps);
  const T se = k_sin(eps);
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

// A, B, C (as abc) and the derivatives by theta^2 of A = sin(th)/th and B = (1 - cos th)/th^2 (series near 0; no
// cancellation): da = (C - B)/2, db = (A - 2B)/(2 th^2).
inline void abc_slopes(double t2, double& a, double& b, double& c, double& da, double& db) {
  abc(t2, a, b, c);
  da = 0.5 * (c - b);
  if (t2 < kSeriesT2)
    db = -1.0 / 24.0 +
         t2 * (2.0 / 720.0 - t2 * (3.0 / 40320.0 - t2 * (4.0 / 3628800.0 - t2 * 5.0 / 479001600.0)));
  else
    db = (a - 2.0 * b) / (2.0 * t2);
}

// C = A B for 3x3 row-major matrices, each entry summed left to right (A[u,0] B[0,v] + A[u,1] B[1,v]) + ...
inline void matmul3(const double* A, const double* B, double* C) {
  for (int u = 0; u < 3; ++u)
    for (int v = 0; v < 3; ++v) C[3 * u + v] = A[3 * u] * B[v] + A[3 * u + 1] * B[3 + v] + A[3 * u + 2] * B[6 + v];
}

// Derivatives of one subsegment's transform by (beta [1/m], gamma [1/m], eps [rad]), in closed form: dR (3, 3, 3),
// dR[a] = dR/dq_a, and dd (3, 3), dd[a] = dd/dq_a [m per unit of q], row-major. With R = E(w) Rz(eps),
// E = I + A K + B K^2, K = [w]x, w = l (-gamma, beta, 0) and A, B functions of t2 = |w|^2; exact and smooth at
// zero curvature. (The Python twin multiplies its 3x3 matrices with BLAS, whose order of summation and fused
// multiply-adds are its own: this agrees with it to round-off, not bit for bit.)
inline void subsegment_derivatives(double beta, double gamma, double eps, double l, double* dR, double* dd) {
  const double wx = -gamma * l;
  const double wy = beta * l;
  const double t2 = wx * wx + wy * wy;
  double a, b, c, da, db;
  abc_slopes(t2, a, b, c, da, db);
  const double K[9] = {0.0, 0.0, wy, 0.0, 0.0, -wx, -wy, wx, 0.0};
  double K2[9];
  matmul3(K, K, K2);
  double E[9];
  for (int u = 0; u < 9; ++u) E[u] = ((u % 4 == 0) ? 1.0 : 0.0) + a * K[u] + b * K2[u];
  const double ce = std::cos(eps);
  const double se = std::sin(eps);
  const double Rz[9] = {ce, -se, 0.0, se, ce, 0.0, 0.0, 0.0, 1.0};
  const double dRz[9] = {-se, -ce, 0.0, ce, -se, 0.0, 0.0, 0.0, 0.0};
  const double ll = l * l;
  for (int j = 0; j < 2; ++j) {  // j = 0: by w_x, j = 1: by w_y
    const double wj = j == 0 ? wx : wy;
    double Kj[9] = {};
    if (j == 0) {
      Kj[5] = -1.0;
      Kj[7] = 1.0;
    } else {
      Kj[2] = 1.0;
      Kj[6] = -1.0;
    }
    double KjK[9], KKj[9], dE[9], dEz[9];
    matmul3(Kj, K, KjK);
    matmul3(K, Kj, KKj);
    const double s1 = 2.0 * wj * da;
    const double s2 = 2.0 * wj * db;
    for (int u = 0; u < 9; ++u) dE[u] = s1 * K[u] + a * Kj[u] + s2 * K2[u] + b * (KjK[u] + KKj[u]);
    matmul3(dE, Rz, dEz);
    // beta moves w_y by l; gamma moves w_x by -l
    const int lane = j == 1 ? 0 : 1;
    const double sgn = j == 1 ? l : -l;
    for (int u = 0; u < 9; ++u) dR[9 * lane + u] = sgn * dEz[u];
  }
  matmul3(E, dRz, dR + 18);
  // d = (l^2 B beta, l^2 B gamma, l A), t2 = l^2 (beta^2 + gamma^2)
  const double dt_db = 2.0 * ll * beta;
  const double dt_dg = 2.0 * ll * gamma;
  dd[0] = ll * (b + beta * db * dt_db);
  dd[1] = ll * gamma * db * dt_db;
  dd[2] = l * da * dt_db;
  dd[3] = ll * beta * db * dt_dg;
  dd[4] = ll * (b + gamma * db * dt_dg);
  dd[5] = l * da * dt_dg;
  dd[6] = 0.0;
  dd[7] = 0.0;
  dd[8] = 0.0;
}

// Exact derivative of the tip position by the unknowns q (3N,): out (3, 3N) row-major [m per unit of q].
// Moving subsegment i moves everything beyond it rigidly: d tip / d q_(i,a) = R_(0,i-1) (dd_i/dq_a + dR_i/dq_a x_i),
// x_i the tip in frame i. sub: the packed (N, 5) rows (lengths in the first column); pos (N+1, 3) and
// rot (N+1, 3, 3): scratch for the disk frames (frames).
inline void tip_jacobian(const double* q, const double* sub, std::size_t n, double* pos, double* rot, double* out) {
  frames(q, sub, n, pos, rot);
  const std::size_t m = 3 * n;
  double dR[27], dd[9], x[3], v[3];
  const double* tip = pos + 3 * n;
  for (std::size_t i = 1; i <= n; ++i) {
    const std::size_t k = 3 * (i - 1);
    subsegment_derivatives(q[k], q[k + 1], q[k + 2], sub[5 * (i - 1)], dR, dd);
    const double* Ri = rot + 9 * i;
    const double* pi = pos + 3 * i;
    for (int u = 0; u < 3; ++u) {
      x[u] = 0.0;
      for (int w = 0; w < 3; ++w) x[u] += Ri[3 * w + u] * (tip[w] - pi[w]);
    }
    const double* P = rot + 9 * (i - 1);
    for (int a = 0; a < 3; ++a) {
      for (int u = 0; u < 3; ++u)
        v[u] = dd[3 * a + u] + dR[9 * a + 3 * u] * x[0] + dR[9 * a + 3 * u + 1] * x[1] + dR[9 * a + 3 * u + 2] * x[2];
      for (int u = 0; u < 3; ++u) out[u * m + k + a] = P[3 * u] * v[0] + P[3 * u + 1] * v[1] + P[3 * u + 2] * v[2];
    }
  }
}

}  // namespace pytdcr
