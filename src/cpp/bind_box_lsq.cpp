// Python binding of box_lsq.hpp (pytdcr._core.box_least_squares), the workspace's boundary-search step.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>

#include "bind_common.hpp"
#include "box_lsq.hpp"

namespace nb = nanobind;

namespace pytdcr {

namespace {
using In = nb::ndarray<const double, nb::c_contig, nb::device::cpu>;
using bind::Array;
}  // namespace

void bind_box_lsq(nb::module_& m) {
  m.def(
      "box_least_squares",
      [](In A, In y, double damp, In lower, In upper) {
        const char* name = "box_least_squares: ";
        if (A.ndim() != 2) throw std::invalid_argument(std::string(name) + "A must be (m, k)");
        const std::size_t rows = A.shape(0), k = A.shape(1);
        if (y.ndim() != 1 || y.shape(0) != rows) throw std::invalid_argument(std::string(name) + "y must be (m,)");
        if (lower.ndim() != 1 || lower.shape(0) != k || upper.ndim() != 1 || upper.shape(0) != k)
          throw std::invalid_argument(std::string(name) + "lower and upper must be (k,)");
        if (!(damp > 0.0) || !std::isfinite(damp))
          throw std::invalid_argument(std::string(name) + "damp must be finite and > 0");
        for (std::size_t i = 0; i < k; ++i)
          if (!(lower.data()[i] <= 0.0 && 0.0 <= upper.data()[i]))
            throw std::invalid_argument(std::string(name) + "need lower <= 0 <= upper");
        Array x = bind::new_array({k});
        double* data = x.data();
        bool ok;
        {
          nb::gil_scoped_release release;
          ok = box_lsq::solve_box(A.data(), rows, k, y.data(), damp, lower.data(), upper.data(), data);
        }
        if (!ok) throw std::runtime_error(std::string(name) + "a free block is singular or not finite");
        return x;
      },
      nb::arg("A"), nb::arg("y"), nb::arg("damp"), nb::arg("lower"), nb::arg("upper"),
      "x (k,) minimising |A x - y|^2 + damp^2 |x|^2 with lower <= x <= upper, A (m, k), y (m,), damp > 0,\n"
      "lower <= 0 <= upper (k,): a primal active-set method from x = 0 (src/cpp/box_lsq.hpp).");
}

}  // namespace pytdcr
