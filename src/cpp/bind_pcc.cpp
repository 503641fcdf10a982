// Python bindings of pcc.hpp: pytdcr._core.PccModel (the packed PCC model, its residual, exact Jacobian and
// tendon tensions, the tip Jacobian) and _bench_evaluate (the kernel's own time per call, measured in C++).
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <chrono>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

#include "bind_common.hpp"
#include "pcc.hpp"

namespace nb = nanobind;

namespace pytdcr {

namespace {

using Out = nb::ndarray<nb::numpy, double>;
using In = nb::ndarray<const double, nb::c_contig, nb::device::cpu>;
using InLong = nb::ndarray<const long, nb::c_contig, nb::device::cpu>;

using bind::new_array;

// A new zeroed numpy array of this shape, owning its memory.
Out new_out(std::initializer_list<std::size_t> shape) { return new_array(shape); }

// A numpy copy of a model's array, of this shape.
Out copy_out(const std::vector<double>& v, std::initializer_list<std::size_t> shape) {
  return bind::copy_array(v.data(), shape);
}

std::string shape_of(const In& a) {
  std::string s = "(";
  for (std::size_t d = 0; d < a.ndim(); ++d) s += (d ? ", " : "") + std::to_string(a.shape(d));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

// Raise ValueError unless a has the shape given (rows, cols; cols == 0 for a vector).
void check_shape(const In& a, const char* name, std::size_t rows, std::size_t cols, const char* want) {
  const bool ok = cols == 0 ? (a.ndim() == 1 && a.shape(0) == rows)
                            : (a.ndim() == 2 && a.shape(0) == rows && a.shape(1) == cols);
  if (!ok) throw std::invalid_argument(std::string("PccModel: ") + name + " must have shape " + want + ", got " +
                                       shape_of(a));
}

std::vector<double> to_vector(const In& a) { return std::vector<double>(a.data(), a.data() + a.size()); }

// The packed model from numpy arrays (layouts in pcc.hpp), with their shapes and values checked.
PccModel make_model(In sub, In holes, InLong anchor, In fric, In tension, In grav, In pforce, In pmoment,
                    int balance) {
  if (sub.ndim() != 2 || sub.shape(1) != 5 || sub.shape(0) < 1)
    throw std::invalid_argument("PccModel: sub must have shape (N, 5) with N >= 1, got " + shape_of(sub));
  if (holes.ndim() != 2 || holes.shape(1) != 2)
    throw std::invalid_argument("PccModel: holes must have shape (n_tendons, 2), got " + shape_of(holes));
  const std::size_t n = sub.shape(0), nt = holes.shape(0);
  if (anchor.ndim() != 1 || anchor.shape(0) != nt)
    throw std::invalid_argument("PccModel: anchor must have shape (" + std::to_string(nt) + ",) (one per hole)");
  check_shape(fric, "fric", 4, 0, "(4,)");
  check_shape(tension, "tension", nt, 0, ("(" + std::to_string(nt) + ",)").c_str());
  check_shape(grav, "grav", 3, 0, "(3,)");
  const std::string n3 = "(" + std::to_string(n) + ", 3)";
  check_shape(pforce, "pforce", n, 3, n3.c_str());
  check_shape(pmoment, "pmoment", n, 3, n3.c_str());
  for (std::size_t c = 0; c < nt; ++c)
    if (anchor.data()[c] < 1 || anchor.data()[c] > static_cast<long>(n))
      throw std::invalid_argument("PccModel: anchor disks must be between 1 and " + std::to_string(n) + ", got " +
                                  std::to_string(anchor.data()[c]));
  if (balance != BALANCE_BASE && balance != BALANCE_MIDPOINT)
    throw std::invalid_argument("PccModel: balance must be 0 (BALANCE_BASE) or 1 (BALANCE_MIDPOINT), got " +
                                std::to_string(balance));
  PccModel model;
  model.n_disks = n;
  model.n_tendons = nt;
  model.sub = to_vector(sub);
  model.holes = to_vector(holes);
  model.anchor.assign(anchor.data(), anchor.data() + nt);
  model.fric = to_vector(fric);
  model.tension = to_vector(tension);
  model.grav = to_vector(grav);
  model.pforce = to_vector(pforce);
  model.pmoment = to_vector(pmoment);
  model.balance = balance;
  return model;
}

void check_q(const In& q, const PccModel& model, const char* name) {
  if (q.ndim() != 1 || q.shape(0) != model.n_unknowns())
    throw std::invalid_argument(std::string("PccModel: ") + name + " must have shape (" +
                                std::to_string(model.n_unknowns()) + ",), got " + shape_of(q));
}

// This thread's scratch, resized to the model's (allocates only when the size changes).
PccWork& scratch(const PccModel& model) {
  thread_local PccWork work;
  if (work.n_disks != model.n_disks || work.n_tendons != model.n_tendons || work.R.empty())
    work = make_work(model);
  return work;
}

}  // namespace

void bind_pcc(nb::module_& m) {
  nb::class_<PccModel>(m, "PccModel",
                       "The packed PCC model (MODEL.md): a robot under its loads, as the numba kernels' Packed\n"
                       "(pytdcr.statics.kernels.pcc), with copies of its arrays.")
      .def(nb::new_(&make_model), nb::arg("sub"), nb::arg("holes"), nb::arg("anchor"), nb::arg("fric"),
           nb::arg("tension"), nb::arg("grav"), nb::arg("pforce"), nb::arg("pmoment"), nb::arg("balance") = 0,
           "sub (N, 5): length [m], EI [N m^2], GJ [N m^2], disk mass [kg], backbone piece mass [kg];\n"
           "holes (nt, 2) [m]; anchor (nt,) 1-based anchor disks; fric (4,): law code, mu0, decay [1/rad],\n"
           "mode; tension (nt,) [N]; grav (3,) [m/s^2]; pforce, pmoment (N, 3) [N, N m]; balance 0 (base)\n"
           "or 1 (midpoint). Raises ValueError on a wrong shape.")
      .def_static(
          "from_packed",
          [](nb::handle p) {
            return make_model(nb::cast<In>(p.attr("sub")), nb::cast<In>(p.attr("holes")),
                              nb::cast<InLong>(p.attr("anchor")), nb::cast<In>(p.attr("fric")),
                              nb::cast<In>(p.attr("tension")), nb::cast<In>(p.attr("grav")),
                              nb::cast<In>(p.attr("pforce")), nb::cast<In>(p.attr("pmoment")),
                              nb::cast<int>(p.attr("balance")));
          },
          nb::arg("packed"), "The model of a numba Packed namedtuple (pytdcr.statics.kernels.pcc.Packed).")
      .def_prop_ro("n_disks", [](const PccModel& s) { return s.n_disks; })
      .def_prop_ro("n_tendons", [](const PccModel& s) { return s.n_tendons; })
      .def_prop_ro("n_unknowns", &PccModel::n_unknowns)
      .def_prop_ro("balance", [](const PccModel& s) { return s.balance; })
      .def_prop_ro("sub", [](const PccModel& s) { return copy_out(s.sub, {s.n_disks, 5}); }, nb::rv_policy::move)
      .def_prop_ro("holes", [](const PccModel& s) { return copy_out(s.holes, {s.n_tendons, 2}); }, nb::rv_policy::move)
      .def_prop_ro("anchor", [](const PccModel& s) { return s.anchor; },
                   "copy of the 1-based anchor disks, as a list")
      .def_prop_ro("fric", [](const PccModel& s) { return copy_out(s.fric, {4}); }, nb::rv_policy::move)
      .def_prop_ro("tension", [](const PccModel& s) { return copy_out(s.tension, {s.n_tendons}); }, nb::rv_policy::move)
      .def_prop_ro("grav", [](const PccModel& s) { return copy_out(s.grav, {3}); }, nb::rv_policy::move)
      .def_prop_ro("pforce", [](const PccModel& s) { return copy_out(s.pforce, {s.n_disks, 3}); }, nb::rv_policy::move)
      .def_prop_ro(
          "pmoment", [](const PccModel& s) { return copy_out(s.pmoment, {s.n_disks, 3}); }, nb::rv_policy::move)
      .def(
          "evaluate",
          [](const PccModel& s, In q, double lam, bool want_jac) {
            check_q(q, s, "q");
            const std::size_t mm = s.n_unknowns();
            Out r = new_out({mm});
            Out T = new_out({s.n_disks + 2, s.n_tendons});
            nb::object J = nb::none();
            double* Jp = nullptr;
            if (want_jac) {
              Out Ja = new_out({mm, mm});
              Jp = Ja.data();
              J = nb::cast(Ja);
            }
            PccWork& work = scratch(s);
            evaluate(q.data(), lam, s, want_jac, r.data(), Jp, work);
            for (std::size_t j = 0; j < work.T.size(); ++j) T.data()[j] = work.T[j];
            return nb::make_tuple(r, J, T);
          },
          nb::arg("q"), nb::arg("lam") = 1.0, nb::arg("want_jac") = false,
          "Residual r (3N,) [N m] at q (3N,) with every load scaled by lam, the exact Jacobian (3N, 3N) if\n"
          "want_jac (else None) and the tendon tensions T (N+2, n_tendons) [N] (row i: piece i).")
      .def(
          "largest_angle",
          [](const PccModel& s, In dq) {
            check_q(dq, s, "dq");
            return largest_angle(dq.data(), s);
          },
          nb::arg("dq"), "Largest change of bend angle or twist of one subsegment for a change dq (3N,) [rad].")
      .def(
          "tip_jacobian",
          [](const PccModel& s, In q) {
            check_q(q, s, "q");
            Out out = new_out({3, s.n_unknowns()});
            tip_jacobian_of(q.data(), s, scratch(s), out.data());
            return out;
          },
          nb::arg("q"), "Exact derivative of the tip position by the unknowns, (3, 3N) [m per unit of q].")
      .def(
          "with_tension",
          [](const PccModel& s, In tension) {
            if (tension.ndim() != 1 || tension.shape(0) != s.n_tendons)
              throw std::invalid_argument("PccModel: tension must have shape (" + std::to_string(s.n_tendons) +
                                          ",), got " + shape_of(tension));
            PccModel out;
            with_tension(s, tension.data(), out);
            return out;
          },
          nb::arg("tension"), "The model with other actuator tensions (n_tendons,) [N].")
      .def(
          "blend",
          [](const PccModel& a, const PccModel& b, double s) {
            if (a.n_disks != b.n_disks || a.n_tendons != b.n_tendons)
              throw std::invalid_argument("PccModel.blend: the two models must be of the same robot");
            PccModel out;
            blend(a, b, s, out);
            return out;
          },
          nb::arg("other"), nb::arg("s"),
          "The model other under the loads (1 - s) self + s other (tensions, gravity, point wrenches).");

  m.def(
      "_bench_evaluate",
      [](const PccModel& model, In q, double lam, bool want_jac, std::size_t repeats) {
        check_q(q, model, "q");
        const std::size_t mm = model.n_unknowns();
        std::vector<double> r(mm), J(want_jac ? mm * mm : 1);
        PccWork work = make_work(model);
        nb::gil_scoped_release release;
        evaluate(q.data(), lam, model, want_jac, r.data(), J.data(), work);  // warm the caches
        const auto t0 = std::chrono::steady_clock::now();
        for (std::size_t j = 0; j < repeats; ++j) evaluate(q.data(), lam, model, want_jac, r.data(), J.data(), work);
        const auto t1 = std::chrono::steady_clock::now();
        return std::chrono::duration<double>(t1 - t0).count() / static_cast<double>(repeats ? repeats : 1);
      },
      nb::arg("model"), nb::arg("q"), nb::arg("lam"), nb::arg("want_jac"), nb::arg("repeats"),
      "Internal: seconds per call of evaluate, timed by a loop of `repeats` calls in C++ (GIL released).");
}

}  // namespace pytdcr
