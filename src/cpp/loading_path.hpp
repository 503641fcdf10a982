// The solver every PCC-family model shares: the C++ twin of src/pytdcr/statics/kernels/loading_path.py, operation
// for operation and in the same order (newton with its Broyden updates, relax, arclength, the follower, the
// snap-through flow, solve_one, solve_range), templated on the packed-model type instead of numba's overloads.
//
// A packed model type Model is solved through these functions, found by argument-dependent lookup in Model's
// namespace (the PCC model's are in src/cpp/pcc.hpp):
//   make_work(model) -> scratch                     (the model's evaluate work)
//   evaluate(q, lam, model, want_jac, r, J, work)   residual r (m,) [N m] and, with want_jac, J (m, m) row-major
//   largest_angle(dq, model)                        largest bend or twist change of one subsegment [rad]
//   with_tension(model, tension, out)               out = model with other actuator tensions (nt,) [N]
//   blend(a, b, s, out)                             out = b under the loads (1 - s) a + s b
// and model.n_unknowns() (m). Unknowns q and residual r have the model's own layout.
//
// The dense linear algebra (numba's LAPACK calls) is linalg.hpp's LU, and the quasi-Newton inverse Jacobian is
// kept as LU factors with Broyden's corrections in product form (InverseJacobian) where the numba code forms and
// updates an explicit inverse: the same iteration in exact arithmetic, so results agree with the numba solver's to
// round-off, not bit for bit. Every scratch array is in SolverWork, made once per solve_range.
#pragma once

#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "linalg.hpp"

namespace pytdcr {
namespace loading_path {

// ------------------------------------------------------------------ codes shared with the Python side
// (src/pytdcr/statics/options.py: the SolvePath codes, the fold handling and the continuation's stepping code)
inline constexpr long PATH_DIRECT = 0;
inline constexpr long PATH_LOADING = 1;
inline constexpr long PATH_SNAP = 2;
inline constexpr long PATH_FALLBACK = 3;
inline constexpr long PATH_CONTINUED = 4;
inline constexpr long PATH_FOLD = 5;
inline constexpr long FOLD_RELAX = 0;      // at a fold, relax at full load from the last equilibrium
inline constexpr long FOLD_ARCLENGTH = 1;  // at a fold, follow the equilibrium curve through its turning points
inline constexpr long FOLD_STOP = 2;       // at a fold, stop: not converged, path PATH_FOLD
inline constexpr long STEP_CONTINUE = 3;   // stepping code of a continuation from a solved state

// ------------------------------------------------------------------ constants (the Python module's, same names)
inline constexpr long STALL = 15;               // Newton gives up after this many iterations without halving |r|
inline constexpr double MAX_DLAM = 0.25;        // largest load step
inline constexpr double STEP_TARGET = 0.05;     // [rad] bend/twist change of a subsegment a load step aims at
inline constexpr double MAX_STEP_CHANGE = 0.1;  // [rad] largest bend/twist change in one load step (else a jump)
inline constexpr long ARC_STEPS = 300;          // pseudo-arclength steps allowed through a fold
inline constexpr long STEP_JACOBIANS = 2;       // exact Jacobians a load step may take before it is halved instead
inline constexpr long UNLIMITED = 1L << 30;
inline constexpr bool FRESH = false;  // newton's reuse: start from the exact Jacobian
inline constexpr long WALKS = 3;      // loading paths walked at most, each with load steps four times finer
inline constexpr double SNAP_DLAM = 1.0 / 128.0;  // how far past a fold's load factor the snap-through is relaxed
inline constexpr double FOLD_H = 1e-4;            // a follower's load step this small that still fails: a fold
inline constexpr double FOLLOW_THETA = 0.5;       // a follower's step contracting worse than this is too long
inline constexpr long FOLLOW_STEPS = 200;         // load steps allowed to the follower between two folds
inline constexpr long MAX_FOLDS = 6;              // snap-throughs allowed on the way to full load
inline constexpr long FLOW_STEPS = 300;           // implicit Euler steps of one snap-through (at most 6 max_iter)
inline constexpr double FLOW_CAP = 1.0;           // largest pseudo-time step while the flow's residual grows
inline constexpr double INF = std::numeric_limits<double>::infinity();

// Solver settings: tolerance [N m], Newton iterations, step limit [rad], load-stepping code (0 Newton only,
// 1 Newton then the loading path, 2 the loading path, STEP_CONTINUE), iterations per load step, what to do at a
// fold (FOLD_*), tolerance of intermediate load steps [N m], scale of the loading path's step target and largest
// step. solve_range replaces both tolerances by each case's own.
struct Settings {
  double atol;
  long max_iter;
  double max_dtheta;
  long stepping;
  long step_iter;
  long fold;
  double step_atol;
  double step_scale;
};

// What solve_one returns (the unknowns reached are written to its q).
struct Outcome {
  bool converged;
  double residual;  // max |residual| [N m]
  long iterations;  // Newton iterations in all
  long jacobians;   // exact Jacobian evaluations
  long load_steps;
  long path;  // a PATH_* code
};

// The path of the loads as the load factor lam goes from 0 to 1. With ramp (a solve: start is end) every load of
// end is scaled by lam; without (a continuation) the loads move along the straight path from start (lam = 0) to
// end (lam = 1).
template <class Model>
struct Homotopy {
  const Model* start;
  const Model* end;
  bool ramp;
};

// What one solve spent (solve_range's optional profile): the model's residual-only and Jacobian evaluations, the
// dense LU factorisations (of the Jacobian, of its bordered and damped forms), and, when timed, the seconds in
// each and in all.
struct Profile {
  bool timed = false;
  long residuals = 0;
  long jacobians = 0;
  long factorisations = 0;
  double residual_s = 0.0;
  double jacobian_s = 0.0;
  double linalg_s = 0.0;
  double total_s = 0.0;
};

using Clock = std::chrono::steady_clock;

// The seconds since t0 (a Clock time).
inline double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// The inverse Jacobian H of the quasi-Newton iteration, kept as the LU factors of an exact Jacobian J (of J^T:
// linalg.hpp's solve_by_transpose, O(b n^2) where J is block lower Hessenberg, as the subsegment rod's is) and the
// rank-one corrections of Broyden's ("good") updates since, in product form:
//
//     H = (I + w_k s_k^T) ... (I + w_1 s_1^T) J^-1,
//
// so that H r costs one forward and back substitution (2 n^2) plus 2 n per correction, and an update 2 n: no
// explicit inverse (2 n^3, twice the factorisation) and no dense rank-one update (2 n^2 each). Where J is not
// finite or exactly singular, H is zero (as the dense code's H = 0 when inv(J) raised), and stays zero under
// updates (s^T H y = 0).
struct InverseJacobian {
  std::size_t n = 0;
  std::vector<double> lu;         // (n, n) the factors of J^T
  std::vector<std::size_t> piv;   // (n,) its row interchanges
  double sign = 0.0;              // sign of det J (0 where J is singular or not finite)
  bool ok = false;                // H = J^-1 (false: H = 0)
  std::vector<double> ws, ss;     // (k, n) each: the corrections' w_j and s_j
  std::size_t k = 0;              // corrections held

  explicit InverseJacobian(std::size_t size = 0)
      : n(size), lu(size * size, 0.0), piv(size, 0), ws(16 * size, 0.0), ss(16 * size, 0.0) {}

  // H = J^-1 (J (n, n) row-major), no corrections. False (H = 0, sign 0) where J has a non-finite entry or an
  // exactly zero pivot. sign is that of det J (its permutation's times its pivots').
  bool factor(const double* J) {
    k = 0;
    ok = all_finite(J, n * n);
    if (ok) {
      transpose_into(J, n, lu.data());
      ok = lu_factor(lu.data(), n, lu.data(), piv.data(), sign);
    }
    if (!ok) {
      sign = 0.0;
      return false;
    }
    for (std::size_t i = 0; i < n; ++i) {
      const double d = lu[i * n + i];
      if (!std::isfinite(d)) sign = 0.0;
      if (d < 0.0) sign = -sign;
    }
    return true;
  }

  // True when H = J^-1 is usable to full precision: factored, its factors finite and every pivot's reciprocal
  // finite (the dense inverse would have been finite).
  bool finite() const {
    if (!ok || !all_finite(lu.data(), n * n)) return false;
    for (std::size_t i = 0; i < n; ++i)
      if (!std::isfinite(1.0 / lu[i * n + i])) return false;
    return true;
  }

  // out (n,) = H r (out may be r).
  void apply(const double* r, double* out) const {
    if (!ok) {
      for (std::size_t u = 0; u < n; ++u) out[u] = 0.0;
      return;
    }
    if (out != r)
      for (std::size_t u = 0; u < n; ++u) out[u] = r[u];
    lu_solve_transposed(lu.data(), piv.data(), n, out);
    for (std::size_t j = 0; j < k; ++j) {
      const double* sj = ss.data() + j * n;
      const double* wj = ws.data() + j * n;
      double c = 0.0;
      for (std::size_t u = 0; u < n; ++u) c += sj[u] * out[u];
      for (std::size_t u = 0; u < n; ++u) out[u] += c * wj[u];
    }
  }

  // H <- (I + w s^T) H: append one correction (w, s, each (n,)).
  void push(const double* w, const double* s) {
    if ((k + 1) * n > ws.size()) {
      ws.resize(2 * (k + 1) * n);
      ss.resize(2 * (k + 1) * n);
    }
    std::copy(w, w + n, ws.data() + k * n);
    std::copy(s, s + n, ss.data() + k * n);
    k += 1;
  }
};

// Every scratch array of one solver (m unknowns): allocated once, reused by every case of a solve_range. Each
// function has its own arrays (prefixed with its name), as the numba code allocates its own on entry; no two
// activations of one function are ever live at once.
template <class Model>
struct SolverWork {
  using ModelWork = decltype(make_work(std::declval<const Model&>()));
  std::size_t nq;
  ModelWork model;        // the model's evaluate work
  Model blended;          // a continuation's model at the load factor being evaluated
  Model start, end;       // solve_range: the case's two models
  std::vector<double> lu;  // linalg scratch (m+1, m+1)
  std::vector<std::size_t> piv;
  std::vector<double> diff;  // _change's qa - qb (m)
  InverseJacobian H;         // solve_one's inverse Jacobian
  std::vector<double> so_r_full, so_start, so_kept, so_qs, so_r, so_J;  // solve_one
  std::vector<double> nw_r, nw_rt, nw_J, nw_qt, nw_hr, nw_hrt, nw_hy, nw_s, nw_dx, nw_A, nw_g, nw_B;  // newton
  std::vector<double> rx_r, rx_J, rx_D, rx_A, rx_dx;  // relax
  std::vector<double> ac_r, ac_r0, ac_r1, ac_dl, ac_J, ac_A, ac_b, ac_t, ac_tprev, ac_z, ac_zs, ac_dq, ac_dz;
  std::vector<double> cr_r, cr_rt, cr_qt, cr_J, cr_dx, cr_hrt;  // _correct
  InverseJacobian cr_H;
  std::vector<double> fo_J, fo_r0, fo_r1, fo_dl, fo_qs, fo_tan;       // _follow
  std::vector<double> fl_r, fl_J, fl_A, fl_qlow, fl_qtry, fl_dx, fl_h;  // _flow
  std::vector<double> st_r, st_J0, st_qs, st_zero;             // snap_through
  InverseJacobian st_H0;
  std::vector<double> tg_r0, tg_J, tg_d;                             // _tangent
  std::vector<double> wk_qprev, wk_qs, wk_tan;                       // _walk
  Profile prof;  // what the current case has spent so far (solve_range resets it per case)

  explicit SolverWork(const Model& m)
      : nq(m.n_unknowns()), model(make_work(m)), blended(m), start(m), end(m) {
    const std::size_t n = nq, n1 = nq + 1;
    lu.assign(n1 * n1, 0.0);
    piv.assign(n1, 0);
    diff.assign(n, 0.0);
    H = InverseJacobian(n);
    cr_H = InverseJacobian(n);
    st_H0 = InverseJacobian(n);
    for (auto* v : {&so_r_full, &so_start, &so_kept, &so_qs, &so_r}) v->assign(n, 0.0);
    so_J.assign(n * n, 0.0);
    for (auto* v : {&nw_r, &nw_rt, &nw_qt, &nw_hr, &nw_hrt, &nw_hy, &nw_s, &nw_dx, &nw_g}) v->assign(n, 0.0);
    for (auto* v : {&nw_J, &nw_A, &nw_B}) v->assign(n * n, 0.0);
    for (auto* v : {&rx_r, &rx_D, &rx_dx}) v->assign(n, 0.0);
    for (auto* v : {&rx_J, &rx_A}) v->assign(n * n, 0.0);
    for (auto* v : {&ac_r, &ac_r0, &ac_r1, &ac_dl, &ac_dq}) v->assign(n, 0.0);
    ac_J.assign(n * n, 0.0);
    ac_A.assign(n1 * n1, 0.0);
    for (auto* v : {&ac_b, &ac_t, &ac_tprev, &ac_z, &ac_zs, &ac_dz}) v->assign(n1, 0.0);
    for (auto* v : {&cr_r, &cr_rt, &cr_qt, &cr_dx, &cr_hrt}) v->assign(n, 0.0);
    cr_J.assign(n * n, 0.0);
    for (auto* v : {&fo_r0, &fo_r1, &fo_dl, &fo_qs, &fo_tan}) v->assign(n, 0.0);
    fo_J.assign(n * n, 0.0);
    for (auto* v : {&fl_r, &fl_qlow, &fl_qtry, &fl_dx, &fl_h}) v->assign(n, 0.0);
    for (auto* v : {&fl_J, &fl_A}) v->assign(n * n, 0.0);
    for (auto* v : {&st_r, &st_qs, &st_zero}) v->assign(n, 0.0);
    st_J0.assign(n * n, 0.0);
    for (auto* v : {&tg_r0, &tg_d}) v->assign(n, 0.0);
    tg_J.assign(n * n, 0.0);
    for (auto* v : {&wk_qprev, &wk_qs, &wk_tan}) v->assign(n, 0.0);
  }
};

// ------------------------------------------------------------------ the homotopy's model functions
// model_evaluate: residual r and, with want_jac, its Jacobian J at load factor lam along the homotopy h.
template <class Model>
inline void model_evaluate(const double* q, double lam, const Homotopy<Model>& h, bool want_jac, double* r,
                           double* J, SolverWork<Model>& w) {
  const Clock::time_point t0 = w.prof.timed ? Clock::now() : Clock::time_point{};
  if (h.ramp) {  // every load scaled by lam
    evaluate(q, lam, *h.end, want_jac, r, J, w.model);
  } else {  // every load at its blend: the load factor moves along the path, not from zero
    blend(*h.start, *h.end, lam, w.blended);
    evaluate(q, 1.0, w.blended, want_jac, r, J, w.model);
  }
  (want_jac ? w.prof.jacobians : w.prof.residuals) += 1;
  if (w.prof.timed) (want_jac ? w.prof.jacobian_s : w.prof.residual_s) += seconds_since(t0);
}

// f(), a dense factorisation of the solver w, counted (and timed) in w's profile.
template <class Model, class F>
inline auto factorisation(SolverWork<Model>& w, F f) {
  const Clock::time_point t0 = w.prof.timed ? Clock::now() : Clock::time_point{};
  const auto out = f();
  w.prof.factorisations += 1;
  if (w.prof.timed) w.prof.linalg_s += seconds_since(t0);
  return out;
}

// model_angle: largest bend or twist of a subsegment that the change dq of the unknowns makes [rad].
template <class Model>
inline double model_angle(const double* dq, const Homotopy<Model>& h) {
  return largest_angle(dq, *h.end);
}

// model_rest: the packed model whose evaluation at load factor 0 is the unloaded robot.
template <class Model>
inline const Model& model_rest(const Homotopy<Model>& h) {
  return *h.start;
}

// ------------------------------------------------------------------ small helpers
// max |r_i| over n entries; infinity if any is NaN.
inline double maxabs(const double* r, std::size_t n) {
  double s = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double ax = std::fabs(r[i]);
    if (!(ax <= s)) s = ax == ax ? ax : INF;  // also catches NaN
  }
  return s;
}

// sum of r_i^2, in order.
inline double sumsq(const double* r, std::size_t n) {
  double s = 0.0;
  for (std::size_t i = 0; i < n; ++i) s += r[i] * r[i];
  return s;
}

// sum of a_i b_i, in order (np.sum(a * b)).
inline double dot(const double* a, const double* b, std::size_t n) {
  double s = 0.0;
  for (std::size_t i = 0; i < n; ++i) s += a[i] * b[i];
  return s;
}

// True when all n entries are finite.
inline bool finite_all(const double* a, std::size_t n) { return all_finite(a, n); }

// _step_scale: largest factor <= 1 keeping every subsegment's bend and twist change <= max_dtheta.
template <class Model>
inline double step_scale(const double* dx, const Homotopy<Model>& m, double max_dtheta) {
  const double big = model_angle(dx, m);
  if (big > max_dtheta) return max_dtheta / big;
  return 1.0;
}

// Broyden's ("good") update of the inverse Jacobian, H <- H + (s - H y) s^T H / (s^T H y), for the step s from q
// to qt whose residual is rt (y = rt - r), with hr = H r at q on entry; on return hr = H rt for the updated H. In
// product form: H <- (I + w s^T) H, w = (s - H y) / (s^T H y). hrt, hy, s: scratch (nq,).
inline void broyden(InverseJacobian& H, const double* q, const double* qt, const double* rt, double* hr,
                    double* hrt, double* hy, double* s, std::size_t nq) {
  H.apply(rt, hrt);
  double shy = 0.0;
  for (std::size_t u = 0; u < nq; ++u) {
    s[u] = qt[u] - q[u];
    hy[u] = hrt[u] - hr[u];  // H y, y = rt - r
    shy += s[u] * hy[u];
  }
  if (!(std::fabs(shy) > 1e-300)) {
    for (std::size_t u = 0; u < nq; ++u) hr[u] = hrt[u];
    return;
  }
  double c = 0.0;  // s^T H rt
  for (std::size_t u = 0; u < nq; ++u) c += s[u] * hrt[u];
  for (std::size_t u = 0; u < nq; ++u) {
    hy[u] = (s[u] - hy[u]) / shy;  // w
    hr[u] = hrt[u] + hy[u] * c;
  }
  H.push(hy, s);
}

// H = J^-1 as factors (InverseJacobian::factor), counted as one factorisation in w's profile.
template <class Model>
inline bool factor_into(const double* J, InverseJacobian& H, SolverWork<Model>& w) {
  return factorisation(w, [&] { return H.factor(J); });
}

// x = A^-1 b (n, n) with w's linalg scratch (np.linalg.solve; by the factors of A^T, solve_by_transpose); false
// where it raises.
template <class Model>
inline bool solve_into(const double* A, const double* b, std::size_t n, double* x, SolverWork<Model>& w) {
  return factorisation(w, [&] { return solve_by_transpose(A, b, n, x, w.lu.data(), w.piv.data()); });
}

// ------------------------------------------------------------------ Newton
struct Result {
  bool converged;
  double res;  // max |r| [N m]
  long iterations;
  long jacobians;
};

// Quasi-Newton iteration from q (in place) at load factor lam. H holds the inverse Jacobian: factored
// from the exact Jacobian unless reuse (then the caller's H is the start), and left updated on return. Later
// steps update it with Broyden's formula; the exact Jacobian is recomputed only when a step stops making good
// progress (at most max_jac times). Steps are scaled so that no subsegment bends or twists by more than
// max_dtheta [rad] and backtracked on ||r||^2; where the Newton direction fails on a fresh Jacobian,
// Levenberg-Marquardt steps take over. Returns (converged, max|r|, iterations, jacobian evaluations).
template <class Model>
Result newton(double* q, double lam, const Homotopy<Model>& m, double atol, long max_iter, double max_dtheta,
              SolverWork<Model>& w, InverseJacobian& H, bool reuse, long max_jac) {
  const std::size_t nq = w.nq;
  double* r = w.nw_r.data();
  double* rt = w.nw_rt.data();
  double* J = w.nw_J.data();
  double* qt = w.nw_qt.data();
  double* hr = w.nw_hr.data();  // H r for the current r (kept up to date through each Broyden update)
  double* hrt = w.nw_hrt.data();
  double* hy = w.nw_hy.data();
  double* s = w.nw_s.data();
  double* dx = w.nw_dx.data();
  bool have_hr = false;
  long njac;
  bool fresh;
  if (reuse) {
    model_evaluate(q, lam, m, false, r, J, w);
    njac = 0;
    fresh = false;
  } else {
    model_evaluate(q, lam, m, true, r, J, w);
    njac = 1;
    fresh = true;
    factor_into(J, H, w);
  }
  double res = maxabs(r, nq);
  long it = 0;
  double best = res;
  long since = 0;
  double f1 = 0.0;
  while (it < max_iter) {
    if (res <= atol) return {true, res, it, njac};
    if (!std::isfinite(res)) return {false, res, it, njac};
    // give up on stagnation: no halving of the residual in STALL iterations
    if (res < 0.5 * best) {
      best = res;
      since = 0;
    } else {
      since += 1;
      if (since > STALL) return {false, res, it, njac};
    }
    it += 1;
    if (!have_hr) {
      H.apply(r, hr);
      have_hr = true;
    }
    for (std::size_t u = 0; u < nq; ++u) dx[u] = -hr[u];
    double alpha = step_scale(dx, m, max_dtheta);
    const double f0 = sumsq(r, nq);
    bool accepted = false;
    const int nls = !fresh ? 8 : 12;
    for (int ls = 0; ls < nls; ++ls) {
      for (std::size_t u = 0; u < nq; ++u) qt[u] = q[u] + alpha * dx[u];
      model_evaluate(qt, lam, m, false, rt, J, w);
      f1 = sumsq(rt, nq);
      if (f1 <= (1.0 - 1e-4 * alpha) * f0) {
        accepted = true;
        break;
      }
      alpha *= 0.5;
    }
    if (!accepted && fresh) {
      // Levenberg-Marquardt on the exact Jacobian (robust where J is near singular): A = J^T J, g = J^T r
      double* A = w.nw_A.data();
      double* g = w.nw_g.data();
      double* B = w.nw_B.data();
      for (std::size_t u = 0; u < nq; ++u)
        for (std::size_t v = 0; v < nq; ++v) {
          double acc = 0.0;
          for (std::size_t k = 0; k < nq; ++k) acc += J[k * nq + u] * J[k * nq + v];
          A[u * nq + v] = acc;
        }
      for (std::size_t u = 0; u < nq; ++u) {
        double acc = 0.0;
        for (std::size_t k = 0; k < nq; ++k) acc += J[k * nq + u] * r[k];
        g[u] = acc;
      }
      double mu = 1e-5;
      double dmax = 0.0;
      for (std::size_t u = 0; u < nq; ++u)
        if (A[u * nq + u] > dmax) dmax = A[u * nq + u];
      for (int lm = 0; lm < 8; ++lm) {
        for (std::size_t i = 0; i < nq * nq; ++i) B[i] = A[i];
        for (std::size_t u = 0; u < nq; ++u) B[u * nq + u] += mu * dmax;
        if (!solve_into(B, g, nq, dx, w)) {
          mu *= 10.0;
          continue;
        }
        for (std::size_t u = 0; u < nq; ++u) dx[u] = -dx[u];
        alpha = step_scale(dx, m, max_dtheta);
        for (std::size_t u = 0; u < nq; ++u) qt[u] = q[u] + alpha * dx[u];
        model_evaluate(qt, lam, m, false, rt, J, w);
        f1 = sumsq(rt, nq);
        if (f1 < f0) {
          accepted = true;
          break;
        }
        mu *= 10.0;
      }
      if (!accepted) return {false, res, it, njac};
    }
    if (!accepted) {
      // stale Broyden inverse: recompute the exact Jacobian here and retry
      if (njac >= max_jac) return {false, res, it, njac};
      model_evaluate(q, lam, m, true, r, J, w);
      njac += 1;
      fresh = true;
      have_hr = false;
      factor_into(J, H, w);
      continue;
    }
    broyden(H, q, qt, rt, hr, hrt, hy, s, nq);
    for (std::size_t u = 0; u < nq; ++u) {
      q[u] = qt[u];
      r[u] = rt[u];
    }
    res = maxabs(r, nq);
    fresh = false;
    if (f1 > 0.25 * f0 && res > atol) {
      if (njac >= max_jac) return {false, res, it, njac};
      model_evaluate(q, lam, m, true, r, J, w);
      njac += 1;
      fresh = true;
      have_hr = false;
      factor_into(J, H, w);
    }
  }
  return {res <= atol, res, it, njac};
}

// Pseudo-transient continuation from q (in place): implicit Euler on dq/dt = -D^-1 r, D = |diag J| + 1e-12, the
// time step growing as the residual falls (switched evolution relaxation), ending in Newton steps.
// Returns (converged, max|r|, iterations, jacobian evaluations).
template <class Model>
Result relax(double* q, double lam, const Homotopy<Model>& m, double atol, long max_iter, double max_dtheta,
             SolverWork<Model>& w) {
  const std::size_t nq = w.nq;
  double* r = w.rx_r.data();
  double* J = w.rx_J.data();
  double* D = w.rx_D.data();
  double* A = w.rx_A.data();
  double* dx = w.rx_dx.data();
  model_evaluate(q, lam, m, true, r, J, w);
  for (std::size_t u = 0; u < nq; ++u) D[u] = std::fabs(J[u * nq + u]) + 1e-12;
  const double r0 = std::sqrt(sumsq(r, nq));
  double rprev = r0;
  double dt = 0.05;
  double res = maxabs(r, nq);
  for (long it = 0; it < max_iter; ++it) {
    if (res <= atol) return {true, res, it, it + 1};
    for (std::size_t i = 0; i < nq * nq; ++i) A[i] = J[i];
    for (std::size_t u = 0; u < nq; ++u) A[u * nq + u] += D[u] / dt;
    if (!solve_into(A, r, nq, dx, w)) return {false, res, it, it + 1};
    for (std::size_t u = 0; u < nq; ++u) dx[u] = -dx[u];
    const double alpha = step_scale(dx, m, max_dtheta);
    for (std::size_t u = 0; u < nq; ++u) q[u] += alpha * dx[u];
    model_evaluate(q, lam, m, true, r, J, w);
    res = maxabs(r, nq);
    if (!std::isfinite(res)) return {false, res, it + 1, it + 2};
    const double rn = std::sqrt(sumsq(r, nq));
    const double grow = rn < rprev ? dt * 2.0 : dt * 0.5;
    dt = std::min(1e12, std::max(grow, 0.05 * r0 / std::max(rn, 1e-300)));
    rprev = rn;
  }
  return {res <= atol, res, max_iter, max_iter + 1};
}

// _change: largest change of bend angle or twist of one subsegment between qa and qb [rad].
template <class Model>
inline double change(const double* qa, const double* qb, const Homotopy<Model>& m, SolverWork<Model>& w) {
  double* d = w.diff.data();
  for (std::size_t u = 0; u < w.nq; ++u) d[u] = qa[u] - qb[u];
  return model_angle(d, m);
}

// _dr_dlam: dr/dlam at (q, lam) into dr by central differences (step 1e-6); r0, r1 scratch (nq).
template <class Model>
inline void dr_dlam(const double* q, double lam, const Homotopy<Model>& m, SolverWork<Model>& w, double* r0,
                    double* r1, double* dr) {
  const double h = 1e-6;
  model_evaluate(q, lam + h, m, false, r0, nullptr, w);
  model_evaluate(q, lam - h, m, false, r1, nullptr, w);
  for (std::size_t u = 0; u < w.nq; ++u) dr[u] = (r0[u] - r1[u]) / (2.0 * h);
}

struct ArcResult {
  bool converged;
  double res;
  long iterations;
  long jacobians;
  long steps;
  bool turned;  // lam decreased somewhere: a turning point was passed
};

// Pseudo-arclength continuation of the equilibrium curve r(q, lam) = 0 from (q, lam) until lam = 1; q in place.
// The tangent t in (q, lam) from J dq = -dr/dlam; each step predicts along it and corrects with Newton on the
// bordered system [J, dr/dlam; t^T] (the step's length fixed); a step that would pass lam = 1, or whose corrector
// carries lam past 1, corrects at lam = 1 instead.
template <class Model>
ArcResult arclength(double* q, double lam, const Homotopy<Model>& m, double atol, long max_iter, double max_dtheta,
                    SolverWork<Model>& w) {
  const std::size_t nq = w.nq, n1 = nq + 1;
  double* r = w.ac_r.data();
  double* r0 = w.ac_r0.data();
  double* r1 = w.ac_r1.data();
  double* dl = w.ac_dl.data();
  double* J = w.ac_J.data();
  double* A = w.ac_A.data();
  double* b = w.ac_b.data();
  double* t = w.ac_t.data();
  double* tprev = w.ac_tprev.data();
  double* z = w.ac_z.data();
  double* zs = w.ac_zs.data();
  double* dq = w.ac_dq.data();
  double* dz = w.ac_dz.data();
  for (std::size_t u = 0; u < n1; ++u) {
    t[u] = 0.0;
    tprev[u] = 0.0;
  }
  tprev[nq] = 1.0;  // the loading path goes towards larger loads
  double ds = 0.05;
  long iters = 0;
  long njac = 0;
  bool turned = false;
  double res = INF;
  for (long step = 0; step < ARC_STEPS; ++step) {
    model_evaluate(q, lam, m, true, r, J, w);
    njac += 1;
    dr_dlam(q, lam, m, w, r0, r1, dl);
    for (std::size_t u = 0; u < nq; ++u) b[u] = -dl[u];
    if (!solve_into(J, b, nq, dq, w)) return {false, res, iters, njac, step, turned};
    for (std::size_t u = 0; u < nq; ++u) t[u] = dq[u];
    t[nq] = 1.0;
    const double nt = std::sqrt(dot(t, t, n1));
    const double sgn = dot(t, tprev, n1) >= 0.0 ? 1.0 : -1.0;
    for (std::size_t u = 0; u < n1; ++u) t[u] = sgn * t[u] / nt;
    bool accepted = false;
    while (ds > 1e-7 && !accepted) {
      bool at_end = lam + ds * t[nq] >= 1.0;
      const double h = at_end ? (1.0 - lam) / t[nq] : ds;
      for (std::size_t u = 0; u < nq; ++u) zs[u] = q[u] + h * t[u];
      zs[nq] = at_end ? 1.0 : lam + h * t[nq];
      for (long it = 0; it < max_iter; ++it) {
        iters += 1;
        model_evaluate(zs, zs[nq], m, true, r, J, w);
        njac += 1;
        res = maxabs(r, nq);
        // on the last step lam is held at 1: Newton in q alone; else the arclength is held
        double g = 0.0;
        if (!at_end) {
          for (std::size_t u = 0; u < n1; ++u) z[u] = zs[u] - (u < nq ? q[u] : lam);
          g = dot(t, z, n1) - h;
        }
        if (res <= atol && std::fabs(g) <= 1e-12) {
          accepted = true;
          break;
        }
        if (!std::isfinite(res)) break;
        for (std::size_t u = 0; u < nq; ++u)
          for (std::size_t v = 0; v < nq; ++v) A[u * n1 + v] = J[u * nq + v];
        if (at_end) {
          for (std::size_t u = 0; u < nq; ++u) A[u * n1 + nq] = 0.0;
          for (std::size_t v = 0; v < n1; ++v) A[nq * n1 + v] = 0.0;
          A[nq * n1 + nq] = 1.0;
        } else {
          dr_dlam(zs, zs[nq], m, w, r0, r1, dl);
          for (std::size_t u = 0; u < nq; ++u) A[u * n1 + nq] = dl[u];
          for (std::size_t v = 0; v < n1; ++v) A[nq * n1 + v] = t[v];
        }
        for (std::size_t u = 0; u < nq; ++u) b[u] = -r[u];
        b[nq] = -g;
        if (!solve_into(A, b, n1, dz, w)) break;
        const double alpha = step_scale(dz, m, max_dtheta);
        for (std::size_t u = 0; u < n1; ++u) zs[u] += alpha * dz[u];
        if (!at_end && zs[nq] > 1.0) {
          // the corrector carried lam past full load: hold it at 1 and finish in q alone
          zs[nq] = 1.0;
          at_end = true;
        }
      }
      if (!accepted) ds *= 0.5;
    }
    if (!accepted) return {false, res, iters, njac, step, turned};
    if (zs[nq] < lam) turned = true;
    for (std::size_t u = 0; u < nq; ++u) q[u] = zs[u];
    lam = zs[nq];
    for (std::size_t u = 0; u < n1; ++u) tprev[u] = t[u];
    if (lam >= 1.0) return {true, res, iters, njac, step + 1, turned};
    ds = std::min(2.0 * ds, 0.25);
    if (lam < -0.5) break;
  }
  return {false, res, iters, njac, ARC_STEPS, turned};
}

// ------------------------------------------------------------------ through a fold: follow, snap, follow on
// _inverse: H = J^-1 as factors; false (H zero) where J is singular or not finite, and false where the inverse
// would not be finite (InverseJacobian::finite).
template <class Model>
inline bool inverse_checked(const double* J, InverseJacobian& H, SolverWork<Model>& w) {
  return factor_into(J, H, w) && H.finite();
}

// _det_sign: the sign of det J (0 where singular or not finite).
template <class Model>
inline double det_sign(const double* J, SolverWork<Model>& w) {
  const std::size_t n = w.nq;
  if (!finite_all(J, n * n)) return 0.0;
  double s, ld;
  factorisation(w, [&] {  // det J = det J^T, whose LU is the cheap one (solve_by_transpose)
    transpose_into(J, n, w.lu.data());
    slogdet(w.lu.data(), n, w.lu.data(), w.piv.data(), s, ld);
    return true;
  });
  return std::isfinite(ld) ? s : 0.0;
}

struct CorrectResult {
  bool converged;
  double res;
  long iterations;
  long jacobians;
  double theta;  // the first iteration's contraction
};

// _correct: Newton from q (in place) at load factor lam with the exact Jacobian every iteration, damped by
// Deuflhard's natural monotonicity test: a step a along the Newton correction dx is accepted when the simplified
// correction J^-1 r(q + a dx) is shorter than (1 - a/4) |dx|. A first contraction above max_theta ends the
// iteration at once (not converged).
template <class Model>
CorrectResult correct(double* q, double lam, const Homotopy<Model>& m, double tol, long max_iter, double max_dtheta,
                      SolverWork<Model>& w, double max_theta) {
  const std::size_t nq = w.nq;
  double* r = w.cr_r.data();
  double* rt = w.cr_rt.data();
  double* qt = w.cr_qt.data();
  double* J = w.cr_J.data();
  InverseJacobian& H = w.cr_H;
  double* dx = w.cr_dx.data();
  double* hrt = w.cr_hrt.data();
  double a = 1.0;
  double theta = 0.0;  // a start already in balance contracts at once
  long njac = 0;
  for (long it = 0; it < max_iter; ++it) {
    model_evaluate(q, lam, m, true, r, J, w);
    njac += 1;
    const double res = maxabs(r, nq);
    if (res <= tol) return {true, res, it, njac, theta};
    if (!std::isfinite(res) || !inverse_checked(J, H, w)) return {false, res, it, njac, theta};
    H.apply(r, dx);
    for (std::size_t u = 0; u < nq; ++u) dx[u] = -dx[u];
    const double ndx = std::sqrt(sumsq(dx, nq));
    a = std::min(std::min(1.0, 2.0 * a), step_scale(dx, m, max_dtheta));
    while (true) {
      for (std::size_t u = 0; u < nq; ++u) qt[u] = q[u] + a * dx[u];
      model_evaluate(qt, lam, m, false, rt, J, w);
      H.apply(rt, hrt);
      const double th = std::sqrt(sumsq(hrt, nq)) / ndx;
      if (it == 0) {
        theta = th;
        if (th > max_theta) return {false, res, it + 1, njac, theta};
      }
      if (th <= 1.0 - 0.25 * a || maxabs(rt, nq) <= tol) break;
      a *= 0.5;
      if (a < 1e-4) return {false, res, it + 1, njac, theta};
    }
    for (std::size_t u = 0; u < nq; ++u) q[u] = qt[u];
    const double rn = maxabs(rt, nq);
    if (rn <= tol) return {true, rn, it + 1, njac, theta};  // in balance at the new point
  }
  model_evaluate(q, lam, m, false, r, J, w);
  const double res = maxabs(r, nq);
  return {res <= tol, res, max_iter, njac, theta};
}

struct FollowResult {
  bool reached;
  double lam;
  double res;
  long iterations;
  long jacobians;
  long steps;
};

// _follow: follow the branch of the equilibrium q (in place) at load factor lam towards lam = 1 in small load
// steps: the tangent dq/dlam as predictor, correct as corrector, steps aimed at target [rad] per subsegment and
// halved on a failed, slowly contracting or jumping step. Stops at lam = 1 or where a step of FOLD_H fails (a
// fold; q the last equilibrium before it).
template <class Model>
FollowResult follow(double* q, double lam, const Homotopy<Model>& m, double atol, double step_atol, long max_iter,
                    double max_dtheta, SolverWork<Model>& w, double target) {
  const std::size_t nq = w.nq;
  double* J = w.fo_J.data();
  double* r0 = w.fo_r0.data();
  double* r1 = w.fo_r1.data();
  double* dl = w.fo_dl.data();
  double* qs = w.fo_qs.data();
  double* tan = w.fo_tan.data();
  long iters = 0;
  long njac = 0;
  double h = MAX_DLAM;
  double res = INF;
  for (long step = 0; step < FOLLOW_STEPS; ++step) {
    if (lam >= 1.0) return {true, lam, res, iters, njac, step};
    model_evaluate(q, lam, m, true, r0, J, w);
    njac += 1;
    dr_dlam(q, lam, m, w, r0, r1, dl);
    if (!solve_into(J, dl, nq, tan, w)) return {false, lam, res, iters, njac, step};
    for (std::size_t u = 0; u < nq; ++u) tan[u] = -tan[u];
    const double rate = model_angle(tan, m);
    if (rate > 0.0 && std::isfinite(rate)) h = std::min(h, target / rate);
    while (true) {
      h = std::min(h, 1.0 - lam);
      const double lt = lam + h;
      for (std::size_t u = 0; u < nq; ++u) qs[u] = q[u] + h * tan[u];
      const double tol = lt >= 1.0 ? atol : std::max(atol, step_atol);
      const CorrectResult c = correct(qs, lt, m, tol, std::min(12L, max_iter), max_dtheta, w, FOLLOW_THETA);
      res = c.res;
      iters += c.iterations;
      njac += c.jacobians;
      if (c.converged && c.theta < FOLLOW_THETA && change(qs, q, m, w) <= std::max(MAX_STEP_CHANGE, 2.0 * h * rate)) {
        for (std::size_t u = 0; u < nq; ++u) q[u] = qs[u];
        lam = lt >= 1.0 ? 1.0 : lt;
        h = std::min(2.0 * h, MAX_DLAM);
        break;
      }
      h *= 0.5;
      if (h < FOLD_H) return {false, lam, res, iters, njac, step + 1};
    }
  }
  return {lam >= 1.0, lam, res, iters, njac, FOLLOW_STEPS};
}

// _flow: the snap-through: implicit Euler (q in place) on the pseudo-time flow dq/dt = -J0^-1 r(q) at load
// factor lam, J0 the unloaded, straight robot's Jacobian (H0 its inverse): a damped, stiffness-proportional flow.
// The time step keeps each step's bend and twist near 0.1 rad, grows towards Newton's as the residual falls, and
// stays at most FLOW_CAP while |J0^-1 r| grows; Newton (correct) is tried from each point where |J0^-1 r| had a
// local minimum. Converged only on an equilibrium whose det J has the sign sign0 of the stable start.
template <class Model>
Result flow(double* q, double lam, const Homotopy<Model>& m, double tol, long max_iter, double max_dtheta,
            SolverWork<Model>& w, const double* J0, const InverseJacobian& H0, double sign0) {
  const std::size_t nq = w.nq;
  double* r = w.fl_r.data();
  double* J = w.fl_J.data();
  double* A = w.fl_A.data();
  double* qlow = w.fl_qlow.data();
  double* qtry = w.fl_qtry.data();
  double* dx = w.fl_dx.data();
  double* hr = w.fl_h.data();
  for (std::size_t u = 0; u < nq; ++u) qlow[u] = q[u];
  model_evaluate(q, lam, m, true, r, J, w);
  long njac = 1;
  long iters = 0;
  H0.apply(r, hr);
  double z = std::sqrt(sumsq(hr, nq));
  bool falling = false;
  double dt = 1.0;
  double res = maxabs(r, nq);
  const long n_steps = std::min(FLOW_STEPS, 6 * max_iter);
  for (long k = 0; k < n_steps; ++k) {
    if (res <= tol) {
      if (det_sign(J, w) == sign0) return {true, res, iters, njac};
      break;
    }
    iters += 1;
    for (std::size_t u = 0; u < nq; ++u)
      for (std::size_t v = 0; v < nq; ++v) A[u * nq + v] = J[u * nq + v] + J0[u * nq + v] / dt;
    if (!solve_into(A, r, nq, dx, w)) break;
    for (std::size_t u = 0; u < nq; ++u) dx[u] = -dx[u];
    const double step = model_angle(dx, m);
    if (!std::isfinite(step)) break;
    if (step > 0.2) {  // too far for one step of the flow: a shorter time step
      dt *= 0.05 / step;
      if (!(dt > 1e-300)) break;  // no time step short enough: the flow cannot go on
      continue;
    }
    for (std::size_t u = 0; u < nq; ++u) qlow[u] = q[u];
    for (std::size_t u = 0; u < nq; ++u) q[u] += dx[u];
    model_evaluate(q, lam, m, true, r, J, w);
    njac += 1;
    res = maxabs(r, nq);
    H0.apply(r, hr);
    const double zn = std::sqrt(sumsq(hr, nq));
    dt = std::min(1e12, dt * std::min(4.0, 0.1 / std::max(step, 1e-300)));
    if (zn > z) {
      dt = std::min(dt, FLOW_CAP);
      if (falling && res > tol) {  // |J0^-1 r| had a local minimum at the last point: Newton from there
        for (std::size_t u = 0; u < nq; ++u) qtry[u] = qlow[u];
        const CorrectResult c = correct(qtry, lam, m, tol, std::min(8L, max_iter), max_dtheta, w, INF);
        iters += c.iterations;
        njac += c.jacobians;
        if (c.converged) {
          model_evaluate(qtry, lam, m, true, r, J, w);
          njac += 1;
          if (det_sign(J, w) == sign0) {
            for (std::size_t u = 0; u < nq; ++u) q[u] = qtry[u];
            return {true, c.res, iters, njac};
          }
          model_evaluate(q, lam, m, true, r, J, w);
          njac += 1;
        }
      }
    }
    falling = zn < z;
    z = zn;
  }
  return {false, res, iters, njac};
}

struct SnapResult {
  bool converged;
  double res;
  long iterations;
  long jacobians;
  long steps;
  bool snapped;
};

// snap_through: from the last equilibrium q (in place) of a loading path that stalled at load factor lam, reach
// full load: follow the branch in small steps, at each fold relax SNAP_DLAM past it (flow; the robot snaps
// through to a neighbouring stable equilibrium) and follow on from there; where that relaxation fails, relax at
// full load. The unloaded, straight robot's Jacobian (its elastic stiffness) weighs the flow.
template <class Model>
SnapResult snap_through(double* q, double lam, const Homotopy<Model>& m, double atol, double step_atol,
                        long max_iter, double max_dtheta, SolverWork<Model>& w, double target) {
  const std::size_t nq = w.nq;
  double* r = w.st_r.data();
  double* J0 = w.st_J0.data();
  InverseJacobian& H0 = w.st_H0;
  double* qs = w.st_qs.data();
  double* zero = w.st_zero.data();
  for (std::size_t u = 0; u < nq; ++u) zero[u] = 0.0;
  evaluate(zero, 0.0, model_rest(m), true, r, J0, w.model);
  long iters = 0;
  long njac = 1;
  long steps = 0;
  bool snapped = false;
  double res = INF;
  if (!inverse_checked(J0, H0, w)) return {false, res, iters, njac, steps, snapped};
  const double sign0 = H0.sign;
  for (long fold = 0; fold < MAX_FOLDS + 1; ++fold) {
    const FollowResult f = follow(q, lam, m, atol, step_atol, max_iter, max_dtheta, w, target);
    lam = f.lam;
    res = f.res;
    iters += f.iterations;
    njac += f.jacobians;
    steps += f.steps;
    if (f.reached || fold == MAX_FOLDS) return {f.reached, res, iters, njac, steps, snapped};
    // a fold at lam: the robot snaps through to another equilibrium just past it
    double lt = std::min(1.0, lam + SNAP_DLAM);
    for (std::size_t u = 0; u < nq; ++u) qs[u] = q[u];
    const double tol = lt >= 1.0 ? atol : std::max(atol, step_atol);
    Result fl = flow(qs, lt, m, tol, max_iter, max_dtheta, w, J0, H0, sign0);
    iters += fl.iterations;
    njac += fl.jacobians;
    steps += 1;
    if (!fl.converged && lt < 1.0) {  // no settling near the fold: relax at full load
      lt = 1.0;
      for (std::size_t u = 0; u < nq; ++u) qs[u] = q[u];
      fl = flow(qs, lt, m, atol, max_iter, max_dtheta, w, J0, H0, sign0);
      iters += fl.iterations;
      njac += fl.jacobians;
      steps += 1;
    }
    res = fl.res;
    if (!fl.converged) return {false, res, iters, njac, steps, snapped};
    for (std::size_t u = 0; u < nq; ++u) q[u] = qs[u];
    lam = lt;
    snapped = true;
    if (lam >= 1.0) return {true, res, iters, njac, steps, snapped};
  }
  return {false, res, iters, njac, steps, snapped};
}

// _tangent: the path's tangent tan = dq/dlam (in place) at q, an equilibrium at lam = 0 whose residual at lam = 1
// is r1: -J^-1 (r(q, 1) - r(q, 0)) (every load is affine in lam), J's inverse left in H. Returns (false where J is
// singular, then tan is zero, or where tan is not finite; the sign of det J there).
template <class Model>
std::pair<bool, double> tangent(const double* q, const double* r1, const Homotopy<Model>& m, SolverWork<Model>& w,
                                InverseJacobian& H, double* tan) {
  const std::size_t nq = w.nq;
  double* r0 = w.tg_r0.data();
  double* J = w.tg_J.data();
  double* d = w.tg_d.data();
  model_evaluate(q, 0.0, m, true, r0, J, w);
  if (!factor_into(J, H, w)) {  // sign 0: J singular or not finite
    for (std::size_t u = 0; u < nq; ++u) tan[u] = 0.0;
    return {false, H.sign};
  }
  const double sign = H.sign;
  for (std::size_t u = 0; u < nq; ++u) d[u] = r1[u] - r0[u];
  H.apply(d, tan);
  for (std::size_t u = 0; u < nq; ++u) tan[u] = -tan[u];
  return {finite_all(tan, nq), sign};
}

struct WalkResult {
  bool converged;
  double lam;  // the load factor reached
  double res;
  long iterations;
  long jacobians;
  long steps;
  long path;
  double sign0;  // sign of det J at the start
};

// _walk: the loading path (or a continuation, cont) from q at lam = 0 (in place) towards lam = 1, load steps
// scaled by scale; r_full is the residual of q at lam = 1. See solve_one.
template <class Model>
WalkResult walk(double* q, const Homotopy<Model>& m, const Settings& settings, SolverWork<Model>& w, InverseJacobian& H,
                double scale, bool cont, const double* r_full) {
  const double atol = settings.atol, max_dtheta = settings.max_dtheta;
  const long max_iter = settings.max_iter;
  const std::size_t nq = w.nq;
  long iters = 0;
  long nj = 0;
  long path = cont ? PATH_CONTINUED : PATH_LOADING;
  double* qprev = w.wk_qprev.data();
  double* qs = w.wk_qs.data();
  double* tan = w.wk_tan.data();
  for (std::size_t u = 0; u < nq; ++u) {
    qprev[u] = 0.0;
    qs[u] = 0.0;
    tan[u] = 0.0;
  }
  double lprev = 0.0;
  double lam = 0.0;
  const double target = STEP_TARGET * scale;
  // a continuation may cross its whole path in one step; the loading path from rest takes at least four
  const double max_dlam = cont ? 1.0 : MAX_DLAM * scale;
  double dlam = max_dlam;
  // the first step is predicted along the path's tangent (there is no secant yet) and sized by it
  const std::pair<bool, double> tg = tangent(q, r_full, m, w, H, tan);
  const bool use_tan = tg.first;
  const double sign0 = tg.second;
  nj += 1;
  double rate = model_angle(tan, m);
  if (use_tan && rate > 0.0) dlam = std::min(max_dlam, target / rate);
  long steps = 0;
  bool ok = false;
  double res = INF;
  const long step_iter = std::min(max_iter, settings.step_iter);
  bool have_h = use_tan;  // an inverse Jacobian from the last converged load step (or the start's)
  while (lam < 1.0 && steps < 400) {
    const double lt = std::min(1.0, lam + dlam);
    if (!(lt > lam)) {  // a step below the load factor's resolution: the path cannot go on
      ok = false;
      break;
    }
    // secant predictor from the last two equilibria
    if (lam > lprev) {
      const double wt = (lt - lam) / (lam - lprev);
      for (std::size_t u = 0; u < nq; ++u) qs[u] = q[u] + wt * (q[u] - qprev[u]);
    } else if (use_tan) {
      for (std::size_t u = 0; u < nq; ++u) qs[u] = q[u] + (lt - lam) * tan[u];
    } else {
      for (std::size_t u = 0; u < nq; ++u) qs[u] = q[u];
    }
    const double tol = lt >= 1.0 ? atol : std::max(atol, settings.step_atol);
    // a step whose corrector fails is halved (from a fresh Jacobian at the shorter step's predictor); correcting
    // again from the last equilibrium without a predictor succeeded on 2 % of the failed steps and cost a fifth
    // of all Jacobians (sscr, paper load) and is not tried
    const Result nw = newton(qs, lt, m, tol, step_iter, max_dtheta, w, H, have_h, STEP_JACOBIANS);
    ok = nw.converged;
    res = nw.res;
    long it = nw.iterations, ne = nw.jacobians;
    iters += it;
    nj += ne;
    steps += 1;
    if (ok && dlam >= 1.0 / 64.0 && change(qs, q, m, w) > MAX_STEP_CHANGE)
      ok = false;  // a converged step that moved far has jumped to another branch: take a smaller step
    have_h = ok;
    if (ok) {
      for (std::size_t u = 0; u < nq; ++u) qprev[u] = q[u];
      lprev = lam;
      for (std::size_t u = 0; u < nq; ++u) q[u] = qs[u];
      lam = lt;
      // next step from the secant rate of change: aim at STEP_TARGET per subsegment
      rate = change(q, qprev, m, w) / (lam - lprev);
      dlam = std::min(std::min(2.0 * dlam, max_dlam), rate > 0.0 ? target / rate : max_dlam);
    } else {
      dlam *= 0.5;
      if (dlam < 1.0 / 128.0) {
        if (settings.fold == FOLD_STOP) {  // no way on: the path ends at a fold, and so does the solve
          path = PATH_FOLD;
          break;
        }
        for (std::size_t u = 0; u < nq; ++u) qs[u] = q[u];
        bool turned;
        if (settings.fold == FOLD_ARCLENGTH) {
          // follow the equilibrium curve through the fold, in (q, lam)
          const ArcResult a = arclength(qs, lam, m, atol, max_iter, max_dtheta, w);
          ok = a.converged;
          res = a.res;
          it = a.iterations;
          ne = a.jacobians;
          turned = a.turned;
          steps += a.steps;
        } else {
          // a stall: follow the branch on in small steps to its fold, snap through, follow on
          const SnapResult s = snap_through(qs, lam, m, atol, settings.step_atol, max_iter, max_dtheta, w, target);
          ok = s.converged;
          res = s.res;
          it = s.iterations;
          ne = s.jacobians;
          turned = s.snapped;
          steps += s.steps;
          if (!ok) {  // relax at full load from the last equilibrium of the loading path
            iters += it;
            nj += ne;
            for (std::size_t u = 0; u < nq; ++u) qs[u] = q[u];
            const Result rx = relax(qs, 1.0, m, atol, 4 * max_iter, max_dtheta, w);
            ok = rx.converged;
            res = rx.res;
            it = rx.iterations;
            ne = rx.jacobians;
            steps += 1;
            turned = true;
          }
        }
        iters += it;
        nj += ne;
        if (ok) {
          for (std::size_t u = 0; u < nq; ++u) q[u] = qs[u];
          lam = 1.0;
          path = turned ? PATH_SNAP : path;
        }
        break;
      }
    }
  }
  return {ok, lam, res, iters, nj, steps, path, sign0};
}

// Solve at full load from q0 (nq,), writing the unknowns reached to q (nq,). m is a Homotopy: with ramp for
// stepping 0 to 2, without for STEP_CONTINUE. stepping: 0 Newton from q0 only; 1 Newton from q0, then the loading
// path if that fails; 2 the loading path from the unloaded, straight robot; STEP_CONTINUE continuation: q0 is an
// equilibrium at lam = 0 followed to lam = 1 (path code PATH_CONTINUED). Where the loading path stalls at a fold,
// settings.fold decides (snap through, arclength, or stop); where it fails, Newton at full load from the last
// equilibrium and then from q0 gives another equilibrium (PATH_FALLBACK). A path that reaches full load with the
// sign of det J changed from its start's has stepped over a fold pair: it is walked again with load steps four
// times finer (at most WALKS walks); a first walk that found no way to full load is walked again once.
template <class Model>
Outcome solve_one(const double* q0, const Homotopy<Model>& m, const Settings& settings, SolverWork<Model>& w,
                  double* q) {
  const double atol = settings.atol, max_dtheta = settings.max_dtheta;
  const long max_iter = settings.max_iter, stepping = settings.stepping;
  const std::size_t nq = w.nq;
  for (std::size_t u = 0; u < nq; ++u) q[u] = q0[u];
  InverseJacobian& H = w.H;
  H.ok = false;
  H.k = 0;
  long iters = 0;
  long nj = 0;
  const bool cont = stepping == STEP_CONTINUE;
  double* r_full = w.so_r_full.data();  // the start's residual at full load
  double res = INF;
  if (stepping != 2) {  // a start already in balance at full load is the answer: no Jacobian for it
    model_evaluate(q, 1.0, m, false, r_full, nullptr, w);
    res = maxabs(r_full, nq);
    if (res <= atol) return {true, res, 0, 0, 0, cont ? PATH_CONTINUED : PATH_DIRECT};
  }
  bool ok = false;
  if (stepping != 2 && !cont) {
    const Result nw = newton(q, 1.0, m, atol, max_iter, max_dtheta, w, H, FRESH, UNLIMITED);
    ok = nw.converged;
    res = nw.res;
    iters += nw.iterations;
    nj += nw.jacobians;
    if (ok || stepping == 0) return {ok, res, iters, nj, 0, PATH_DIRECT};
  }
  if (!cont) {
    for (std::size_t u = 0; u < nq; ++u) q[u] = 0.0;
    model_evaluate(q, 1.0, m, false, r_full, nullptr, w);
  }
  double* start = w.so_start.data();
  for (std::size_t u = 0; u < nq; ++u) start[u] = q[u];
  double scale = settings.step_scale;
  long steps = 0;
  double* kept = w.so_kept.data();  // the last answer that reached full load on the other sign of det J
  double kept_res = INF;
  long kept_path = PATH_LOADING;
  double lam = 0.0;
  long path = PATH_LOADING;
  for (long attempt = 0; attempt < WALKS; ++attempt) {
    for (std::size_t u = 0; u < nq; ++u) q[u] = start[u];
    const WalkResult wr = walk(q, m, settings, w, H, scale, cont, r_full);
    ok = wr.converged;
    lam = wr.lam;
    res = wr.res;
    path = wr.path;
    iters += wr.iterations;
    nj += wr.jacobians;
    steps += wr.steps;
    if (lam >= 1.0) {
      if (path == PATH_SNAP || wr.sign0 == 0.0 || attempt == WALKS - 1) break;
      // the branch reached must be the one the path started on: det J keeps its sign along it
      model_evaluate(q, 1.0, m, true, w.so_r.data(), w.so_J.data(), w);
      nj += 1;
      if (det_sign(w.so_J.data(), w) == wr.sign0) break;
      for (std::size_t u = 0; u < nq; ++u) kept[u] = q[u];
      kept_res = res;
      kept_path = path;
    } else if (path == PATH_FOLD) {  // the path ends at a fold
      break;
    } else if (attempt > 0) {  // a finer walk found no way: the answer a coarser one reached (if any) stands
      if (kept_res <= atol) {
        for (std::size_t u = 0; u < nq; ++u) q[u] = kept[u];
        ok = true;
        lam = 1.0;
        res = kept_res;
        path = kept_path;
      }
      break;
    }
    scale *= 0.25;  // stepped over a fold pair, or stalled with no way on: walk again in finer steps
  }
  if (lam < 1.0) {
    // last resort: any equilibrium at full load, from the last equilibrium, then from q0 (none where the path was
    // to stop at a fold)
    double* qs = w.so_qs.data();
    const int tries = path == PATH_FOLD ? 0 : 2;
    for (int which = 0; which < tries; ++which) {
      for (std::size_t u = 0; u < nq; ++u) qs[u] = which == 0 ? q[u] : q0[u];
      const Result nw = newton(qs, 1.0, m, atol, max_iter, max_dtheta, w, H, FRESH, UNLIMITED);
      iters += nw.iterations;
      nj += nw.jacobians;
      if (nw.converged) {
        for (std::size_t u = 0; u < nq; ++u) q[u] = qs[u];
        return {true, nw.res, iters, nj, steps, PATH_FALLBACK};
      }
    }
    double* r = w.so_r.data();
    model_evaluate(q, 1.0, m, false, r, nullptr, w);
    return {false, maxabs(r, nq), iters, nj, steps, path};
  }
  return {ok, res, iters, nj, steps, path};
}

// Solve, or continue, the cases start <= b < stop of a batch, one after the other. t_end (B, nt) holds each
// case's actuator tensions [N]; mb gives every other load. Solve (stepping 0 to 2): case b from q0[b] (B, m) as
// solve_one does (ma and t_start unused). Continue (STEP_CONTINUE): q0[b] is an equilibrium of ma at the tensions
// t_start[b] (B, nt) [N], followed along the straight path of the loads to mb at t_end[b]. tols (B, 2): each
// case's tolerance and load-step tolerance [N m], in place of settings'. Writes out_q (B, m), out_ok, out_res,
// out_it, out_steps and out_path (B,) for those cases. All arrays C-ordered. With profiles (B,) given, case b's
// work is written to profiles[b], timed if profiles[start].timed.
template <class Model>
void solve_range(const double* q0, const Model& ma, const Model& mb, const double* t_start, const double* t_end,
                 std::size_t nt, const Settings& settings, const double* tols, std::size_t start, std::size_t stop,
                 double* out_q, bool* out_ok, double* out_res, std::int64_t* out_it, std::int64_t* out_steps,
                 std::int64_t* out_path, Profile* profiles = nullptr) {
  SolverWork<Model> w(mb);
  const bool timed = profiles != nullptr && start < stop && profiles[start].timed;
  const std::size_t nq = w.nq;
  const bool blending = settings.stepping == STEP_CONTINUE;
  for (std::size_t b = start; b < stop; ++b) {
    with_tension(mb, t_end + b * nt, w.end);
    Homotopy<Model> h{&w.end, &w.end, true};
    if (blending) {
      with_tension(ma, t_start + b * nt, w.start);
      h = Homotopy<Model>{&w.start, &w.end, false};
    }
    Settings s = settings;  // _case_settings: case b's tolerance and load-step tolerance
    s.atol = tols[2 * b];
    s.step_atol = tols[2 * b + 1];
    w.prof = Profile{};
    w.prof.timed = timed;
    const Clock::time_point t0 = timed ? Clock::now() : Clock::time_point{};
    const Outcome o = solve_one(q0 + b * nq, h, s, w, out_q + b * nq);
    if (timed) w.prof.total_s = seconds_since(t0);
    if (profiles != nullptr) profiles[b] = w.prof;
    out_ok[b] = o.converged;
    out_res[b] = o.residual;
    out_it[b] = o.iterations;
    out_steps[b] = o.load_steps;
    out_path[b] = o.path;
  }
}

}  // namespace loading_path
}  // namespace pytdcr
