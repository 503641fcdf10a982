// Python bindings of kinematics.hpp (pytdcr._core.subsegment, subsegment_derivatives, frames).
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/tuple.h>

#include <stdexcept>

#include "bind_common.hpp"
#include "kinematics.hpp"

namespace nb = nanobind;

namespace pytdcr {

using bind::Array;
using In = nb::ndarray<const double, nb::c_contig, nb::device::cpu>;

using bind::new_array;

void bind_kinematics(nb::module_& m) {
  m.def(
      "subsegment",
      [](double beta, double gamma, double eps, double length) {
        Array R = new_array({3, 3}), d = new_array({3}), pg = new_array({3});
        subsegment(beta, gamma, eps, length, R.data(), d.data(), pg.data());
        return nb::make_tuple(R, d, pg);
      },
      nb::arg("beta"), nb::arg("gamma"), nb::arg("eps"), nb::arg("length"),
      "The rotation (3, 3) and translation (3,) [m] of frame i in frame i-1 and the backbone piece's centroid (3,)\n"
      "[m] of one subsegment of bending (beta, gamma) [1/m], twist eps [rad] and length [m].");
  m.def(
      "subsegment_derivatives",
      [](double beta, double gamma, double eps, double length) {
        Array dR = new_array({3, 3, 3}), dd = new_array({3, 3});
        subsegment_derivatives(beta, gamma, eps, length, dR.data(), dd.data());
        return nb::make_tuple(dR, dd);
      },
      nb::arg("beta"), nb::arg("gamma"), nb::arg("eps"), nb::arg("length"),
      "The derivatives of one subsegment's transform by (beta [1/m], gamma [1/m], eps [rad]), in closed form:\n"
      "dR (3, 3, 3), dR[a] = dR/dq_a, and dd (3, 3), dd[a] = dd/dq_a [m per unit of q_a].");
  m.def(
      "frames",
      [](In q, In sub) {
        if (q.ndim() != 1 || sub.ndim() != 2 || sub.shape(1) != 5 || q.shape(0) != 3 * sub.shape(0))
          throw std::invalid_argument("frames: q must be (3N,) and sub (N, 5)");
        const std::size_t n = sub.shape(0);
        Array pos = new_array({n + 1, 3}), rot = new_array({n + 1, 3, 3});
        frames(q.data(), sub.data(), n, pos.data(), rot.data());
        return nb::make_tuple(pos, rot);
      },
      nb::arg("q"), nb::arg("sub"),
      "The disk frames in the base frame: positions (N+1, 3) [m] and rotations (N+1, 3, 3), from the unknowns\n"
      "q (3N,) and the packed subsegments (N, 5) (lengths in the first column).");
}

}  // namespace pytdcr
