// The PCC kineto-static model's residual and its exact Jacobian (MODEL.md): the C++ twin of
// src/pytdcr/statics/kernels/pcc.py, operation for operation and in the same order, so that both round alike.
//
// Layout of the packed model (PccModel; built from pytdcr.statics.pcc.PCCEquations.build's Packed), row-major:
//   sub     (N, 5)   per subsegment i: l_i [m], EI [N m^2], GJ [N m^2], disk mass [kg], backbone piece mass [kg]
//   holes   (nt, 2)  tendon hole (x, y) in its disk's frame [m]
//   anchor  (nt,)    1-based anchor disk of each tendon
//   fric    (4,)     law code (0 none, 1 constant, 2 exponential), mu0, decay [1/rad], mode (+1 pull, -1 release)
//   tension (nt,)    actuator tensions [N]
//   grav    (3,)     gravity in the base frame [m/s^2]
//   pforce, pmoment (N, 3)  point wrench on disk i in the base frame [N, N m]
// Unknowns q (3N,) = (beta_i [1/m], gamma_i [1/m], eps_i [rad]) for i = 1..N; the residual rows of subsegment i
// are written in frame i-1 [N m].
//
// The Jacobian is exact: the local derivatives of one subsegment's transform come from the complex step (no
// truncation or cancellation error), those of one tendon's load at one disk from a hand-derived tangent
// (forward-mode) kernel; they are chained across disks analytically (tensions forward, wrenches backward,
// base-fixed loads through the angular velocities of the frames): O(N^2) per Jacobian.
#pragma once

#include <cmath>
#include <complex>
#include <cstddef>
#include <limits>
#include <vector>

#include "kinematics.hpp"

namespace pytdcr {

//: the paper's balance, about each subsegment's base (MODEL.md; first order in the disk spacing)
inline constexpr int BALANCE_BASE = 0;
//: about the subsegment's midpoint, in the midpoint's cross-section frame (MODEL.md, appendix A; second order)
inline constexpr int BALANCE_MIDPOINT = 1;
//: complex-step size of the subsegment derivatives
inline constexpr double kComplexStep = 1e-30;

// The packed model, owning copies of its arrays (row-major; layouts in the header comment).
struct PccModel {
  std::size_t n_disks = 0, n_tendons = 0;
  std::vector<double> sub;      // (N, 5)
  std::vector<double> holes;    // (nt, 2) [m]
  std::vector<long> anchor;     // (nt,) 1-based
  std::vector<double> fric;     // (4,)
  std::vector<double> tension;  // (nt,) [N]
  std::vector<double> grav;     // (3,) [m/s^2]
  std::vector<double> pforce, pmoment;  // (N, 3) [N], [N m]
  int balance = 0;              // BALANCE_BASE or BALANCE_MIDPOINT
  std::size_t n_unknowns() const { return 3 * n_disks; }
};

// Scratch of evaluate (N disks, nt tendons, m = 3N unknowns), as pcc.Work: O(N nt + N m) numbers, row-major.
struct PccWork {
  std::size_t n_disks = 0, n_tendons = 0;
  std::vector<double> R;      // (N+2, 3, 3) subsegment rotations R[i] (index 1..N; N+1 = padding)
  std::vector<double> d;      // (N+2, 3) subsegment translations [m]
  std::vector<double> pg;     // (N+2, 3) backbone piece centroids [m]
  std::vector<double> dR;     // (N+2, 3, 3, 3) dR[i, a]: derivative by q[3(i-1) + a]
  std::vector<double> dd;     // (N+2, 3, 3)
  std::vector<double> dpg;    // (N+2, 3, 3)
  std::vector<double> G;      // (N+1, 3, 3) G[i] = R_{0,i}^T
  std::vector<double> omega;  // (3, m) body angular velocity of one frame per unknown (swept base to tip and back)
  std::vector<double> T;      // (N+2, nt) tension in piece i of each tendon [N]
  std::vector<double> dTl;    // (m,) one tendon's tension in one piece, by every unknown
  std::vector<double> lnP;    // (nt, N+1, 3) log-derivative sums of tension_lanes, lanes of subsegment s < i
  std::vector<double> lnQ;    // (nt, N+1, 3) the same for s = i (disk s-1's ratio only)
  std::vector<double> W;      // (N+1, nt, 7) unit load (force, moment) and tension ratio at disk i
  std::vector<double> dW;     // (N+1, nt, 7, 6) its local derivative
  std::vector<double> dF;     // (3, m)
  std::vector<double> dM;     // (3, m)
  std::vector<double> dL;     // (6, m)
  std::vector<double> pos;    // (N+1, 3) disk positions of tip_jacobian_of [m]
  std::vector<double> rot;    // (N+1, 3, 3) disk rotations of tip_jacobian_of
};

inline PccWork make_work(std::size_t n, std::size_t nt) {
  const std::size_t m = 3 * n;
  PccWork w;
  w.n_disks = n;
  w.n_tendons = nt;
  w.R.assign((n + 2) * 9, 0.0);
  w.d.assign((n + 2) * 3, 0.0);
  w.pg.assign((n + 2) * 3, 0.0);
  w.dR.assign((n + 2) * 27, 0.0);
  w.dd.assign((n + 2) * 9, 0.0);
  w.dpg.assign((n + 2) * 9, 0.0);
  w.G.assign((n + 1) * 9, 0.0);
  w.omega.assign(3 * m, 0.0);
  w.T.assign((n + 2) * nt, 0.0);
  w.dTl.assign(m, 0.0);
  w.lnP.assign((n + 1) * nt * 3, 0.0);
  w.lnQ.assign((n + 1) * nt * 3, 0.0);
  w.W.assign((n + 1) * nt * 7, 0.0);
  w.dW.assign((n + 1) * nt * 42, 0.0);
  w.dF.assign(3 * m, 0.0);
  w.dM.assign(3 * m, 0.0);
  w.dL.assign(6 * m, 0.0);
  w.pos.assign((n + 1) * 3, 0.0);
  w.rot.assign((n + 1) * 9, 0.0);
  return w;
}

// The scratch of evaluate for this model's size.
inline PccWork make_work(const PccModel& model) { return make_work(model.n_disks, model.n_tendons); }

// Load of one tendon of unit tension on disk i, in frame i-1, and its derivatives.
//
// R (3x3), d (3): transform of subsegment i; hn (3): the hole at disk i+1 in frame i (unused at the anchor);
// (px, py): the tendon's hole in its disk's frame [m]. Writes out[0:3] the force, out[3:6] the moment about the
// origin of frame i-1 and out[6] the tension ratio T_{i+1}/T_i across the disk (0 at the anchor); the
// deflection angle of the paper's friction law is atan2(|u_prev x u_next|, -u_prev . u_next).
//
// Lane a (of nl, 0 for the load alone) moves the subsegment transform by dR[a] (3x3), dd[a] (3) and the next
// hole by dh[a] (3). Writes dout[6 u + a] (7 rows of 6 lanes). At the non-smooth points of the friction law (a
// straight tendon: zero deflection, zero normal force) the derivative of the norm is taken as 0.
inline void tendon_unit_load_jvp(const double* R, const double* d, const double* hn, const double (*dR)[9],
                                 const double (*dd)[3], const double (*dh)[3], int nl, double px, double py,
                                 bool is_anchor, const double* fric, double* out, double* dout) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double bx = R[0] * px + R[1] * py + d[0];
  const double by = R[3] * px + R[4] * py + d[1];
  const double bz = R[6] * px + R[7] * py + d[2];
  const double v1x = px - bx;
  const double v1y = py - by;
  const double v1z = -bz;
  double n1 = std::sqrt(v1x * v1x + v1y * v1y + v1z * v1z);
  if (!(n1 > 0.0)) n1 = nan;  // two holes at one point (a subsegment folded onto itself): no tendon direction
  const double u1x = v1x / n1;
  const double u1y = v1y / n1;
  const double u1z = v1z / n1;
  const int law = static_cast<int>(fric[0]);
  const bool fr = !is_anchor && law != 0 && fric[1] != 0.0;
  // primal
  double n2 = 0.0, u2x = 0.0, u2y = 0.0, u2z = 0.0;
  const double zx = R[2];
  const double zy = R[5];
  const double zz = R[8];
  double cs = 0.0, sn = 0.0, crx = 0.0, cry = 0.0, crz = 0.0;
  double mu = 0.0;
  double yx = 0.0, yy = 0.0, yz = 0.0, zy_ = 0.0, nx = 0.0, ny = 0.0, nz = 0.0, hm = 0.0;
  double rho = 0.0;
  bool clipped = false;
  double xx = 0.0, xy = 0.0, xz = 0.0, zx_ = 0.0, tx = 0.0, ty = 0.0, tz = 0.0, tn = 0.0, w = 0.0;
  double fx, fy, fz;
  if (is_anchor) {
    fx = u1x;
    fy = u1y;
    fz = u1z;
  } else {
    const double ex = R[0] * hn[0] + R[1] * hn[1] + R[2] * hn[2] + d[0];
    const double ey = R[3] * hn[0] + R[4] * hn[1] + R[5] * hn[2] + d[1];
    const double ez = R[6] * hn[0] + R[7] * hn[1] + R[8] * hn[2] + d[2];
    const double v2x = ex - bx;
    const double v2y = ey - by;
    const double v2z = ez - bz;
    n2 = std::sqrt(v2x * v2x + v2y * v2y + v2z * v2z);
    if (!(n2 > 0.0)) n2 = nan;
    u2x = v2x / n2;
    u2y = v2y / n2;
    u2z = v2z / n2;
    yx = u1x + u2x;
    yy = u1y + u2y;
    yz = u1z + u2z;
    zy_ = zx * yx + zy * yy + zz * yz;
    if (!fr) {
      rho = 1.0;
      fx = yx - zx * zy_;
      fy = yy - zy * zy_;
      fz = yz - zz * zy_;
    } else {
      if (law == 1) {
        mu = fric[1];
      } else {
        cs = -(u1x * u2x + u1y * u2y + u1z * u2z);
        crx = u1y * u2z - u1z * u2y;
        cry = u1z * u2x - u1x * u2z;
        crz = u1x * u2y - u1y * u2x;
        sn = std::sqrt(crx * crx + cry * cry + crz * crz);
        mu = fric[1] * std::exp(-fric[2] * std::atan2(sn, cs));  // mu0 exp(-decay sigma)
      }
      nx = yx - zx * zy_;
      ny = yy - zy * zy_;
      nz = yz - zz * zy_;
      hm = std::sqrt(nx * nx + ny * ny + nz * nz);
      rho = 1.0 - fric[3] * mu * hm;
      if (rho < 0.0) {
        rho = 0.0;
        clipped = true;
      }
      xx = u1x + rho * u2x;
      xy = u1y + rho * u2y;
      xz = u1z + rho * u2z;
      zx_ = zx * xx + zy * xy + zz * xz;
      tx = u1x - u2x;
      ty = u1y - u2y;
      tz = u1z - u2z;
      tn = std::sqrt(tx * tx + ty * ty + tz * tz);
      if (!(tn * tn > 0.0)) tn = nan;  // the tendon turned back on itself: no normal direction
      w = (1.0 - rho) / tn;
      fx = xx - zx * zx_ + w * tx;
      fy = xy - zy * zx_ + w * ty;
      fz = xz - zz * zx_ + w * tz;
    }
  }
  out[0] = fx;
  out[1] = fy;
  out[2] = fz;
  out[3] = by * fz - bz * fy;
  out[4] = bz * fx - bx * fz;
  out[5] = bx * fy - by * fx;
  out[6] = rho;
  // tangents
  for (int a = 0; a < nl; ++a) {
    const double* A = dR[a];
    const double dbx = A[0] * px + A[1] * py + dd[a][0];
    const double dby = A[3] * px + A[4] * py + dd[a][1];
    const double dbz = A[6] * px + A[7] * py + dd[a][2];
    const double p1 = (u1x * dbx + u1y * dby + u1z * dbz);
    const double du1x = (-dbx + u1x * p1) / n1;
    const double du1y = (-dby + u1y * p1) / n1;
    const double du1z = (-dbz + u1z * p1) / n1;
    double drho = 0.0;
    double dfx, dfy, dfz;
    if (is_anchor) {
      dfx = du1x;
      dfy = du1y;
      dfz = du1z;
    } else {
      double dex = A[0] * hn[0] + A[1] * hn[1] + A[2] * hn[2] + dd[a][0];
      double dey = A[3] * hn[0] + A[4] * hn[1] + A[5] * hn[2] + dd[a][1];
      double dez = A[6] * hn[0] + A[7] * hn[1] + A[8] * hn[2] + dd[a][2];
      dex += R[0] * dh[a][0] + R[1] * dh[a][1] + R[2] * dh[a][2];
      dey += R[3] * dh[a][0] + R[4] * dh[a][1] + R[5] * dh[a][2];
      dez += R[6] * dh[a][0] + R[7] * dh[a][1] + R[8] * dh[a][2];
      const double dvx = dex - dbx;
      const double dvy = dey - dby;
      const double dvz = dez - dbz;
      const double p2 = u2x * dvx + u2y * dvy + u2z * dvz;
      const double du2x = (dvx - u2x * p2) / n2;
      const double du2y = (dvy - u2y * p2) / n2;
      const double du2z = (dvz - u2z * p2) / n2;
      const double dzx = A[2];
      const double dzy = A[5];
      const double dzz = A[8];
      const double dyx = du1x + du2x;
      const double dyy = du1y + du2y;
      const double dyz = du1z + du2z;
      const double dzy_ = dzx * yx + dzy * yy + dzz * yz + zx * dyx + zy * dyy + zz * dyz;
      if (!fr) {
        dfx = dyx - dzx * zy_ - zx * dzy_;
        dfy = dyy - dzy * zy_ - zy * dzy_;
        dfz = dyz - dzz * zy_ - zz * dzy_;
      } else {
        double dmu = 0.0;
        if (law == 2) {
          const double dcs = -(du1x * u2x + du1y * u2y + du1z * u2z + u1x * du2x + u1y * du2y + u1z * du2z);
          const double dcrx = du1y * u2z - du1z * u2y + u1y * du2z - u1z * du2y;
          const double dcry = du1z * u2x - du1x * u2z + u1z * du2x - u1x * du2z;
          const double dcrz = du1x * u2y - du1y * u2x + u1x * du2y - u1y * du2x;
          const double dsn = sn > 0.0 ? (crx * dcrx + cry * dcry + crz * dcrz) / sn : 0.0;
          const double dsig = (cs * dsn - sn * dcs) / (cs * cs + sn * sn);
          dmu = -fric[2] * mu * dsig;
        }
        const double dnx = dyx - dzx * zy_ - zx * dzy_;
        const double dny = dyy - dzy * zy_ - zy * dzy_;
        const double dnz = dyz - dzz * zy_ - zz * dzy_;
        const double dhm = hm > 0.0 ? (nx * dnx + ny * dny + nz * dnz) / hm : 0.0;
        drho = clipped ? 0.0 : -fric[3] * (dmu * hm + mu * dhm);
        const double dxx = du1x + drho * u2x + rho * du2x;
        const double dxy = du1y + drho * u2y + rho * du2y;
        const double dxz = du1z + drho * u2z + rho * du2z;
        const double dzx_ = dzx * xx + dzy * xy + dzz * xz + zx * dxx + zy * dxy + zz * dxz;
        const double dtx = du1x - du2x;
        const double dty = du1y - du2y;
        const double dtz = du1z - du2z;
        const double dtn = (tx * dtx + ty * dty + tz * dtz) / tn;
        const double dw = (-drho * tn - (1.0 - rho) * dtn) / (tn * tn);
        dfx = dxx - dzx * zx_ - zx * dzx_ + dw * tx + w * dtx;
        dfy = dxy - dzy * zx_ - zy * dzx_ + dw * ty + w * dty;
        dfz = dxz - dzz * zx_ - zz * dzx_ + dw * tz + w * dtz;
      }
    }
    dout[0 * 6 + a] = dfx;
    dout[1 * 6 + a] = dfy;
    dout[2 * 6 + a] = dfz;
    dout[3 * 6 + a] = dby * fz - dbz * fy + by * dfz - bz * dfy;
    dout[4 * 6 + a] = dbz * fx - dbx * fz + bz * dfx - bx * dfz;
    dout[5 * 6 + a] = dbx * fy - dby * fx + bx * dfy - by * dfx;
    dout[6 * 6 + a] = drho;
  }
}

// The log-derivatives of the tension ratios by the lanes of subsegment s, for every disk s = 1..N and tendon c,
// into lnP and lnQ (nt, N+1, 3): T_i = T_1 prod_{k<i} rho_k, and rho_k depends on the lanes of subsegments k and
// k+1 only (dW[k, c, 6]), so lane (s, a) of d T_i / d q collects at most two terms,
//     (d rho_{s-1} / d q_(s,a)) / rho_{s-1}  (disk s-1's ratio through its next subsegment's lanes, s >= 2)
//   + (d rho_s / d q_(s,a)) / rho_s          (disk s's ratio through its own lanes, only for s < i),
// each only where its ratio is > 0 (a ratio clipped to zero has no derivative and leaves no tension beyond it).
// lnQ holds the first term (what s = i gets) and lnP both; each summed from 0.0 in that order, as the numba
// kernel's _tension_lanes does for every i (which repeats these divisions O(N) times; here they are done once).
inline void tension_log_derivatives(const double* dW, const double* W, std::size_t n, std::size_t nt, double* lnP,
                                    double* lnQ) {
  for (std::size_t s = 1; s <= n; ++s) {
    for (std::size_t c = 0; c < nt; ++c) {
      const double rho_prev = s >= 2 ? W[((s - 1) * nt + c) * 7 + 6] : 0.0;
      const double rho_own = W[(s * nt + c) * 7 + 6];
      for (std::size_t a = 0; a < 3; ++a) {
        double acc = 0.0;
        if (s >= 2 && rho_prev > 0.0) acc += dW[(((s - 1) * nt + c) * 7 + 6) * 6 + 3 + a] / rho_prev;
        lnQ[(c * (n + 1) + s) * 3 + a] = acc;
        if (rho_own > 0.0) acc += dW[((s * nt + c) * 7 + 6) * 6 + a] / rho_own;
        lnP[(c * (n + 1) + s) * 3 + a] = acc;
      }
    }
  }
}

// d T_{i,c} / d q for the lanes of subsegments 1..i, into out (3i,): T_i times the sum of the log-derivatives of
// the tension ratios upstream (tension_log_derivatives). The caller skips T_i = 0.
inline void tension_lanes(const double* lnP, const double* lnQ, std::size_t n, std::size_t c, std::size_t i,
                          double Ti, double* out) {
  const double* P = lnP + (c * (n + 1) + 1) * 3;  // lanes of subsegments 1..i-1
  for (std::size_t j = 0; j + 3 < 3 * i; ++j) out[j] = Ti * P[j];
  const double* Q = lnQ + (c * (n + 1) + i) * 3;  // subsegment i's lanes
  for (std::size_t a = 0; a < 3; ++a) out[3 * (i - 1) + a] = Ti * Q[a];
}

// Residual rows k..k+2 of one subsegment, balanced about its midpoint (MODEL.md, appendix A), and (if want_jac)
// their Jacobian rows in J (m, m).
//
// The distal wrench (nF [N], nM [N m]: frame i-1, about the subsegment's base) is moved to the midpoint of the
// arc, p_m = d(beta, gamma; l/2), and written in the midpoint's cross-section frame
// R_m = Exp((l/2)[-gamma, beta, 0]) Rz(eps/2) (half the bend, half the twist), where the bending moment is
// EI Rz(-eps/2) [-gamma, beta, 0] and the torsion GJ eps/l:
//
//     r = EI Rz(-eps/2) [-gamma, beta, 0] + [0, 0, GJ eps / l] - R_m^T (nM - p_m x nF)
//
// dF, dM (3, m) hold the derivatives of nF and nM by every unknown; the local derivatives of R_m and p_m come
// from the complex step, like the subsegment's own.
inline void midpoint_rows(const double* q, std::size_t k, double ell, double EI, double GJ, double nFx, double nFy,
                          double nFz, double nMx, double nMy, double nMz, const double* dF, const double* dM,
                          std::size_t m, bool want_jac, double* r, double* J) {
  using cd = std::complex<double>;
  const double beta = q[k];
  const double gamma = q[k + 1];
  const double eps = q[k + 2];
  double Rm[9], pm[3], pg[3];
  subsegment(beta, gamma, 0.5 * eps, 0.5 * ell, Rm, pm, pg);
  // mu = nM - pm x nF, about the midpoint, frame i-1
  const double mux = nMx - (pm[1] * nFz - pm[2] * nFy);
  const double muy = nMy - (pm[2] * nFx - pm[0] * nFz);
  const double muz = nMz - (pm[0] * nFy - pm[1] * nFx);
  const double c = std::cos(0.5 * eps);
  const double s = std::sin(0.5 * eps);
  const double b0 = EI * (-c * gamma + s * beta);
  const double b1 = EI * (s * gamma + c * beta);
  const double tz = GJ * eps / ell;
  r[k] = b0 - (Rm[0] * mux + Rm[3] * muy + Rm[6] * muz);
  r[k + 1] = b1 - (Rm[1] * mux + Rm[4] * muy + Rm[7] * muz);
  r[k + 2] = tz - (Rm[2] * mux + Rm[5] * muy + Rm[8] * muz);
  if (!want_jac) return;
  double* J0 = J + k * m;
  double* J1 = J0 + m;
  double* J2 = J1 + m;
  // d(mu)/dq_j through the distal wrench (every lane), then R_m^T of it
  for (std::size_t j = 0; j < m; ++j) {
    const double dmx = dM[j] - (pm[1] * dF[2 * m + j] - pm[2] * dF[m + j]);
    const double dmy = dM[m + j] - (pm[2] * dF[j] - pm[0] * dF[2 * m + j]);
    const double dmz = dM[2 * m + j] - (pm[0] * dF[m + j] - pm[1] * dF[j]);
    J0[j] = -(Rm[0] * dmx + Rm[3] * dmy + Rm[6] * dmz);
    J1[j] = -(Rm[1] * dmx + Rm[4] * dmy + Rm[7] * dmz);
    J2[j] = -(Rm[2] * dmx + Rm[5] * dmy + Rm[8] * dmz);
  }
  // local lanes: R_m and p_m move with the subsegment's own unknowns (complex step)
  cd Rc[9], pc[3], gc[3];
  const double h = kComplexStep;
  for (std::size_t a = 0; a < 3; ++a) {
    cd qb(beta + 0.0, 0.0), qg(gamma + 0.0, 0.0), qe(eps + 0.0, 0.0);
    if (a == 0)
      qb += cd(0.0, h);
    else if (a == 1)
      qg += cd(0.0, h);
    else
      qe += cd(0.0, h);
    subsegment(qb, qg, cd(0.5) * qe, 0.5 * ell, Rc, pc, gc);
    const double dpx = pc[0].imag() / h;
    const double dpy = pc[1].imag() / h;
    const double dpz = pc[2].imag() / h;
    // d(mu) from the moving midpoint
    const double dmx = -(dpy * nFz - dpz * nFy);
    const double dmy = -(dpz * nFx - dpx * nFz);
    const double dmz = -(dpx * nFy - dpy * nFx);
    for (std::size_t u = 0; u < 3; ++u) {
      double acc = Rm[u] * dmx + Rm[3 + u] * dmy + Rm[6 + u] * dmz;
      acc += (Rc[u].imag() * mux + Rc[3 + u].imag() * muy + Rc[6 + u].imag() * muz) / h;
      J[(k + u) * m + k + a] -= acc;
    }
  }
  // the bending and torsion terms
  J0[k] += EI * s;
  J0[k + 1] += -EI * c;
  J1[k] += EI * c;
  J1[k + 1] += EI * s;
  J0[k + 2] += 0.5 * EI * (s * gamma + c * beta);
  J1[k + 2] += 0.5 * EI * (c * gamma - s * beta);
  J2[k + 2] += GJ / ell;
}

// Residual r (m,) [N m] at the unknowns q (3N,) and, if want_jac, its Jacobian J (m, m) row-major (J may be
// nullptr when !want_jac). lam scales every load (tensions, gravity, point wrenches): load stepping. The
// tendon tensions land in work.T (N+2, nt) [N]: row i is piece i (from disk i-1 to disk i), 0 past the anchor.
// No allocation: the scratch is work's (make_work(model)).
inline void evaluate(const double* q, double lam, const PccModel& model, bool want_jac, double* r, double* J,
                     PccWork& work) {
  using cd = std::complex<double>;
  const double* sub = model.sub.data();
  const double* holes = model.holes.data();
  const long* anchor = model.anchor.data();
  const double* fric = model.fric.data();
  const double* tension = model.tension.data();
  const double* grav = model.grav.data();
  const double* pforce = model.pforce.data();
  const double* pmoment = model.pmoment.data();
  const std::size_t n = model.n_disks;
  const std::size_t nt = model.n_tendons;
  const std::size_t m = 3 * n;
  double* Rs = work.R.data();
  double* ds = work.d.data();
  double* pgs = work.pg.data();
  double* dRs = work.dR.data();
  double* dds = work.dd.data();
  double* dpgs = work.dpg.data();
  double* G = work.G.data();
  double* Om = work.omega.data();
  double* T = work.T.data();
  double* W = work.W.data();
  double* dW = work.dW.data();
  double* dF = work.dF.data();
  double* dM = work.dM.data();
  double* dL = work.dL.data();
  double* dTl = work.dTl.data();
  double* lnP = work.lnP.data();
  double* lnQ = work.lnQ.data();
  cd Rc[9], dc[3], pgc[3];
  double lR[6][9] = {};
  double ld[6][3] = {};
  double lh[6][3] = {};
  double hn[3] = {};
  double out[7];
  const double h = kComplexStep;

  // ---- subsegment transforms (and their derivatives by complex step)
  for (std::size_t i = 1; i <= n; ++i) {
    const std::size_t k = 3 * (i - 1);
    subsegment(q[k], q[k + 1], q[k + 2], sub[5 * (i - 1)], Rs + 9 * i, ds + 3 * i, pgs + 3 * i);
    if (want_jac) {
      for (std::size_t a = 0; a < 3; ++a) {
        cd qc0(q[k] + 0.0, 0.0), qc1(q[k + 1] + 0.0, 0.0), qc2(q[k + 2] + 0.0, 0.0);
        if (a == 0)
          qc0 += cd(0.0, h);
        else if (a == 1)
          qc1 += cd(0.0, h);
        else
          qc2 += cd(0.0, h);
        subsegment(qc0, qc1, qc2, sub[5 * (i - 1)], Rc, dc, pgc);
        for (std::size_t u = 0; u < 3; ++u) {
          for (std::size_t v = 0; v < 3; ++v) dRs[27 * i + 9 * a + 3 * u + v] = Rc[3 * u + v].imag() / h;
          dds[9 * i + 3 * a + u] = dc[u].imag() / h;
          dpgs[9 * i + 3 * a + u] = pgc[u].imag() / h;
        }
      }
    }
  }

  // ---- base-to-frame rotations and angular velocities per lane
  for (std::size_t u = 0; u < 3; ++u)
    for (std::size_t v = 0; v < 3; ++v) G[3 * u + v] = u == v ? 1.0 : 0.0;
  for (std::size_t i = 1; i <= n; ++i) {
    const double* R = Rs + 9 * i;
    const double* Gp = G + 9 * (i - 1);
    double* Gi = G + 9 * i;
    for (std::size_t u = 0; u < 3; ++u)
      for (std::size_t v = 0; v < 3; ++v) Gi[3 * u + v] = R[u] * Gp[v] + R[3 + u] * Gp[3 + v] + R[6 + u] * Gp[6 + v];
    if (want_jac) {  // Om holds frame i-1's angular velocities per lane; it becomes frame i's
      const std::size_t k = 3 * (i - 1);
      for (std::size_t j = 0; j < k; ++j) {
        const double o0 = Om[j];
        const double o1 = Om[m + j];
        const double o2 = Om[2 * m + j];
        Om[j] = R[0] * o0 + R[3] * o1 + R[6] * o2;
        Om[m + j] = R[1] * o0 + R[4] * o1 + R[7] * o2;
        Om[2 * m + j] = R[2] * o0 + R[5] * o1 + R[8] * o2;
      }
      for (std::size_t a = 0; a < 3; ++a) {
        // vee(R^T dR)
        const double* dRa = dRs + 27 * i + 9 * a;
        const double s21 = R[2] * dRa[1] + R[5] * dRa[4] + R[8] * dRa[7];
        const double s02 = R[0] * dRa[2] + R[3] * dRa[5] + R[6] * dRa[8];
        const double s10 = R[1] * dRa[0] + R[4] * dRa[3] + R[7] * dRa[6];
        Om[k + a] = s21;
        Om[m + k + a] = s02;
        Om[2 * m + k + a] = s10;
      }
      for (std::size_t j = k + 3; j < m; ++j) {
        Om[j] = 0.0;
        Om[m + j] = 0.0;
        Om[2 * m + j] = 0.0;
      }
    }
  }

  // ---- tendons, base to tip: unit loads, tension ratios, tensions
  for (std::size_t c = 0; c < nt; ++c) T[nt + c] = lam * tension[c];
  for (std::size_t i = 1; i <= n; ++i) {
    if (want_jac) {  // tangent lanes 0-2 move subsegment i, lanes 3-5 the hole on disk i+1
      for (std::size_t a = 0; a < 3; ++a)
        for (std::size_t u = 0; u < 3; ++u) {
          for (std::size_t v = 0; v < 3; ++v) lR[a][3 * u + v] = dRs[27 * i + 9 * a + 3 * u + v];
          ld[a][u] = dds[9 * i + 3 * a + u];
        }
    }
    for (std::size_t c = 0; c < nt; ++c) {
      const long anc = anchor[c];
      double* Wic = W + (i * nt + c) * 7;
      double* dWic = dW + (i * nt + c) * 42;
      if (static_cast<long>(i) > anc) {
        for (std::size_t u = 0; u < 7; ++u) Wic[u] = 0.0;
        T[(i + 1) * nt + c] = 0.0;
        if (want_jac)
          for (std::size_t u = 0; u < 42; ++u) dWic[u] = 0.0;
        continue;
      }
      const bool is_anchor = static_cast<long>(i) == anc;
      const double px = holes[2 * c];
      const double py = holes[2 * c + 1];
      if (!is_anchor) {
        const double* Rn = Rs + 9 * (i + 1);
        const double* dn = ds + 3 * (i + 1);
        for (std::size_t u = 0; u < 3; ++u) hn[u] = Rn[3 * u] * px + Rn[3 * u + 1] * py + dn[u];
      }
      if (want_jac) {
        const int nl = is_anchor ? 3 : 6;
        if (!is_anchor) {
          for (std::size_t a = 0; a < 3; ++a)
            for (std::size_t u = 0; u < 3; ++u) {
              const double* dRn = dRs + 27 * (i + 1) + 9 * a + 3 * u;
              lh[a + 3][u] = dRn[0] * px + dRn[1] * py + dds[9 * (i + 1) + 3 * a + u];
            }
        }
        tendon_unit_load_jvp(Rs + 9 * i, ds + 3 * i, hn, lR, ld, lh, nl, px, py, is_anchor, fric, out, dWic);
        for (int a = nl; a < 6; ++a)
          for (std::size_t u = 0; u < 7; ++u) dWic[6 * u + a] = 0.0;
      } else {  // the same kernel with no tangent lanes: the load alone
        tendon_unit_load_jvp(Rs + 9 * i, ds + 3 * i, hn, lR, ld, lh, 0, px, py, is_anchor, fric, out, dWic);
      }
      for (std::size_t u = 0; u < 7; ++u) Wic[u] = out[u];
      const double rho = out[6];
      T[(i + 1) * nt + c] = !is_anchor ? rho * T[i * nt + c] : 0.0;
    }
  }

  if (want_jac) tension_log_derivatives(dW, W, n, nt, lnP, lnQ);

  // ---- wrenches, tip to base
  double Fx = 0.0, Fy = 0.0, Fz = 0.0, Mx = 0.0, My = 0.0, Mz = 0.0;
  if (want_jac) {
    for (std::size_t j = 0; j < 3 * m; ++j) {
      dF[j] = 0.0;
      dM[j] = 0.0;
    }
  }
  for (std::size_t i = n; i >= 1; --i) {
    const std::size_t k = 3 * (i - 1);
    const double* R = Rs + 9 * i;
    const double* d = ds + 3 * i;
    const double* pg = pgs + 3 * i;
    const double* si = sub + 5 * (i - 1);
    const double ell = si[0];
    const double md = si[3];
    const double mb = si[4];
    const double* Gp = G + 9 * (i - 1);
    const double* pf = pforce + 3 * (i - 1);
    const double* pmo = pmoment + 3 * (i - 1);
    // base-fixed loads in frame i-1: gravity [m/s^2], point force [N] and moment [N m]
    const double glx = lam * (Gp[0] * grav[0] + Gp[1] * grav[1] + Gp[2] * grav[2]);
    const double gly = lam * (Gp[3] * grav[0] + Gp[4] * grav[1] + Gp[5] * grav[2]);
    const double glz = lam * (Gp[6] * grav[0] + Gp[7] * grav[1] + Gp[8] * grav[2]);
    const double pfx = lam * (Gp[0] * pf[0] + Gp[1] * pf[1] + Gp[2] * pf[2]);
    const double pfy = lam * (Gp[3] * pf[0] + Gp[4] * pf[1] + Gp[5] * pf[2]);
    const double pfz = lam * (Gp[6] * pf[0] + Gp[7] * pf[1] + Gp[8] * pf[2]);
    const double pmx = lam * (Gp[0] * pmo[0] + Gp[1] * pmo[1] + Gp[2] * pmo[2]);
    const double pmy = lam * (Gp[3] * pmo[0] + Gp[4] * pmo[1] + Gp[5] * pmo[2]);
    const double pmz = lam * (Gp[6] * pmo[0] + Gp[7] * pmo[1] + Gp[8] * pmo[2]);
    const double mass = md + mb;
    const double cmx = md * d[0] + mb * pg[0];
    const double cmy = md * d[1] + mb * pg[1];
    const double cmz = md * d[2] + mb * pg[2];
    // the local load on subsegment i about the origin of frame i-1
    double LFx = mass * glx + pfx;
    double LFy = mass * gly + pfy;
    double LFz = mass * glz + pfz;
    double LMx = cmy * glz - cmz * gly + d[1] * pfz - d[2] * pfy + pmx;
    double LMy = cmz * glx - cmx * glz + d[2] * pfx - d[0] * pfz + pmy;
    double LMz = cmx * gly - cmy * glx + d[0] * pfy - d[1] * pfx + pmz;
    for (std::size_t c = 0; c < nt; ++c) {
      if (static_cast<long>(i) <= anchor[c]) {
        const double Tc = T[i * nt + c];
        const double* Wic = W + (i * nt + c) * 7;
        LFx += Tc * Wic[0];
        LFy += Tc * Wic[1];
        LFz += Tc * Wic[2];
        LMx += Tc * Wic[3];
        LMy += Tc * Wic[4];
        LMz += Tc * Wic[5];
      }
    }
    // propagate F_{i+1}, M_{i+1} (frame i) into frame i-1
    const double RFx = R[0] * Fx + R[1] * Fy + R[2] * Fz;
    const double RFy = R[3] * Fx + R[4] * Fy + R[5] * Fz;
    const double RFz = R[6] * Fx + R[7] * Fy + R[8] * Fz;
    const double RMx = R[0] * Mx + R[1] * My + R[2] * Mz;
    const double RMy = R[3] * Mx + R[4] * My + R[5] * Mz;
    const double RMz = R[6] * Mx + R[7] * My + R[8] * Mz;
    const double nFx = LFx + RFx;
    const double nFy = LFy + RFy;
    const double nFz = LFz + RFz;
    const double nMx = LMx + RMx + d[1] * RFz - d[2] * RFy;
    const double nMy = LMy + RMy + d[2] * RFx - d[0] * RFz;
    const double nMz = LMz + RMz + d[0] * RFy - d[1] * RFx;
    // residual: EI [-gamma, beta, 0] + R e_z GJ eps / l - M_i = 0 about the base of subsegment i
    const double EI = si[1];
    const double tau = si[2] * q[k + 2] / ell;
    if (model.balance == BALANCE_BASE) {
      r[k] = -EI * q[k + 1] + R[2] * tau - nMx;
      r[k + 1] = EI * q[k] + R[5] * tau - nMy;
      r[k + 2] = R[8] * tau - nMz;
    }

    if (want_jac) {
      for (std::size_t j = 0; j < 6 * m; ++j) dL[j] = 0.0;
      // Om: frame i's angular velocities per lane -> frame i-1's (lanes of subsegment i drop out)
      for (std::size_t j = 0; j < k; ++j) {
        const double o0 = Om[j];
        const double o1 = Om[m + j];
        const double o2 = Om[2 * m + j];
        Om[j] = R[0] * o0 + R[1] * o1 + R[2] * o2;
        Om[m + j] = R[3] * o0 + R[4] * o1 + R[5] * o2;
        Om[2 * m + j] = R[6] * o0 + R[7] * o1 + R[8] * o2;
      }
      for (std::size_t j = k; j < k + 3; ++j) {
        Om[j] = 0.0;
        Om[m + j] = 0.0;
        Om[2 * m + j] = 0.0;
      }
      // tendons: through tensions (all upstream lanes) and local geometry
      for (std::size_t c = 0; c < nt; ++c) {
        if (static_cast<long>(i) <= anchor[c]) {
          const double Tc = T[i * nt + c];
          const double* Wic = W + (i * nt + c) * 7;
          const double* dWic = dW + (i * nt + c) * 42;
          if (Tc != 0.0) {
            tension_lanes(lnP, lnQ, n, c, i, Tc, dTl);
            for (std::size_t u = 0; u < 6; ++u) {
              const double wu = Wic[u];
              double* dLu = dL + u * m;
              for (std::size_t j = 0; j < k + 3; ++j) dLu[j] += wu * dTl[j];
            }
          }
          const std::size_t la = k + 6 <= m ? 6 : 3;
          for (std::size_t a = 0; a < la; ++a)
            for (std::size_t u = 0; u < 6; ++u) dL[u * m + k + a] += Tc * dWic[6 * u + a];
        }
      }
      // base-fixed loads: upstream lanes rotate them, local lanes move the points
      for (std::size_t j = 0; j < k; ++j) {
        const double ox = Om[j];
        const double oy = Om[m + j];
        const double oz = Om[2 * m + j];
        // d(v) = v x omega for each base-fixed vector v in frame i-1
        const double dgx = gly * oz - glz * oy;
        const double dgy = glz * ox - glx * oz;
        const double dgz = glx * oy - gly * ox;
        const double dfx = pfy * oz - pfz * oy;
        const double dfy = pfz * ox - pfx * oz;
        const double dfz = pfx * oy - pfy * ox;
        const double dmx = pmy * oz - pmz * oy;
        const double dmy = pmz * ox - pmx * oz;
        const double dmz = pmx * oy - pmy * ox;
        dL[j] += mass * dgx + dfx;
        dL[m + j] += mass * dgy + dfy;
        dL[2 * m + j] += mass * dgz + dfz;
        dL[3 * m + j] += cmy * dgz - cmz * dgy + d[1] * dfz - d[2] * dfy + dmx;
        dL[4 * m + j] += cmz * dgx - cmx * dgz + d[2] * dfx - d[0] * dfz + dmy;
        dL[5 * m + j] += cmx * dgy - cmy * dgx + d[0] * dfy - d[1] * dfx + dmz;
      }
      for (std::size_t a = 0; a < 3; ++a) {
        const double ddx = dds[9 * i + 3 * a];
        const double ddy = dds[9 * i + 3 * a + 1];
        const double ddz = dds[9 * i + 3 * a + 2];
        const double dcx = md * ddx + mb * dpgs[9 * i + 3 * a];
        const double dcy = md * ddy + mb * dpgs[9 * i + 3 * a + 1];
        const double dcz = md * ddz + mb * dpgs[9 * i + 3 * a + 2];
        dL[3 * m + k + a] += dcy * glz - dcz * gly + ddy * pfz - ddz * pfy;
        dL[4 * m + k + a] += dcz * glx - dcx * glz + ddz * pfx - ddx * pfz;
        dL[5 * m + k + a] += dcx * gly - dcy * glx + ddx * pfy - ddy * pfx;
      }
      // dF_i, dM_i from dF_{i+1}, dM_{i+1} (in place, lane by lane)
      for (std::size_t j = 0; j < m; ++j) {
        const double ax = dF[j];
        const double ay = dF[m + j];
        const double az = dF[2 * m + j];
        const double bx_ = dM[j];
        const double by_ = dM[m + j];
        const double bz_ = dM[2 * m + j];
        const double rfx = R[0] * ax + R[1] * ay + R[2] * az;
        const double rfy = R[3] * ax + R[4] * ay + R[5] * az;
        const double rfz = R[6] * ax + R[7] * ay + R[8] * az;
        const double rmx = R[0] * bx_ + R[1] * by_ + R[2] * bz_;
        const double rmy = R[3] * bx_ + R[4] * by_ + R[5] * bz_;
        const double rmz = R[6] * bx_ + R[7] * by_ + R[8] * bz_;
        dF[j] = dL[j] + rfx;
        dF[m + j] = dL[m + j] + rfy;
        dF[2 * m + j] = dL[2 * m + j] + rfz;
        dM[j] = dL[3 * m + j] + rmx + d[1] * rfz - d[2] * rfy;
        dM[m + j] = dL[4 * m + j] + rmy + d[2] * rfx - d[0] * rfz;
        dM[2 * m + j] = dL[5 * m + j] + rmz + d[0] * rfy - d[1] * rfx;
      }
      for (std::size_t a = 0; a < 3; ++a) {
        const double* dRa = dRs + 27 * i + 9 * a;
        const double ddx = dds[9 * i + 3 * a];
        const double ddy = dds[9 * i + 3 * a + 1];
        const double ddz = dds[9 * i + 3 * a + 2];
        const double gfx = dRa[0] * Fx + dRa[1] * Fy + dRa[2] * Fz;
        const double gfy = dRa[3] * Fx + dRa[4] * Fy + dRa[5] * Fz;
        const double gfz = dRa[6] * Fx + dRa[7] * Fy + dRa[8] * Fz;
        const double gmx = dRa[0] * Mx + dRa[1] * My + dRa[2] * Mz;
        const double gmy = dRa[3] * Mx + dRa[4] * My + dRa[5] * Mz;
        const double gmz = dRa[6] * Mx + dRa[7] * My + dRa[8] * Mz;
        dF[k + a] += gfx;
        dF[m + k + a] += gfy;
        dF[2 * m + k + a] += gfz;
        dM[k + a] += gmx + ddy * RFz - ddz * RFy + d[1] * gfz - d[2] * gfy;
        dM[m + k + a] += gmy + ddz * RFx - ddx * RFz + d[2] * gfx - d[0] * gfz;
        dM[2 * m + k + a] += gmz + ddx * RFy - ddy * RFx + d[0] * gfy - d[1] * gfx;
      }
      if (model.balance == BALANCE_BASE) {
        // Jacobian rows of subsegment i
        for (std::size_t j = 0; j < m; ++j) {
          J[k * m + j] = -dM[j];
          J[(k + 1) * m + j] = -dM[m + j];
          J[(k + 2) * m + j] = -dM[2 * m + j];
        }
        const double GJl = si[2] / ell;
        for (std::size_t a = 0; a < 3; ++a)
          for (std::size_t u = 0; u < 3; ++u) J[(k + u) * m + k + a] += dRs[27 * i + 9 * a + 3 * u + 2] * tau;
        J[k * m + k + 1] += -EI;
        J[(k + 1) * m + k] += EI;
        for (std::size_t u = 0; u < 3; ++u) J[(k + u) * m + k + 2] += R[3 * u + 2] * GJl;
      }
    }
    if (model.balance == BALANCE_MIDPOINT)
      midpoint_rows(q, k, ell, EI, si[2], nFx, nFy, nFz, nMx, nMy, nMz, dF, dM, m, want_jac, r, J);
    Fx = nFx;
    Fy = nFy;
    Fz = nFz;
    Mx = nMx;
    My = nMy;
    Mz = nMz;
  }
}

// The tip's exact derivative by the unknowns, out (3, 3N) row-major [m per unit of q], at q
// (tip_jacobian in kinematics.hpp); the frames go to work.pos and work.rot.
inline void tip_jacobian_of(const double* q, const PccModel& model, PccWork& work, double* out) {
  tip_jacobian(q, model.sub.data(), model.n_disks, work.pos.data(), work.rot.data(), out);
}

// Largest change of bend angle or twist of one subsegment for a change dq (3N,) of the unknowns [rad]:
// max_i max(l_i sqrt(dbeta_i^2 + dgamma_i^2), |deps_i|).
inline double largest_angle(const double* dq, const PccModel& model) {
  const double* sub = model.sub.data();
  double big = 0.0;
  for (std::size_t i = 0; i < model.n_disks; ++i) {
    const double dth = std::sqrt(dq[3 * i] * dq[3 * i] + dq[3 * i + 1] * dq[3 * i + 1]) * sub[5 * i];
    const double de = std::fabs(dq[3 * i + 2]);
    // Python's max(big, dth, de): the first of the largest
    double best = big;
    if (dth > best) best = dth;
    if (de > best) best = de;
    big = best;
  }
  return big;
}

// out = model with other actuator tensions (nt,) [N] (out may be model itself).
inline void with_tension(const PccModel& model, const double* tension, PccModel& out) {
  if (&out != &model) out = model;
  out.tension.assign(tension, tension + model.n_tendons);
}

// out = the model b under the loads (1 - s) a + s b: actuator tensions, gravity and point wrenches, each as
// a + s (b - a) (both the same robot; out may be a or b). Exactly a at s = 0 and b at s = 1; the equations are
// affine in the loads, so the residual is too.
inline void blend(const PccModel& a, const PccModel& b, double s, PccModel& out) {
  if (s == 1.0) {
    if (&out != &b) out = b;
    return;
  }
  if (s == 0.0) {
    if (&out != &a) out = a;
    return;
  }
  // the loads first, element by element (safe when out is a or b; no allocation once out has the sizes)
  auto mix = [s](const std::vector<double>& x, const std::vector<double>& y, std::vector<double>& z) {
    z.resize(x.size());
    for (std::size_t j = 0; j < x.size(); ++j) z[j] = x[j] + s * (y[j] - x[j]);
  };
  mix(a.tension, b.tension, out.tension);
  mix(a.grav, b.grav, out.grav);
  mix(a.pforce, b.pforce, out.pforce);
  mix(a.pmoment, b.pmoment, out.pmoment);
  // then the robot (and the friction law, its mode included) from b
  if (&out != &b) {
    out.n_disks = b.n_disks;
    out.n_tendons = b.n_tendons;
    out.sub = b.sub;
    out.holes = b.holes;
    out.anchor = b.anchor;
    out.fric = b.fric;
    out.balance = b.balance;
  }
}

}  // namespace pytdcr
