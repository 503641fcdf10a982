// Python bindings of loading_path.hpp for the PCC model (pytdcr._core.solve_range_pcc) and the subsegment Cosserat
// rod (solve_range_sscr), one template over the packed model; and of linalg.hpp's LU for its tests
// (pytdcr._core._lu_solve, _lu_solve_by_transpose, _lu_slogdet: internal, not part of the package's API).
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/tuple.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "bind_common.hpp"
#include "linalg.hpp"
#include "loading_path.hpp"
#include "pcc.hpp"
#include "sscr.hpp"

namespace nb = nanobind;

namespace pytdcr {

namespace {

using In = nb::ndarray<const double, nb::c_contig, nb::device::cpu>;
using OutF = nb::ndarray<double, nb::c_contig, nb::device::cpu>;
using OutB = nb::ndarray<bool, nb::c_contig, nb::device::cpu>;
using OutI = nb::ndarray<std::int64_t, nb::c_contig, nb::device::cpu>;
using bind::Array;

using bind::new_array;

// The (n, n) matrix a, checked square.
std::size_t square(const In& a, const char* name) {
  if (a.ndim() != 2 || a.shape(0) != a.shape(1))
    throw std::invalid_argument(std::string(name) + ": a must be a square (n, n) matrix");
  return a.shape(0);
}

void check(bool ok, const std::string& function, const std::string& what) {
  if (!ok) throw std::invalid_argument(function + ": " + what);
}

// The solver's settings from the attributes of the numba solver's Settings (a NamedTuple with the same fields).
loading_path::Settings settings_from(nb::handle s) {
  loading_path::Settings out{};
  out.atol = nb::cast<double>(s.attr("atol"));
  out.max_iter = nb::cast<long>(s.attr("max_iter"));
  out.max_dtheta = nb::cast<double>(s.attr("max_dtheta"));
  out.stepping = nb::cast<long>(s.attr("stepping"));
  out.step_iter = nb::cast<long>(s.attr("step_iter"));
  out.fold = nb::cast<long>(s.attr("fold"));
  out.step_atol = nb::cast<double>(s.attr("step_atol"));
  out.step_scale = nb::cast<double>(s.attr("step_scale"));
  return out;
}

// The checks of a solve_range call's arguments (name: the Python function's), raising ValueError.
template <class Model>
void check_range(const std::string& name, const In& q0, const Model& ma, const Model& mb, const In& t_start,
                 const In& t_end, const loading_path::Settings& s, const In& tols, std::size_t start,
                 std::size_t stop) {
  const std::size_t nq = mb.n_unknowns(), nt = mb.n_tendons;
  check(q0.ndim() == 2 && q0.shape(1) == nq, name, "q0 must be (B, m), m the model's unknowns");
  const std::size_t B = q0.shape(0);
  check(ma.n_unknowns() == nq && ma.n_tendons == nt, name, "ma and mb must be models of one robot");
  check(mb.tension.size() == nt && ma.tension.size() == nt, name, "a model's tension must have n_tendons entries");
  check(t_end.ndim() == 2 && t_end.shape(0) == B && t_end.shape(1) == nt, name, "t_end must be (B, n_tendons)");
  check(t_start.ndim() == 2 && t_start.shape(0) == B && t_start.shape(1) == nt, name,
        "t_start must be (B, n_tendons)");
  check(tols.ndim() == 2 && tols.shape(0) == B && tols.shape(1) == 2, name, "tols must be (B, 2)");
  check(start <= stop && stop <= B, name, "need 0 <= start <= stop <= B");
  check(s.stepping >= 0 && s.stepping <= loading_path::STEP_CONTINUE, name, "settings.stepping must be 0 to 3");
  check(s.fold >= loading_path::FOLD_RELAX && s.fold <= loading_path::FOLD_STOP, name,
        "settings.fold must be 0 to 2");
  check(s.max_iter >= 0 && s.step_iter >= 0, name, "settings.max_iter and step_iter must be >= 0");
}

// solve_range_<suffix>: loading_path::solve_range for the packed model type Model (its Python class's
// "model" is the name said in the docstring).
template <class Model>
void bind_solve_range(nb::module_& m, const std::string& suffix, const char* model) {
  const std::string name = "solve_range_" + suffix;
  const std::string doc =
      "Solve, or continue, the cases start <= b < stop of a batch with the " + std::string(model) +
      " (the GIL released): the twin\n"
      "of pytdcr.statics.kernels.loading_path.solve_range, with the two packed models of the homotopy (the\n"
      "core's, in place of numba's packed named tuples). q0 (B, m) start points; t_start, t_end (B, nt) tensions\n"
      "[N]; settings with the fields of loading_path.Settings (stepping 0-2 a solve of mb at t_end from q0, 3 a\n"
      "continuation from ma at t_start); tols (B, 2) each case's tolerance and load-step tolerance [N m]. Writes\n"
      "rows start..stop-1 of out_q (B, m) float64, out_ok (B,) bool, out_res (B,) float64, out_it, out_steps,\n"
      "out_path (B,) int64.";
  m.def(
      name.c_str(),
      [name](In q0, const Model& ma, const Model& mb, In t_start, In t_end, nb::handle settings, In tols,
             std::size_t start, std::size_t stop, OutF out_q, OutB out_ok, OutF out_res, OutI out_it,
             OutI out_steps, OutI out_path) {
        const loading_path::Settings s = settings_from(settings);
        check_range(name, q0, ma, mb, t_start, t_end, s, tols, start, stop);
        const std::size_t nq = mb.n_unknowns(), B = q0.shape(0);
        check(out_q.ndim() == 2 && out_q.shape(0) == B && out_q.shape(1) == nq, name, "out_q must be (B, m)");
        for (std::size_t size : {out_ok.ndim() == 1 ? out_ok.shape(0) : 0, out_res.ndim() == 1 ? out_res.shape(0) : 0,
                                 out_it.ndim() == 1 ? out_it.shape(0) : 0,
                                 out_steps.ndim() == 1 ? out_steps.shape(0) : 0,
                                 out_path.ndim() == 1 ? out_path.shape(0) : 0})
          check(size == B, name, "out_ok, out_res, out_it, out_steps and out_path must be (B,)");
        nb::gil_scoped_release release;
        loading_path::solve_range(q0.data(), ma, mb, t_start.data(), t_end.data(), mb.n_tendons, s, tols.data(),
                                  start, stop, out_q.data(), out_ok.data(), out_res.data(), out_it.data(),
                                  out_steps.data(), out_path.data());
      },
      nb::arg("q0"), nb::arg("ma"), nb::arg("mb"), nb::arg("t_start"), nb::arg("t_end"), nb::arg("settings"),
      nb::arg("tols"), nb::arg("start"), nb::arg("stop"), nb::arg("out_q").noconvert(), nb::arg("out_ok").noconvert(),
      nb::arg("out_res").noconvert(), nb::arg("out_it").noconvert(), nb::arg("out_steps").noconvert(),
      nb::arg("out_path").noconvert(), doc.c_str());

  const std::string pname = "_profile_range_" + suffix;
  m.def(
      pname.c_str(),
      [pname](In q0, const Model& ma, const Model& mb, In t_start, In t_end, nb::handle settings, In tols,
              bool timed) {
        const loading_path::Settings s = settings_from(settings);
        const std::size_t B = q0.ndim() == 2 ? q0.shape(0) : 0;
        check_range(pname, q0, ma, mb, t_start, t_end, s, tols, 0, B);
        const std::size_t nq = mb.n_unknowns();
        std::vector<double> q(B * nq), res(B);
        std::vector<std::int64_t> it(B), steps(B), path(B);
        std::unique_ptr<bool[]> ok(new bool[B]());
        std::vector<loading_path::Profile> prof(B);
        for (auto& p : prof) p.timed = timed;
        {
          nb::gil_scoped_release release;
          loading_path::solve_range(q0.data(), ma, mb, t_start.data(), t_end.data(), mb.n_tendons, s, tols.data(), 0,
                                    B, q.data(), ok.get(), res.data(), it.data(), steps.data(), path.data(),
                                    prof.data());
        }
        Array q_out = new_array({B, nq}), counts = new_array({B, 5}),
              secs = new_array({B, 4}), res_out = new_array({B});
        for (std::size_t b = 0; b < B; ++b) {
          for (std::size_t u = 0; u < nq; ++u) q_out.data()[b * nq + u] = q[b * nq + u];
          res_out.data()[b] = ok[b] ? res[b] : -res[b] - 1.0;  // converged: the residual; else -(1 + residual)
          const loading_path::Profile& p = prof[b];
          const double c[5] = {double(p.residuals), double(p.jacobians), double(p.factorisations), double(steps[b]),
                               double(path[b])};
          for (int k = 0; k < 5; ++k) counts.data()[b * 5 + k] = c[k];
          const double t[4] = {p.residual_s, p.jacobian_s, p.linalg_s, p.total_s};
          for (int k = 0; k < 4; ++k) secs.data()[b * 4 + k] = t[k];
        }
        return std::make_tuple(q_out, res_out, counts, secs);
      },
      nb::arg("q0"), nb::arg("ma"), nb::arg("mb"), nb::arg("t_start"), nb::arg("t_end"), nb::arg("settings"),
      nb::arg("tols"), nb::arg("timed") = true,
      ("Internal (bench/solve_profile.py): " + name + " over every case, one thread, with each case's work:\n"
       "returns q (B, m); res (B,) max |residual| [N m] where converged, else -(1 + it); counts (B, 5) float:\n"
       "residual-only evaluations, Jacobian evaluations, dense factorisations, load steps, path code; seconds\n"
       "(B, 4): in residuals, in Jacobians, in factorisations, in all (zero unless timed).")
          .c_str());
}

}  // namespace

void bind_loading_path(nb::module_& m) {
  bind_solve_range<PccModel>(m, "pcc", "PCC model (PccModel)");
  bind_solve_range<SscrModel>(m, "sscr", "subsegment Cosserat rod (SscrModel)");

  m.def(
      "_lu_solve",
      [](In a, In b) -> nb::object {
        const std::size_t n = square(a, "_lu_solve");
        if (b.ndim() != 1 || b.shape(0) != n) throw std::invalid_argument("_lu_solve: b must be (n,)");
        std::vector<double> lu(n * n);
        std::vector<std::size_t> piv(n);
        Array x = new_array({n});
        if (!solve(a.data(), b.data(), n, x.data(), lu.data(), piv.data())) return nb::none();
        return nb::cast(x);
      },
      nb::arg("a"), nb::arg("b"),
      "Internal (tests of linalg.hpp): x (n,) with a x = b by LU with partial pivoting; None where a or b is not\n"
      "finite or a is exactly singular (where np.linalg.solve raises).");
  m.def(
      "_lu_solve_by_transpose",
      [](In a, In b) -> nb::object {
        const std::size_t n = square(a, "_lu_solve_by_transpose");
        if (b.ndim() != 1 || b.shape(0) != n)
          throw std::invalid_argument("_lu_solve_by_transpose: b must be (n,)");
        std::vector<double> lu(n * n);
        std::vector<std::size_t> piv(n);
        Array x = new_array({n});
        if (!solve_by_transpose(a.data(), b.data(), n, x.data(), lu.data(), piv.data())) return nb::none();
        return nb::cast(x);
      },
      nb::arg("a"), nb::arg("b"),
      "Internal (tests of linalg.hpp): x (n,) with a x = b by the LU factors of a^T (the solver's way); None where\n"
      "a or b is not finite or a is exactly singular.");
  m.def(
      "_lu_slogdet",
      [](In a) {
        const std::size_t n = square(a, "_lu_slogdet");
        std::vector<double> lu(n * n);
        std::vector<std::size_t> piv(n);
        double sign, logdet;
        slogdet(a.data(), n, lu.data(), piv.data(), sign, logdet);
        return std::make_tuple(sign, logdet);
      },
      nb::arg("a"),
      "Internal (tests of linalg.hpp): (sign, log|det a|) as np.linalg.slogdet; (0.0, -inf) where a is exactly\n"
      "singular.");
}

}  // namespace pytdcr
