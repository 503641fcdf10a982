// The subsegment Cosserat rod (sscr): the multiple-shooting residual of the disks' balances and its exact
// Jacobian, the C++ twin of src/pytdcr/statics/kernels/sscr.py, operation for operation and in the same order, so
// that both round alike (the build has -ffp-contract=off and no fast-math).
//
// The backbone between neighbouring disks is a Cosserat rod carrying only its own weight; the disks are rigid
// bodies on it. Each disk receives the tendon forces through its holes along the actual chords to the
// neighbouring disks (the PCC model's pull rule, anchor and friction laws: the PCC tendon kernel applied to the
// relative transforms of the disks), its weight and any point wrench.
//
// Unknowns x (6N,): per subsegment i (from disk i-1 to disk i), the internal force n_i and moment m_i at its base,
// in the frame of disk i-1, as (l_i n_i, m_i) [N m]. Residual, per disk i, its balance about its centre in the
// frame of disk i:
//
//     r_i = R_i^T ( l_i (n_i^e - n_{i+1} - F_i),  m_i^e - m_{i+1} - M_i ),   n_{N+1} = m_{N+1} = 0
//
// with (n_i^e, m_i^e) the internal wrench at the end of subsegment i (world) and (F_i, M_i) the loads on disk i.
// The rod (world frame; n, m the internal force and moment about the rod's point):
//
//     p' = R v,  R' = R [u]x,  n' = -rho A g,  m' = -p' x n,
//     u = K_bt^-1 R^T m,  v = e3 (+ K_se^-1 R^T n with shear and extension),
//
// integrated by classical Runge-Kutta, nsub steps per subsegment, R pulled back onto SO(3) after each step. The
// Jacobian is exact for the discrete scheme (forward mode through every step, nine directions).
//
// Layout of the packed model (SscrModel, row-major), as the PCC model's (pcc.hpp) plus rod:
//   sub     (N, 5)   per subsegment i: l_i [m], EI [N m^2], GJ [N m^2], disk mass [kg], backbone piece mass [kg]
//   holes   (nt, 2)  tendon hole (x, y) in its disk's frame [m]
//   anchor  (nt,)    1-based anchor disk of each tendon
//   fric    (4,)     law code (0 none, 1 constant, 2 exponential), mu0, decay [1/rad], mode (+1 pull, -1 release)
//   tension (nt,)    actuator tensions [N]
//   grav    (3,)     gravity in the base frame [m/s^2]
//   pforce, pmoment (N, 3)  point wrench on disk i in the base frame [N, N m]
//   rod     (5,)     GA [N], EA [N], mass per length [kg/m], shear and extension (1) or not (0), RK steps per
//                    subsegment
//
// Where the numba kernel multiplies small matrices with '@', numba calls BLAS: blas_dot3 reproduces its FMA
// accumulation. Where it solves with np.linalg.solve (LAPACK), this file uses linalg.hpp's LU with partial
// pivoting: that result (tangent_stiffness) agrees to round-off, not to the bit. The tendon loads are a copy of
// pcc.hpp's kernel (sscr_detail::tendon_unit_load_jvp: why, there).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include "linalg.hpp"

namespace pytdcr {

// The packed subsegment Cosserat rod, owning copies of its arrays (row-major; layouts in the header comment).
struct SscrModel {
  std::size_t n_disks = 0, n_tendons = 0;
  std::vector<double> sub;              // (N, 5)
  std::vector<double> holes;            // (nt, 2) [m]
  std::vector<long> anchor;             // (nt,) 1-based
  std::vector<double> fric;             // (4,)
  std::vector<double> tension;          // (nt,) [N]
  std::vector<double> grav;             // (3,) [m/s^2]
  std::vector<double> pforce, pmoment;  // (N, 3) [N], [N m]
  std::vector<double> rod;              // (5,)
  std::size_t n_unknowns() const { return 6 * n_disks; }
};

namespace sscr_detail {
//: lanes of one disk's tendon loads: (dp, dtheta) of the disks before it, itself and after it
inline constexpr int kLanes = 18;
}  // namespace sscr_detail

// Scratch of evaluate (N disks, nt tendons, m = 6N unknowns), as sscr.SSCRWork, row-major; plus the fixed-size
// scratch the numba kernel allocates per call (here once, so that evaluate does not allocate).
struct SscrWork {
  std::size_t n_disks = 0, n_tendons = 0;
  std::vector<double> pos;   // (N+2, 3) disk centres, world [m]; 0 the base; N+1 padding
  std::vector<double> rot;   // (N+2, 3, 3) disk frames, world
  std::vector<double> wend;  // (N+1, 6) internal wrench at the end of subsegment i, world [N, N m]
  std::vector<double> phi;   // (N+1, 12, 12) d(pose_i, wend_i) / d(pose_{i-1}, x_i); pose = (dp, dtheta), world
  std::vector<double> S;     // (N+2, 6, m) d pose_i / d x
  std::vector<double> E;     // (N+1, 6, m) d wend_i / d x
  std::vector<double> Rrel;  // (N+2, 3, 3) frame of disk i in frame of disk i-1
  std::vector<double> drel;  // (N+2, 3) [m]
  std::vector<double> T;     // (N+2, nt) tension in piece i of each tendon [N]
  std::vector<double> dT;    // (N+2, nt, m)
  std::vector<double> W;     // (N+1, nt, 7) unit load (frame i-1, about its origin) and tension ratio at disk i
  std::vector<double> dW;    // (N+1, nt, 7, 18) its derivative by the 18 pose lanes
  std::vector<double> dD;    // (6, m) scratch: derivative of one disk's load
  std::vector<double> G;     // (6, m) scratch of evaluate: d u / d x of one disk
  // scratch of tangent_stiffness (sized on its first use; not evaluate's)
  std::vector<double> ts_r, ts_J, ts_P;
  std::vector<std::size_t> ts_piv;
};

// Scratch for N = n disks and nt tendons (a name of its own: pcc.hpp's make_work(n, nt) makes a PccWork).
inline SscrWork make_sscr_work(std::size_t n, std::size_t nt) {
  const std::size_t m = 6 * n;
  SscrWork w;
  w.n_disks = n;
  w.n_tendons = nt;
  w.pos.assign((n + 2) * 3, 0.0);
  w.rot.assign((n + 2) * 9, 0.0);
  w.Rrel.assign((n + 2) * 9, 0.0);
  for (std::size_t i = 0; i < n + 2; ++i)
    for (int a = 0; a < 3; ++a) {
      w.rot[9 * i + 4 * a] = 1.0;
      w.Rrel[9 * i + 4 * a] = 1.0;
    }
  w.wend.assign((n + 1) * 6, 0.0);
  w.phi.assign((n + 1) * 144, 0.0);
  w.S.assign((n + 2) * 6 * m, 0.0);
  w.E.assign((n + 1) * 6 * m, 0.0);
  w.drel.assign((n + 2) * 3, 0.0);
  w.T.assign((n + 2) * nt, 0.0);
  w.dT.assign((n + 2) * nt * m, 0.0);
  w.W.assign((n + 1) * nt * 7, 0.0);
  w.dW.assign((n + 1) * nt * 7 * sscr_detail::kLanes, 0.0);
  w.dD.assign(6 * m, 0.0);
  w.G.assign(6 * m, 0.0);
  return w;
}

// Scratch arrays for model (make_model_work).
inline SscrWork make_work(const SscrModel& model) { return make_sscr_work(model.n_disks, model.n_tendons); }

// out = model with other actuator tensions (nt,) [N] (out may be model itself).
inline void with_tension(const SscrModel& model, const double* tension, SscrModel& out) {
  if (&out != &model) out = model;
  out.tension.assign(tension, tension + model.n_tendons);
}

// out = the packed rod b under the loads (1 - s) a + s b: actuator tensions, gravity and point wrenches, each as
// a + s (b - a) (both the same robot; out may be a or b). Exactly a at s = 0 and b at s = 1.
inline void blend(const SscrModel& a, const SscrModel& b, double s, SscrModel& out) {
  if (s == 1.0) {
    if (&out != &b) out = b;
    return;
  }
  if (s == 0.0) {
    if (&out != &a) out = a;
    return;
  }
  auto mix = [s](const std::vector<double>& x, const std::vector<double>& y, std::vector<double>& z) {
    z.resize(x.size());
    for (std::size_t j = 0; j < x.size(); ++j) z[j] = x[j] + s * (y[j] - x[j]);
  };
  mix(a.tension, b.tension, out.tension);
  mix(a.grav, b.grav, out.grav);
  mix(a.pforce, b.pforce, out.pforce);
  mix(a.pmoment, b.pmoment, out.pmoment);
  if (&out != &b) {  // the robot, its friction law and its rod from b
    out.n_disks = b.n_disks;
    out.n_tendons = b.n_tendons;
    out.sub = b.sub;
    out.holes = b.holes;
    out.anchor = b.anchor;
    out.fric = b.fric;
    out.rod = b.rod;
  }
}

// How far a change dq (6N,) of the base wrenches bends or twists a subsegment [rad]: max_i l_i |dm_i| /
// min(EI, GJ) (numba's min and max: the second argument only when strictly smaller or larger).
inline double largest_angle(const double* dq, const SscrModel& model) {
  const double* sub = model.sub.data();
  double big = 0.0;
  for (std::size_t i = 0; i < model.n_disks; ++i) {
    const std::size_t k = 6 * i;
    const double dm = std::sqrt(dq[k + 3] * dq[k + 3] + dq[k + 4] * dq[k + 4] + dq[k + 5] * dq[k + 5]);
    const double EI = sub[5 * i + 1], GJ = sub[5 * i + 2];
    const double stiff = GJ < EI ? GJ : EI;
    const double v = sub[5 * i] * dm / stiff;
    if (v > big) big = v;
  }
  return big;
}

namespace sscr_detail {

// ------------------------------------------------------------------------ the PCC tendon kernel (pcc.py's)
// Load of one tendon of unit tension on disk i, in frame i-1, and its derivatives: pcc.tendon_unit_load_jvp, a
// copy of pcc.hpp's (the same operations, so the same bits) with the row stride of dout a parameter.
//
// Why a copy: pcc.hpp's kernel writes 6 lanes a row (dout[6 u + a]); sscr has 18. Calling it three times, six
// lanes at a time, gives the same bits but recomputes the primal (chords, friction law) thrice: measured about
// +8 % on the Jacobian evaluation of the paper robot (_bench_evaluate_sscr, best of 7 x 300 calls on a loaded
// 2-core machine: 356-360 us with this copy, 389 us and more through pcc.hpp's; the residual alone unchanged), the
// solver's main cost. A stride parameter on pcc.hpp's kernel (default 6) would let both share one at no cost.
//
// R (3x3), d (3): transform of subsegment i; hn (3): the hole at disk i+1 in frame i (unused at the anchor);
// (px, py): the tendon's hole in its disk's frame [m]. Writes out[0:3] the force, out[3:6] the moment about the
// origin of frame i-1 and out[6] the tension ratio T_{i+1}/T_i across the disk (0 at the anchor). Lane a (of nl)
// moves the transform by dR[a] (3x3), dd[a] (3) and the next hole by dh[a] (3); writes dout[stride u + a].
inline void tendon_unit_load_jvp(const double* R, const double* d, const double* hn, const double (*dR)[9],
                                 const double (*dd)[3], const double (*dh)[3], int nl, double px, double py,
                                 bool is_anchor, const double* fric, double* out, double* dout, int stride) {
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
    dout[0 * stride + a] = dfx;
    dout[1 * stride + a] = dfy;
    dout[2 * stride + a] = dfz;
    dout[3 * stride + a] = dby * fz - dbz * fy + by * dfz - bz * dfy;
    dout[4 * stride + a] = dbz * fx - dbx * fz + bz * dfx - bx * dfz;
    dout[5 * stride + a] = dbx * fy - dby * fx + bx * dfy - by * dfx;
    dout[6 * stride + a] = drho;
  }
}

// a0 b0 + a1 b1 + a2 b2 as numba's '@' computes one entry of a 3x3 product: numba calls BLAS dgemm, whose
// OpenBLAS kernels on x86-64 with FMA (Haswell and later, this project's machines) accumulate a0 b0, then
// fma(a1, b1, .), then fma(a2, b2, .) (measured: every entry of 300 random products to the bit). std::fma rounds
// once, exactly, whatever the compiler flags, so this is bit-identical to numba there; on a CPU whose BLAS has no
// FMA the two differ in the last bit of these entries.
inline double blas_dot3(double a0, double b0, double a1, double b1, double a2, double b2) {
  return std::fma(a2, b2, std::fma(a1, b1, a0 * b0));
}

// ------------------------------------------------------------------------------------ the rod between two disks
// d/ds of the state y (18,): p [m], R (row-major), n [N], m [N m]; uv (6,) receives u [1/m], v. kinv (6,): 1/EI,
// 1/EI, 1/GJ, 1/GA, 1/GA, 1/EA; fw (3,): the distributed force -rho A g [N/m].
inline void rhs(const double* y, const double* kinv, bool ext, const double* fw, double* dy, double* uv) {
  for (int b = 0; b < 3; ++b) {
    const double rtm = y[3 + b] * y[15] + y[6 + b] * y[16] + y[9 + b] * y[17];
    uv[b] = kinv[b] * rtm;
    uv[3 + b] = 0.0;
  }
  uv[5] = 1.0;
  if (ext) {
    for (int b = 0; b < 3; ++b) {
      const double rtn = y[3 + b] * y[12] + y[6 + b] * y[13] + y[9 + b] * y[14];
      uv[3 + b] += kinv[3 + b] * rtn;
    }
    // axial strain <= -1: the rod crushed through itself; no equilibrium (NaN residual)
    if (uv[5] <= 0.0) uv[5] = std::numeric_limits<double>::quiet_NaN();
  }
  const double u0 = uv[0], u1 = uv[1], u2 = uv[2], v0 = uv[3], v1 = uv[4], v2 = uv[5];
  for (int a = 0; a < 3; ++a) {
    const double r0 = y[3 + 3 * a], r1 = y[4 + 3 * a], r2 = y[5 + 3 * a];
    dy[a] = r0 * v0 + r1 * v1 + r2 * v2;
    dy[3 + 3 * a] = r1 * u2 - r2 * u1;
    dy[4 + 3 * a] = -r0 * u2 + r2 * u0;
    dy[5 + 3 * a] = r0 * u1 - r1 * u0;
  }
  for (int a = 0; a < 3; ++a) dy[12 + a] = fw[a];
  const double n0 = y[12], n1 = y[13], n2 = y[14];
  dy[15] = -(dy[1] * n2 - dy[2] * n1);
  dy[16] = -(dy[2] * n0 - dy[0] * n2);
  dy[17] = -(dy[0] * n1 - dy[1] * n0);
}

// Tangent of rhs along each column of Y (18, nc), row-major; dy and uv from rhs at y; into dY (18, nc).
template <int nc>
inline void rhs_tangent(const double* y, const double* Y, const double* kinv, bool ext, const double* dy,
                        const double* uv, double* dY) {
  const double u0 = uv[0], u1 = uv[1], u2 = uv[2], v0 = uv[3], v1 = uv[4], v2 = uv[5];
  const double n0 = y[12], n1 = y[13], n2 = y[14];
  const double m0 = y[15], m1 = y[16], m2 = y[17];
  auto Yv = [Y](int a, int c) { return Y[a * nc + c]; };
  for (int c = 0; c < nc; ++c) {
    const double dn0 = Yv(12, c), dn1 = Yv(13, c), dn2 = Yv(14, c);
    const double dm0 = Yv(15, c), dm1 = Yv(16, c), dm2 = Yv(17, c);
    const double du0 = kinv[0] * (Yv(3, c) * m0 + Yv(6, c) * m1 + Yv(9, c) * m2 + y[3] * dm0 + y[6] * dm1 +
                                  y[9] * dm2);
    const double du1 = kinv[1] * (Yv(4, c) * m0 + Yv(7, c) * m1 + Yv(10, c) * m2 + y[4] * dm0 + y[7] * dm1 +
                                  y[10] * dm2);
    const double du2 = kinv[2] * (Yv(5, c) * m0 + Yv(8, c) * m1 + Yv(11, c) * m2 + y[5] * dm0 + y[8] * dm1 +
                                  y[11] * dm2);
    double dv0 = 0.0, dv1 = 0.0, dv2 = 0.0;
    if (ext) {
      dv0 = kinv[3] * (Yv(3, c) * n0 + Yv(6, c) * n1 + Yv(9, c) * n2 + y[3] * dn0 + y[6] * dn1 + y[9] * dn2);
      dv1 = kinv[4] * (Yv(4, c) * n0 + Yv(7, c) * n1 + Yv(10, c) * n2 + y[4] * dn0 + y[7] * dn1 + y[10] * dn2);
      dv2 = kinv[5] * (Yv(5, c) * n0 + Yv(8, c) * n1 + Yv(11, c) * n2 + y[5] * dn0 + y[8] * dn1 + y[11] * dn2);
    }
    for (int a = 0; a < 3; ++a) {
      const double dr0 = Yv(3 + 3 * a, c), dr1 = Yv(4 + 3 * a, c), dr2 = Yv(5 + 3 * a, c);
      const double r0 = y[3 + 3 * a], r1 = y[4 + 3 * a], r2 = y[5 + 3 * a];
      dY[a * nc + c] = dr0 * v0 + dr1 * v1 + dr2 * v2 + r0 * dv0 + r1 * dv1 + r2 * dv2;
      dY[(3 + 3 * a) * nc + c] = dr1 * u2 - dr2 * u1 + r1 * du2 - r2 * du1;
      dY[(4 + 3 * a) * nc + c] = -dr0 * u2 + dr2 * u0 - r0 * du2 + r2 * du0;
      dY[(5 + 3 * a) * nc + c] = dr0 * u1 - dr1 * u0 + r0 * du1 - r1 * du0;
      dY[(12 + a) * nc + c] = 0.0;
    }
    const double dp0 = dY[0 * nc + c], dp1 = dY[1 * nc + c], dp2 = dY[2 * nc + c];
    dY[15 * nc + c] = -(dp1 * n2 - dp2 * n1 + dy[1] * dn2 - dy[2] * dn1);
    dY[16 * nc + c] = -(dp2 * n0 - dp0 * n2 + dy[2] * dn0 - dy[0] * dn2);
    dY[17 * nc + c] = -(dp0 * n1 - dp1 * n0 + dy[0] * dn1 - dy[1] * dn0);
  }
}

// R <- R (3 I - R^T R) / 2 (one Newton-Schulz step back onto SO(3)) on the rotation of y (18,), with its tangent
// along the columns of Y (18, nc) when tangent.
template <int nc>
inline void reorthonormalize(double* y, double* Y, bool tangent) {
  double R[3][3], S[3][3];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) R[a][b] = y[3 + 3 * a + b];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      S[a][b] = (a == b ? 3.0 : 0.0) - (R[0][a] * R[0][b] + R[1][a] * R[1][b] + R[2][a] * R[2][b]);
  if (tangent) {
    double dS[3][3], dRn[3][3];
    for (int c = 0; c < nc; ++c) {
      // dRn = (dR S + R dS) / 2, dS = -(dR^T R + R^T dR)
      for (int e = 0; e < 3; ++e)
        for (int b = 0; b < 3; ++b) {
          double acc = 0.0;
          for (int f = 0; f < 3; ++f)
            acc -= Y[(3 + 3 * f + e) * nc + c] * R[f][b] + R[f][e] * Y[(3 + 3 * f + b) * nc + c];
          dS[e][b] = acc;
        }
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
          double acc = 0.0;
          for (int e = 0; e < 3; ++e) acc += Y[(3 + 3 * a + e) * nc + c] * S[e][b] + R[a][e] * dS[e][b];
          dRn[a][b] = 0.5 * acc;
        }
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) Y[(3 + 3 * a + b) * nc + c] = dRn[a][b];
    }
  }
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) y[3 + 3 * a + b] = 0.5 * (R[a][0] * S[0][b] + R[a][1] * S[1][b] + R[a][2] * S[2][b]);
}

// Integrate one subsegment of length ell [m] from the state y (18,), in place, nsub classical Runge-Kutta steps.
// With tangent, Y (18, nc) is carried along (forward mode of the discrete scheme). The points after each
// step are written to curve (rows, 3) from row ic while rows remain; returns the next free row.
template <int nc>
inline std::size_t integrate(double* y, double ell, long nsub, const double* kinv, bool ext, const double* fw,
                             bool tangent, double* Y, double* curve, std::size_t rows, std::size_t ic) {
  const double h = ell / static_cast<double>(nsub);
  double k[4][18], yt[18], uv[6];
  double K[4][18 * nc], Yt[18 * nc];
  for (long step = 0; step < nsub; ++step) {
    for (int st = 0; st < 4; ++st) {
      const double* src = st == 0 ? y : yt;
      rhs(src, kinv, ext, fw, k[st], uv);
      if (tangent) rhs_tangent<nc>(src, st == 0 ? Y : Yt, kinv, ext, k[st], uv, K[st]);
      if (st < 3) {
        const double c = st == 2 ? h : 0.5 * h;
        for (int a = 0; a < 18; ++a) yt[a] = y[a] + c * k[st][a];
        if (tangent)
          for (int a = 0; a < 18; ++a)
            for (int b = 0; b < nc; ++b) Yt[a * nc + b] = Y[a * nc + b] + c * K[st][a * nc + b];
      }
    }
    for (int a = 0; a < 18; ++a) y[a] += h / 6.0 * (k[0][a] + 2.0 * k[1][a] + 2.0 * k[2][a] + k[3][a]);
    if (tangent)
      for (int a = 0; a < 18; ++a)
        for (int b = 0; b < nc; ++b) {
          const int ab = a * nc + b;
          Y[ab] += h / 6.0 * (K[0][ab] + 2.0 * K[1][ab] + 2.0 * K[2][ab] + K[3][ab]);
        }
    reorthonormalize<nc>(y, Y, tangent);
    if (ic < rows) {
      curve[3 * ic] = y[0];
      curve[3 * ic + 1] = y[1];
      curve[3 * ic + 2] = y[2];
      ++ic;
    }
  }
  return ic;
}

// kinv (6,) of subsegment i (0-based): 1/EI, 1/EI, 1/GJ, 1/GA, 1/GA, 1/EA.
inline void stiffness_inverse(const SscrModel& model, const double* rod, std::size_t i, double* kinv) {
  const double EI = model.sub[5 * i + 1];
  const double GJ = model.sub[5 * i + 2];
  kinv[0] = 1.0 / EI;
  kinv[1] = 1.0 / EI;
  kinv[2] = 1.0 / GJ;
  kinv[3] = 1.0 / rod[0];
  kinv[4] = 1.0 / rod[0];
  kinv[5] = 1.0 / rod[1];
}

// The 12x12 state-transition matrix phi of one subsegment from the tangents Y (18, 9) at its end state y.
// Columns: start (dp, dtheta, dn, dm); rows: end (dp, dtheta, dn, dm); rotations as world-frame angles.
inline void transition(const double* y, const double* Y, double* phi) {
  for (int a = 0; a < 144; ++a) phi[a] = 0.0;
  for (int a = 0; a < 3; ++a) phi[13 * a] = 1.0;  // moving the start moves the end alike; nothing else depends on it
  const double* R = y + 3;
  for (int c = 0; c < 9; ++c) {
    const int col = 3 + c;
    for (int a = 0; a < 3; ++a) {
      phi[12 * a + col] = Y[9 * a + c];
      phi[12 * (6 + a) + col] = Y[9 * (12 + a) + c];
      phi[12 * (9 + a) + col] = Y[9 * (15 + a) + c];
    }
    // A = dR R^T (numba's '@': BLAS, see blas_dot3)
    double A[3][3];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        A[a][b] = blas_dot3(Y[9 * (3 + 3 * a) + c], R[3 * b], Y[9 * (4 + 3 * a) + c], R[3 * b + 1],
                            Y[9 * (5 + 3 * a) + c], R[3 * b + 2]);
    phi[12 * 3 + col] = 0.5 * (A[2][1] - A[1][2]);
    phi[12 * 4 + col] = 0.5 * (A[0][2] - A[2][0]);
    phi[12 * 5 + col] = 0.5 * (A[1][0] - A[0][1]);
  }
}

// The state y (18,) at the base of subsegment i (1-based): pose of disk i-1, wrench R_{i-1} (x_n / l_i, x_m),
// world.
inline void start_state(const double* q, const SscrModel& model, std::size_t i, const double* pos,
                        const double* rot, double* y) {
  const std::size_t k = 6 * (i - 1);
  const double ell = model.sub[5 * (i - 1)];
  const double* Rp = rot + 9 * (i - 1);
  for (int a = 0; a < 3; ++a) {
    y[a] = pos[3 * (i - 1) + a];
    y[12 + a] = (Rp[3 * a] * q[k] + Rp[3 * a + 1] * q[k + 1] + Rp[3 * a + 2] * q[k + 2]) / ell;
    y[15 + a] = Rp[3 * a] * q[k + 3] + Rp[3 * a + 1] * q[k + 4] + Rp[3 * a + 2] * q[k + 5];
    for (int b = 0; b < 3; ++b) y[3 + 3 * a + b] = Rp[3 * a + b];
  }
}

// Rewrite the wrench columns of phi for the local unknowns (l n, m) in the frame of disk i-1 (Rp): the world
// start wrench is R_{i-1} (x_n / l, x_m); turning disk i-1 by dtheta turns it by dtheta x.
inline void local_columns(const double* y0, const double* Rp, double ell, double* phi) {
  double col[12][6];
  for (int a = 0; a < 12; ++a)
    for (int b = 0; b < 6; ++b) col[a][b] = phi[12 * a + 6 + b];
  const double n0 = y0[12], n1 = y0[13], n2 = y0[14];
  const double m0 = y0[15], m1 = y0[16], m2 = y0[17];
  for (int a = 0; a < 12; ++a) {
    // d(start n) = dtheta x n = -[n]x dtheta; likewise m
    const double c0 = col[a][0], c1 = col[a][1], c2 = col[a][2];
    const double d0 = col[a][3], d1 = col[a][4], d2 = col[a][5];
    double* row = phi + 12 * a;
    row[3] += (n1 * c2 - n2 * c1) + (m1 * d2 - m2 * d1);
    row[4] += (n2 * c0 - n0 * c2) + (m2 * d0 - m0 * d2);
    row[5] += (n0 * c1 - n1 * c0) + (m0 * d1 - m1 * d0);
    for (int j = 0; j < 3; ++j) {
      row[6 + j] = (c0 * Rp[j] + c1 * Rp[3 + j] + c2 * Rp[6 + j]) / ell;
      row[9 + j] = d0 * Rp[j] + d1 * Rp[3 + j] + d2 * Rp[6 + j];
    }
  }
}

// Integrate every subsegment from the base: the poses, the end wrenches and, with want_jac, each subsegment's
// transition matrix phi; the relative transforms Rrel, drel. rod: the rod's 5 numbers (model.rod or a variant).
inline void chain(const double* q, double lam, const SscrModel& model, const double* rod, bool want_jac,
                  SscrWork& work) {
  const std::size_t n = model.n_disks;
  const long nsub = static_cast<long>(rod[4]);
  const bool ext = rod[3] > 0.5;
  double fw[3];
  for (int a = 0; a < 3; ++a) fw[a] = -lam * rod[2] * model.grav[a];
  double y[18], Y[18 * 9], y0[18], kinv[6];
  for (int a = 0; a < 18 * 9; ++a) Y[a] = 0.0;
  double* pos = work.pos.data();
  double* rot = work.rot.data();
  for (std::size_t i = 1; i <= n; ++i) {
    start_state(q, model, i, pos, rot, y);
    for (int a = 0; a < 18; ++a) y0[a] = y[a];
    const double* Rp = rot + 9 * (i - 1);
    if (want_jac) {
      for (int a = 0; a < 18 * 9; ++a) Y[a] = 0.0;
      for (int e = 0; e < 3; ++e) {  // rotation of the start by e: dR = [e_x] R
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) {
            double acc = 0.0;
            if (a == 0)
              acc = (e == 2 ? -Rp[3 + b] : 0.0) + (e == 1 ? Rp[6 + b] : 0.0);
            else if (a == 1)
              acc = (e == 2 ? Rp[b] : 0.0) - (e == 0 ? Rp[6 + b] : 0.0);
            else
              acc = (e == 1 ? -Rp[b] : 0.0) + (e == 0 ? Rp[3 + b] : 0.0);
            Y[9 * (3 + 3 * a + b) + e] = acc;
          }
        Y[9 * (12 + e) + 3 + e] = 1.0;
        Y[9 * (15 + e) + 6 + e] = 1.0;
      }
    }
    stiffness_inverse(model, rod, i - 1, kinv);
    integrate<9>(y, model.sub[5 * (i - 1)], nsub, kinv, ext, fw, want_jac, Y, nullptr, 0, 0);
    for (int a = 0; a < 3; ++a) {
      pos[3 * i + a] = y[a];
      work.wend[6 * i + a] = y[12 + a];
      work.wend[6 * i + 3 + a] = y[15 + a];
      for (int b = 0; b < 3; ++b) rot[9 * i + 3 * a + b] = y[3 + 3 * a + b];
    }
    if (want_jac) {
      double* phi = work.phi.data() + 144 * i;
      transition(y, Y, phi);
      local_columns(y0, Rp, model.sub[5 * (i - 1)], phi);
    }
    const double* Ri = rot + 9 * i;
    for (int a = 0; a < 3; ++a) {
      double acc = 0.0;
      for (int b = 0; b < 3; ++b) {
        work.Rrel[9 * i + 3 * a + b] = Rp[a] * Ri[b] + Rp[3 + a] * Ri[3 + b] + Rp[6 + a] * Ri[6 + b];
        acc += Rp[3 * b + a] * (pos[3 * i + b] - pos[3 * (i - 1) + b]);
      }
      work.drel[3 * i + a] = acc;
    }
  }
}

// S_i = d pose_i / d x and E_i = d wend_i / d x (6, m each), chained from the base.
inline void sensitivities(const SscrModel& model, SscrWork& work) {
  const std::size_t n = model.n_disks;
  const std::size_t m = 6 * n;
  double* S = work.S.data();
  double* E = work.E.data();
  for (std::size_t j = 0; j < 6 * m; ++j) {
    S[j] = 0.0;
    S[(n + 1) * 6 * m + j] = 0.0;
  }
  for (std::size_t i = 1; i <= n; ++i) {
    const std::size_t k = 6 * (i - 1);
    const double* P = work.phi.data() + 144 * i;
    const double* Sp = S + (i - 1) * 6 * m;
    double* Si = S + i * 6 * m;
    double* Ei = E + i * 6 * m;
    for (std::size_t a = 0; a < 6; ++a) {
      // per j < k: acc = 0, then acc += P[a, b] S_{i-1}[b, j] for b = 0..5, in numba's order; the loops swapped
      // (b outside) so that the compiler vectorizes over j
      double* Sa = Si + a * m;
      double* Ea = Ei + a * m;
      for (std::size_t j = 0; j < k; ++j) {
        Sa[j] = 0.0;
        Ea[j] = 0.0;
      }
      for (std::size_t b = 0; b < 6; ++b) {
        const double ps = P[12 * a + b], pe = P[12 * (6 + a) + b];
        const double* Sb = Sp + b * m;
        for (std::size_t j = 0; j < k; ++j) {
          Sa[j] += ps * Sb[j];
          Ea[j] += pe * Sb[j];
        }
      }
      for (std::size_t j = 0; j < 6; ++j) {
        Si[a * m + k + j] = P[12 * a + 6 + j];
        Ei[a * m + k + j] = P[12 * (6 + a) + 6 + j];
      }
      for (std::size_t j = k + 6; j < m; ++j) {
        Si[a * m + j] = 0.0;
        Ei[a * m + j] = 0.0;
      }
    }
  }
}

inline void cross_into(double a0, double a1, double a2, double b0, double b1, double b2, double* out) {
  out[0] = a1 * b2 - a2 * b1;
  out[1] = a2 * b0 - a0 * b2;
  out[2] = a0 * b1 - a1 * b0;
}

// Tangent lanes of the transform of subsegment i by the 18 pose lanes (disks i-1, i, i+1): lR (18, 3, 3),
// ld (18, 3).
inline void pose_lanes(const SscrWork& work, std::size_t i, double (*lR)[9], double (*ld)[3]) {
  const double* Rp = work.rot.data() + 9 * (i - 1);
  const double* Ri = work.rot.data() + 9 * i;
  for (int L = 0; L < kLanes; ++L) {
    for (int a = 0; a < 9; ++a) lR[L][a] = 0.0;
    for (int a = 0; a < 3; ++a) ld[L][a] = 0.0;
  }
  double dp[3];
  for (int a = 0; a < 3; ++a) dp[a] = work.pos[3 * i + a] - work.pos[3 * (i - 1) + a];
  for (int e = 0; e < 3; ++e) {
    // [e_x] Ri, then Rp^T of it: dRrel = Rp^T [dtheta_i - dtheta_{i-1}]x Ri; G = (Rp^T Ex) Ri (numba: BLAS)
    double Ex[3][3] = {{0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}};
    if (e == 0) {
      Ex[1][2] = -1.0;
      Ex[2][1] = 1.0;
    } else if (e == 1) {
      Ex[0][2] = 1.0;
      Ex[2][0] = -1.0;
    } else {
      Ex[0][1] = -1.0;
      Ex[1][0] = 1.0;
    }
    double M[3][3], G[3][3];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) M[a][b] = blas_dot3(Rp[a], Ex[0][b], Rp[3 + a], Ex[1][b], Rp[6 + a], Ex[2][b]);
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) G[a][b] = blas_dot3(M[a][0], Ri[b], M[a][1], Ri[3 + b], M[a][2], Ri[6 + b]);
    double ex[3] = {0.0, 0.0, 0.0};
    ex[e] = 1.0;
    double cr[3];
    cross_into(ex[0], ex[1], ex[2], dp[0], dp[1], dp[2], cr);
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) {
        lR[3 + e][3 * a + b] = -G[a][b];
        lR[9 + e][3 * a + b] = G[a][b];
      }
      ld[e][a] = -Rp[3 * e + a];
      ld[6 + e][a] = Rp[3 * e + a];
      ld[3 + e][a] = -(Rp[a] * cr[0] + Rp[3 + a] * cr[1] + Rp[6 + a] * cr[2]);
    }
  }
}

// Tangent lanes lh (18, 3) of the next hole (on disk i+1, in frame i) by the 18 pose lanes.
inline void hole_lanes(const SscrWork& work, std::size_t i, double px, double py, double (*lh)[3]) {
  const double* Ri = work.rot.data() + 9 * i;
  const double* Rn = work.rot.data() + 9 * (i + 1);
  for (int L = 0; L < kLanes; ++L)
    for (int a = 0; a < 3; ++a) lh[L][a] = 0.0;
  double hw[3];  // R_{i+1} r, world
  double w[3];   // p_{i+1} + R_{i+1} r - p_i, world
  for (int a = 0; a < 3; ++a) {
    hw[a] = Rn[3 * a] * px + Rn[3 * a + 1] * py;
    w[a] = work.pos[3 * (i + 1) + a] + hw[a] - work.pos[3 * i + a];
  }
  double cr[3];
  for (int e = 0; e < 3; ++e) {
    double ex[3] = {0.0, 0.0, 0.0};
    ex[e] = 1.0;
    for (int a = 0; a < 3; ++a) {
      lh[6 + e][a] = -Ri[3 * e + a];
      lh[12 + e][a] = Ri[3 * e + a];
    }
    cross_into(ex[0], ex[1], ex[2], hw[0], hw[1], hw[2], cr);
    for (int a = 0; a < 3; ++a) lh[15 + e][a] = Ri[a] * cr[0] + Ri[3 + a] * cr[1] + Ri[6 + a] * cr[2];
    cross_into(ex[0], ex[1], ex[2], w[0], w[1], w[2], cr);
    for (int a = 0; a < 3; ++a) lh[9 + e][a] = -(Ri[a] * cr[0] + Ri[3 + a] * cr[1] + Ri[6 + a] * cr[2]);
  }
}

// Tensions piece by piece (friction from the base on) T (N+2, nt) [N], with want_jac their derivatives dT by x;
// every tendon's unit load at every disk W and its lanes dW.
inline void tendons(double lam, const SscrModel& model, bool want_jac, SscrWork& work) {
  const std::size_t n = model.n_disks;
  const std::size_t nt = model.n_tendons;
  const std::size_t m = 6 * n;
  double* T = work.T.data();
  double* dT = work.dT.data();
  double* W = work.W.data();
  double* dW = work.dW.data();
  const double* S = work.S.data();
  double lR[kLanes][9] = {};
  double ld[kLanes][3] = {};
  double lh[kLanes][3] = {};
  double hn[3] = {0.0, 0.0, 0.0};
  double out[7];
  const std::size_t dWc = 7 * kLanes;  // numbers of one tendon's dW at one disk
  for (std::size_t c = 0; c < nt; ++c) {
    T[nt + c] = lam * model.tension[c];
    if (want_jac)
      for (std::size_t j = 0; j < m; ++j) dT[(nt + c) * m + j] = 0.0;
  }
  for (std::size_t i = 1; i <= n; ++i) {
    if (want_jac) pose_lanes(work, i, lR, ld);
    for (std::size_t c = 0; c < nt; ++c) {
      const long anc = model.anchor[c];
      double* Wic = W + (i * nt + c) * 7;
      double* dTn = dT + ((i + 1) * nt + c) * m;
      if (static_cast<long>(i) > anc) {
        for (int u = 0; u < 7; ++u) Wic[u] = 0.0;
        T[(i + 1) * nt + c] = 0.0;
        if (want_jac)
          for (std::size_t j = 0; j < m; ++j) dTn[j] = 0.0;
        continue;
      }
      const bool is_anchor = static_cast<long>(i) == anc;
      const double px = model.holes[2 * c];
      const double py = model.holes[2 * c + 1];
      if (!is_anchor) {
        const double* Rn = work.Rrel.data() + 9 * (i + 1);
        for (int a = 0; a < 3; ++a) hn[a] = Rn[3 * a] * px + Rn[3 * a + 1] * py + work.drel[3 * (i + 1) + a];
        if (want_jac) hole_lanes(work, i, px, py, lh);
      }
      const int nl = want_jac ? kLanes : 0;
      double* dWic = dW + (i * nt + c) * dWc;
      tendon_unit_load_jvp(work.Rrel.data() + 9 * i, work.drel.data() + 3 * i, hn, lR, ld, lh, nl, px, py,
                           is_anchor, model.fric.data(), out, dWic, kLanes);
      for (int u = 0; u < 7; ++u) Wic[u] = out[u];
      const double rho = out[6];
      T[(i + 1) * nt + c] = !is_anchor ? rho * T[i * nt + c] : 0.0;
      if (want_jac) {
        if (is_anchor) {
          for (std::size_t j = 0; j < m; ++j) dTn[j] = 0.0;
        } else {
          const double Ti = T[i * nt + c];
          const double* dTi = dT + (i * nt + c) * m;
          const double* dr = dWic + 6 * kLanes;  // d rho by the lanes
          const double* Sp = S + (i - 1) * 6 * m;
          const double* Si = S + i * 6 * m;
          const double* Sn = S + (i + 1) * 6 * m;
          // per j: acc = rho dT_i[j], then acc += T_i (...) for L = 0..5, in numba's order; the loops swapped
          // (L outside) so that the compiler vectorizes over j. Columns j >= 6(i+1) of S_{i-1}, S_i, S_{i+1} and
          // dT_i are exact +0, so there numba's sum is +0 whenever these factors are finite: written directly.
          const std::size_t jmax = all_finite(dr, kLanes) && std::isfinite(rho) && std::isfinite(Ti)
                                       ? std::min(m, 6 * (i + 1)) : m;
          for (std::size_t j = 0; j < jmax; ++j) dTn[j] = rho * dTi[j];
          for (std::size_t L = 0; L < 6; ++L) {
            const double a0 = dr[L], a1 = dr[6 + L], a2 = dr[12 + L];
            const double* s0 = Sp + L * m;
            const double* s1 = Si + L * m;
            const double* s2 = Sn + L * m;
            for (std::size_t j = 0; j < jmax; ++j) dTn[j] += Ti * (a0 * s0[j] + a1 * s1[j] + a2 * s2[j]);
          }
          for (std::size_t j = jmax; j < m; ++j) dTn[j] = 0.0;
        }
      }
    }
  }
}

// The change of d_rel (frame i-1) along pose lane L < 12 (disks i-1 and i), into dd (3,).
inline void ddrel(const SscrWork& work, std::size_t i, int L, double* dd) {
  const double* Rp = work.rot.data() + 9 * (i - 1);
  if (L < 3) {
    dd[0] = -Rp[3 * L];
    dd[1] = -Rp[3 * L + 1];
    dd[2] = -Rp[3 * L + 2];
    return;
  }
  if (L < 6) {
    const int e = L - 3;
    const double dp0 = work.pos[3 * i] - work.pos[3 * (i - 1)];
    const double dp1 = work.pos[3 * i + 1] - work.pos[3 * (i - 1) + 1];
    const double dp2 = work.pos[3 * i + 2] - work.pos[3 * (i - 1) + 2];
    double c0, c1, c2;
    if (e == 0) {
      c0 = 0.0;
      c1 = -dp2;
      c2 = dp1;
    } else if (e == 1) {
      c0 = dp2;
      c1 = 0.0;
      c2 = -dp0;
    } else {
      c0 = -dp1;
      c1 = dp0;
      c2 = 0.0;
    }
    dd[0] = -(Rp[0] * c0 + Rp[3] * c1 + Rp[6] * c2);
    dd[1] = -(Rp[1] * c0 + Rp[4] * c1 + Rp[7] * c2);
    dd[2] = -(Rp[2] * c0 + Rp[5] * c1 + Rp[8] * c2);
    return;
  }
  if (L < 9) {
    const int e = L - 6;
    dd[0] = Rp[3 * e];
    dd[1] = Rp[3 * e + 1];
    dd[2] = Rp[3 * e + 2];
    return;
  }
  dd[0] = 0.0;
  dd[1] = 0.0;
  dd[2] = 0.0;
}

// The load on disk i (world, about its centre): load (6,) [N, N m]; with want_jac, its local derivative A (6, 18)
// by the pose lanes (tendon geometry) and, in work.dD (6, m), the part through the tensions.
inline void disk_load(std::size_t i, double lam, const SscrModel& model, bool want_jac, SscrWork& work,
                      double* load, double (*A)[kLanes]) {
  const std::size_t nt = model.n_tendons;
  const std::size_t m = 6 * model.n_disks;
  const double* Rp = work.rot.data() + 9 * (i - 1);
  const double* d = work.drel.data() + 3 * i;
  const double md = model.sub[5 * (i - 1) + 3];
  for (int a = 0; a < 3; ++a) {
    load[a] = lam * (md * model.grav[a] + model.pforce[3 * (i - 1) + a]);
    load[3 + a] = lam * model.pmoment[3 * (i - 1) + a];
  }
  double* dD = work.dD.data();
  if (want_jac) {
    for (int a = 0; a < 6; ++a)
      for (int L = 0; L < kLanes; ++L) A[a][L] = 0.0;
    for (std::size_t j = 0; j < 6 * m; ++j) dD[j] = 0.0;
  }
  double Fl[3], Ml[3], Fw[3], Mw[3];
  for (std::size_t c = 0; c < nt; ++c) {
    if (static_cast<long>(i) > model.anchor[c]) continue;
    const double Tc = work.T[i * nt + c];
    const double* Wc = work.W.data() + (i * nt + c) * 7;
    // the unit load in frame i-1 about disk i's centre, then in the world frame
    for (int a = 0; a < 3; ++a) Fl[a] = Wc[a];
    Ml[0] = Wc[3] - (d[1] * Wc[2] - d[2] * Wc[1]);
    Ml[1] = Wc[4] - (d[2] * Wc[0] - d[0] * Wc[2]);
    Ml[2] = Wc[5] - (d[0] * Wc[1] - d[1] * Wc[0]);
    for (int a = 0; a < 3; ++a) {
      Fw[a] = Rp[3 * a] * Fl[0] + Rp[3 * a + 1] * Fl[1] + Rp[3 * a + 2] * Fl[2];
      Mw[a] = Rp[3 * a] * Ml[0] + Rp[3 * a + 1] * Ml[1] + Rp[3 * a + 2] * Ml[2];
      load[a] += Tc * Fw[a];
      load[3 + a] += Tc * Mw[a];
    }
    if (!want_jac) continue;
    const double* dTc = work.dT.data() + (i * nt + c) * m;
    for (std::size_t j = 0; j < m; ++j) {
      const double g = dTc[j];
      if (g != 0.0)
        for (int a = 0; a < 3; ++a) {
          dD[a * m + j] += Fw[a] * g;
          dD[(3 + a) * m + j] += Mw[a] * g;
        }
    }
    const double* dWc = work.dW.data() + (i * nt + c) * 7 * kLanes;
    for (int L = 0; L < kLanes; ++L) {
      // the local change of the unit load in frame i-1 (about disk i), rotated to the world
      const double dfl0 = dWc[L], dfl1 = dWc[kLanes + L], dfl2 = dWc[2 * kLanes + L];
      double dd[3] = {0.0, 0.0, 0.0};
      if (L < 12) ddrel(work, i, L, dd);
      const double dml0 = dWc[3 * kLanes + L] - (dd[1] * Fl[2] - dd[2] * Fl[1]) - (d[1] * dfl2 - d[2] * dfl1);
      const double dml1 = dWc[4 * kLanes + L] - (dd[2] * Fl[0] - dd[0] * Fl[2]) - (d[2] * dfl0 - d[0] * dfl2);
      const double dml2 = dWc[5 * kLanes + L] - (dd[0] * Fl[1] - dd[1] * Fl[0]) - (d[0] * dfl1 - d[1] * dfl0);
      for (int a = 0; a < 3; ++a) {
        const double dfw = Rp[3 * a] * dfl0 + Rp[3 * a + 1] * dfl1 + Rp[3 * a + 2] * dfl2;
        const double dmw = Rp[3 * a] * dml0 + Rp[3 * a + 1] * dml1 + Rp[3 * a + 2] * dml2;
        A[a][L] += Tc * dfw;
        A[3 + a][L] += Tc * dmw;
      }
      if (3 <= L && L < 6) {  // rotating disk i-1 rotates the frame the load was written in
        const int e = L - 3;
        double ex[3] = {0.0, 0.0, 0.0};
        ex[e] = 1.0;
        double cr[3];
        cross_into(ex[0], ex[1], ex[2], Fw[0], Fw[1], Fw[2], cr);
        for (int a = 0; a < 3; ++a) A[a][L] += Tc * cr[a];
        cross_into(ex[0], ex[1], ex[2], Mw[0], Mw[1], Mw[2], cr);
        for (int a = 0; a < 3; ++a) A[3 + a][L] += Tc * cr[a];
      }
    }
  }
}

// evaluate with the rod's numbers from rod (5,) rather than model.rod (tangent_stiffness's extensible rod).
inline void evaluate_rod(const double* q, double lam, const SscrModel& model, const double* rod, bool want_jac,
                         double* r, double* J, SscrWork& work) {
  const std::size_t n = model.n_disks;
  const std::size_t m = 6 * n;
  const double* sub = model.sub.data();
  chain(q, lam, model, rod, want_jac, work);
  if (want_jac) sensitivities(model, work);
  tendons(lam, model, want_jac, work);
  double load[6], u[6];
  double A[6][kLanes] = {};
  double* G = work.G.data();
  const double* S = work.S.data();
  const double* E = work.E.data();
  const double* dD = work.dD.data();
  for (std::size_t i = 1; i <= n; ++i) {
    const std::size_t k = 6 * (i - 1);
    const double ell = sub[5 * (i - 1)];
    const double* Ri = work.rot.data() + 9 * i;
    disk_load(i, lam, model, want_jac, work, load, A);
    for (int a = 0; a < 6; ++a) u[a] = work.wend[6 * i + a] - load[a];  // what disk i leaves for the next one
    for (int a = 0; a < 3; ++a)
      for (int h = 0; h < 2; ++h) {
        const int o = 3 * h;
        double val = Ri[a] * u[o] + Ri[3 + a] * u[o + 1] + Ri[6 + a] * u[o + 2];
        if (i < n) val -= h == 0 ? q[k + 6 + o + a] / sub[5 * i] : q[k + 6 + o + a];
        r[k + o + a] = h == 0 ? ell * val : val;
      }
    if (!want_jac) continue;
    // G = d u / d x (world), then rows R_i^T (G + u x dtheta_i)
    const double* Sp = S + (i - 1) * 6 * m;
    const double* Si = S + i * 6 * m;
    const double* Sn = S + (i + 1) * 6 * m;
    const double* Ei = E + i * 6 * m;
    // Columns j >= 6(i+1) of E_i, dD, S_{i-1}, S_i and S_{i+1} are exact +0, so there G is +0 and J's row a is
    // scale (R_i[0,a] 0 + R_i[1,a] 0 + R_i[2,a] 0) (a signed zero) whenever A, u and R_i are finite: written
    // directly.
    const std::size_t jmax = all_finite(&A[0][0], 6 * kLanes) && all_finite(u, 6) && all_finite(Ri, 9)
                                 ? std::min(m, 6 * (i + 1)) : m;
    // per (a, j): acc = E - dD, then acc -= (...) for L = 0..5, in numba's order; the loops swapped (L outside j)
    // so that the compiler vectorizes over j
    for (std::size_t a = 0; a < 6; ++a) {
      double* Ga = G + a * m;
      for (std::size_t j = 0; j < jmax; ++j) Ga[j] = Ei[a * m + j] - dD[a * m + j];
      for (std::size_t L = 0; L < 6; ++L) {
        const double a0 = A[a][L], a1 = A[a][6 + L], a2 = A[a][12 + L];
        const double* s0 = Sp + L * m;
        const double* s1 = Si + L * m;
        const double* s2 = Sn + L * m;
        for (std::size_t j = 0; j < jmax; ++j) Ga[j] -= a0 * s0[j] + a1 * s1[j] + a2 * s2[j];
      }
    }
    for (int h = 0; h < 2; ++h) {
      const int o = 3 * h;
      const double u0 = u[o], u1 = u[o + 1], u2 = u[o + 2];
      const double scale = h == 0 ? ell : 1.0;
      for (int a = 0; a < 3; ++a) {
        const double zero = scale * (Ri[a] * 0.0 + Ri[3 + a] * 0.0 + Ri[6 + a] * 0.0);
        for (std::size_t j = jmax; j < m; ++j) J[(k + o + a) * m + j] = zero;
      }
      for (std::size_t j = 0; j < jmax; ++j) {
        const double t0 = Si[3 * m + j], t1 = Si[4 * m + j], t2 = Si[5 * m + j];
        const double g0 = G[o * m + j] + u1 * t2 - u2 * t1;
        const double g1 = G[(o + 1) * m + j] + u2 * t0 - u0 * t2;
        const double g2 = G[(o + 2) * m + j] + u0 * t1 - u1 * t0;
        for (int a = 0; a < 3; ++a) J[(k + o + a) * m + j] = scale * (Ri[a] * g0 + Ri[3 + a] * g1 + Ri[6 + a] * g2);
      }
      if (i < n)
        for (int a = 0; a < 3; ++a) J[(k + o + a) * m + k + 6 + o + a] -= h == 0 ? scale / sub[5 * i] : scale;
    }
  }
}

}  // namespace sscr_detail

// Residual r (6N,) [N m] and, if want_jac, its Jacobian J (6N, 6N) row-major; every load scaled by lam. No heap
// allocation: the scratch is work's (make_work(model)).
inline void evaluate(const double* q, double lam, const SscrModel& model, bool want_jac, double* r, double* J,
                     SscrWork& work) {
  sscr_detail::evaluate_rod(q, lam, model, model.rod.data(), want_jac, r, J, work);
}

// Disk poses pos (N+1, 3) [m], rot (N+1, 3, 3) and backbone points curve (N nsub + 1, 3) [m] at q.
inline void record_shape(const double* q, const SscrModel& model, double* pos, double* rot, double* curve) {
  using namespace sscr_detail;
  SscrWork work = make_work(model);
  const std::size_t n = model.n_disks;
  const double* rod = model.rod.data();
  chain(q, 1.0, model, rod, false, work);
  const long nsub = static_cast<long>(rod[4]);
  const bool ext = rod[3] > 0.5;
  double fw[3];
  for (int a = 0; a < 3; ++a) fw[a] = -rod[2] * model.grav[a];
  double y[18], Y[18] = {}, kinv[6];
  const std::size_t rows = n * static_cast<std::size_t>(nsub) + 1;
  for (int a = 0; a < 3; ++a) curve[a] = 0.0;
  std::size_t ic = 1;
  for (std::size_t i = 1; i <= n; ++i) {
    start_state(q, model, i, work.pos.data(), work.rot.data(), y);
    stiffness_inverse(model, rod, i - 1, kinv);
    ic = integrate<1>(y, model.sub[5 * (i - 1)], nsub, kinv, ext, fw, false, Y, curve, rows, ic);
  }
  for (std::size_t j = 0; j < (n + 1) * 3; ++j) pos[j] = work.pos[j];
  for (std::size_t j = 0; j < (n + 1) * 9; ++j) rot[j] = work.rot[j];
}

// Base wrenches q (6N,) that balance every disk at the given poses pos (N+1, 3) [m], rot (N+1, 3, 3): each disk's
// load follows from the poses; the internal wrench at the base of subsegment i is everything beyond it, the
// backbone's weight taken at the chords' midpoints.
inline void wrenches_from_poses(const double* pos, const double* rot, const SscrModel& model, double* q) {
  using namespace sscr_detail;
  const std::size_t n = model.n_disks;
  SscrWork work = make_work(model);
  for (std::size_t j = 0; j < (n + 1) * 3; ++j) work.pos[j] = pos[j];
  for (std::size_t j = 0; j < (n + 1) * 9; ++j) work.rot[j] = rot[j];
  for (std::size_t i = 1; i <= n; ++i) {
    const double* Rp = rot + 9 * (i - 1);
    const double* Ri = rot + 9 * i;
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b)
        work.Rrel[9 * i + 3 * a + b] = Rp[a] * Ri[b] + Rp[3 + a] * Ri[3 + b] + Rp[6 + a] * Ri[6 + b];
      work.drel[3 * i + a] = Rp[a] * (pos[3 * i] - pos[3 * (i - 1)]) +
                             Rp[3 + a] * (pos[3 * i + 1] - pos[3 * (i - 1) + 1]) +
                             Rp[6 + a] * (pos[3 * i + 2] - pos[3 * (i - 1) + 2]);
    }
  }
  tendons(1.0, model, false, work);
  std::vector<double> loads((n + 1) * 6, 0.0);
  double A[6][kLanes] = {};
  for (std::size_t i = 1; i <= n; ++i) disk_load(i, 1.0, model, false, work, loads.data() + 6 * i, A);
  double F[3] = {0.0, 0.0, 0.0};
  double M[3] = {0.0, 0.0, 0.0};  // about the current point, world
  const double* g = model.grav.data();
  for (std::size_t i = n; i >= 1; --i) {
    // move the moment from p_i to p_{i-1}: M <- M + (p_i - p_{i-1}) x F, after adding disk i's load
    for (int a = 0; a < 3; ++a) {
      F[a] += loads[6 * i + a];
      M[a] += loads[6 * i + 3 + a];
    }
    const double d0 = pos[3 * i] - pos[3 * (i - 1)];
    const double d1 = pos[3 * i + 1] - pos[3 * (i - 1) + 1];
    const double d2 = pos[3 * i + 2] - pos[3 * (i - 1) + 2];
    const double mb = model.sub[5 * (i - 1) + 4];
    const double wb[3] = {mb * g[0], mb * g[1], mb * g[2]};  // the backbone piece's weight, at the chord's midpoint
    M[0] += d1 * F[2] - d2 * F[1] + 0.5 * (d1 * wb[2] - d2 * wb[1]);
    M[1] += d2 * F[0] - d0 * F[2] + 0.5 * (d2 * wb[0] - d0 * wb[2]);
    M[2] += d0 * F[1] - d1 * F[0] + 0.5 * (d0 * wb[1] - d1 * wb[0]);
    for (int a = 0; a < 3; ++a) F[a] += wb[a];
    const std::size_t k = 6 * (i - 1);
    const double ell = model.sub[5 * (i - 1)];
    const double* Rp = rot + 9 * (i - 1);
    for (int a = 0; a < 3; ++a) {
      q[k + a] = ell * (Rp[a] * F[0] + Rp[3 + a] * F[1] + Rp[6 + a] * F[2]);
      q[k + 3 + a] = Rp[a] * M[0] + Rp[3 + a] * M[1] + Rp[6 + a] * M[2];
    }
  }
}

// The tangent stiffness K (6N, 6N) [N m], row-major, of the disks' poses at the equilibrium q (6N,): K = B P^-1
// with B = dr/dx, each disk's rows turned to the world (R_i r_i), and P = d pose / dx (positions divided by l_i,
// rotation angles), the rod evaluated with its real axial and shear stiffness (EA, GA; MODEL.md, appendix B).
// Solves P^T (row a of K)^T = (row a of B)^T, a = 0..6N-1, by linalg.hpp's LU with partial pivoting (numba: one
// np.linalg.solve, LAPACK); throws std::runtime_error where P is exactly singular (numba: LinAlgError).
inline void tangent_stiffness(const double* q, const SscrModel& model, SscrWork& work, double* K) {
  using namespace sscr_detail;
  const std::size_t n = model.n_disks;
  const std::size_t m = 6 * n;
  double rod[5];
  for (int a = 0; a < 5; ++a) rod[a] = model.rod[a];
  rod[3] = 1.0;
  work.ts_r.resize(m);
  work.ts_J.resize(m * m);
  work.ts_P.resize(m * m);
  work.ts_piv.resize(m);
  double* J = work.ts_J.data();
  evaluate_rod(q, 1.0, model, rod, true, work.ts_r.data(), J, work);
  double* Pt = work.ts_P.data();  // P^T (m, m)
  const double* S = work.S.data();
  for (std::size_t i = 1; i <= n; ++i) {
    const std::size_t k = 6 * (i - 1);
    const double* Ri = work.rot.data() + 9 * i;
    const double ell = model.sub[5 * (i - 1)];
    for (int h = 0; h < 2; ++h) {  // B into K (m, m): rows o..o+2 = R_i (rows o..o+2 of J)
      const std::size_t o = k + 3 * h;
      for (int a = 0; a < 3; ++a)
        for (std::size_t j = 0; j < m; ++j)
          K[(o + a) * m + j] = Ri[3 * a] * J[o * m + j] + Ri[3 * a + 1] * J[(o + 1) * m + j] +
                               Ri[3 * a + 2] * J[(o + 2) * m + j];
    }
    for (std::size_t a = 0; a < 6; ++a)
      for (std::size_t j = 0; j < m; ++j) {
        const double s = S[(i * 6 + a) * m + j];
        Pt[j * m + k + a] = a < 3 ? s / ell : s;
      }
  }
  // K P = B  <=>  P^T K^T = B^T: one LU of P^T, then each row of B (a column of B^T) solved in place
  double sign;
  if (!lu_factor(Pt, m, Pt, work.ts_piv.data(), sign))
    throw std::runtime_error("tangent_stiffness: the pose sensitivities are singular");
  for (std::size_t a = 0; a < m; ++a) lu_solve(Pt, work.ts_piv.data(), m, K + a * m);
}

// For k in [start, stop): tangent_stiffness at the equilibrium q[rows[k]] (B, 6N) of model at the actuator
// tensions tensions[rows[k]] (B, nt) [N], into out[k - start] (stop - start, 6N, 6N).
inline void stiffness_range(const double* q, const SscrModel& model, const double* tensions, const long* rows,
                            std::size_t start, std::size_t stop, double* out) {
  SscrWork work = make_work(model);
  SscrModel at = model;
  const std::size_t m = model.n_unknowns();
  const std::size_t nt = model.n_tendons;
  for (std::size_t k = start; k < stop; ++k) {
    const std::size_t b = static_cast<std::size_t>(rows[k]);
    with_tension(model, tensions + b * nt, at);
    tangent_stiffness(q + b * m, at, work, out + (k - start) * m * m);
  }
}

// The tip's exact derivative by the unknowns, out (3, 6N) row-major: the chained sensitivity work.S[N, :3] of the
// evaluation with the Jacobian at q that work holds (as the numba kernel, it reads work and does not evaluate).
inline void tip_jacobian_of(const double* q, const SscrModel& model, SscrWork& work, double* out) {
  (void)q;
  const std::size_t n = model.n_disks;
  const std::size_t m = 6 * n;
  for (std::size_t j = 0; j < 3 * m; ++j) out[j] = work.S[n * 6 * m + j];
}

}  // namespace pytdcr
