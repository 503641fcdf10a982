// Python bindings of stiffness.hpp for the PCC model and the subsegment Cosserat rod: pytdcr._core.jacobian_range_X,
// largest_residuals_X and tip_gradient_range_X (X = pcc, sscr), the twins of pytdcr.statics.kernels.stiffness's
// functions (same arguments, the packed model a PccModel or an SscrModel), writing into the caller's arrays with
// the GIL released.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "pcc.hpp"
#include "sscr.hpp"
#include "stiffness.hpp"

namespace nb = nanobind;

namespace pytdcr {

namespace {

using In = nb::ndarray<const double, nb::c_contig, nb::device::cpu>;
using Rows = nb::ndarray<const std::int64_t, nb::c_contig, nb::device::cpu>;
using OutF = nb::ndarray<double, nb::c_contig, nb::device::cpu>;

void check(bool ok, const char* function, const std::string& what) {
  if (!ok) throw std::invalid_argument(std::string(function) + ": " + what);
}

// q (B, m) and tensions (B, nt) of model, checked.
template <class Model>
std::size_t check_batch(const In& q, const In& tensions, const Model& model, const char* function) {
  check(q.ndim() == 2 && q.shape(1) == model.n_unknowns(), function, "q must be (B, m), m the model's unknowns");
  check(tensions.ndim() == 2 && tensions.shape(0) == q.shape(0) && tensions.shape(1) == model.n_tendons, function,
        "tensions must be (B, n_tendons), one row per row of q");
  return q.shape(0);
}

void check_rows(const Rows& rows, std::size_t count, std::size_t B, const char* function) {
  check(rows.ndim() == 1 && rows.shape(0) >= count, function, "rows must be (K,), K >= the rows asked for");
  for (std::size_t k = 0; k < count; ++k)
    check(rows.data()[k] >= 0 && static_cast<std::size_t>(rows.data()[k]) < B, function, "rows must index q");
}

template <class Model>
void bind_for(nb::module_& m, const std::string& suffix) {
  const std::string jac = "jacobian_range_" + suffix, res = "largest_residuals_" + suffix,
                    grad = "tip_gradient_range_" + suffix;
  m.def(
      jac.c_str(),
      [](In q, const Model& model, In tensions, Rows rows, std::size_t start, std::size_t stop, OutF out) {
        const char* f = "jacobian_range";
        const std::size_t B = check_batch(q, tensions, model, f), nq = model.n_unknowns();
        check(start <= stop, f, "start must not exceed stop");
        check_rows(rows, stop, B, f);
        check(out.ndim() == 3 && out.shape(0) >= stop - start && out.shape(1) == nq && out.shape(2) == nq, f,
              "out must be (K, m, m), K >= stop - start");
        nb::gil_scoped_release release;
        jacobian_range(q.data(), nq, model, tensions.data(), rows.data(), start, stop, out.data());
      },
      nb::arg("q"), nb::arg("model"), nb::arg("tensions"), nb::arg("rows"), nb::arg("start"), nb::arg("stop"),
      nb::arg("out"),
      "For k in [start, stop): the residual's exact Jacobian (m, m) at the equilibrium q[rows[k]] (B, m) of\n"
      "model at the actuator tensions tensions[rows[k]] (B, nt) [N], at full load, into out[k - start].");
  m.def(
      res.c_str(),
      [](In q, const Model& model, In tensions, Rows rows, OutF out) {
        const char* f = "largest_residuals";
        const std::size_t B = check_batch(q, tensions, model, f);
        check(rows.ndim() == 1, f, "rows must be (K,)");
        const std::size_t count = rows.shape(0);
        check_rows(rows, count, B, f);
        check(out.ndim() == 1 && out.shape(0) == count, f, "out must be (K,), one per row asked for");
        nb::gil_scoped_release release;
        largest_residuals(q.data(), model.n_unknowns(), model, tensions.data(), rows.data(), count, out.data());
      },
      nb::arg("q"), nb::arg("model"), nb::arg("tensions"), nb::arg("rows"), nb::arg("out"),
      "For each k: max |residual| [N m] at q[rows[k]] (B, m) of model at the actuator tensions\n"
      "tensions[rows[k]] (B, nt) [N], at full load, into out[k] (NaN where a residual is NaN).");
  m.def(
      grad.c_str(),
      [](In q, const Model& model, In tensions, std::size_t start, std::size_t stop, OutF out) {
        const char* f = "tip_gradient_range";
        const std::size_t B = check_batch(q, tensions, model, f);
        check(start <= stop && stop <= B, f, "rows start <= b < stop must index q");
        check(out.ndim() == 3 && out.shape(0) == B && out.shape(1) == 3 && out.shape(2) == model.n_tendons, f,
              "out must be (B, 3, n_tendons)");
        nb::gil_scoped_release release;
        tip_gradient_range(q.data(), model, tensions.data(), start, stop, out.data());
      },
      nb::arg("q"), nb::arg("model"), nb::arg("tensions"), nb::arg("start"), nb::arg("stop"), nb::arg("out"),
      "Rows start <= b < stop: the tip's exact derivative by the tensions (3, nt) [m/N] at the equilibrium q[b]\n"
      "(B, m) of model at the actuator tensions tensions[b] (B, nt) [N], into out[b]; rows whose q[b] is not\n"
      "finite, or whose Jacobian is singular, are left as they are.");
}

}  // namespace

void bind_stiffness(nb::module_& m) {
  bind_for<PccModel>(m, "pcc");
  bind_for<SscrModel>(m, "sscr");
}

}  // namespace pytdcr
