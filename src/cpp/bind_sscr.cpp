// Python bindings of sscr.hpp: pytdcr._core.SscrModel (the packed subsegment Cosserat rod: its residual, exact
// Jacobian and tendon tensions, the tip and pose Jacobians, the shape, the tangent stiffness), the module function
// stiffness_range_sscr (GIL released) and _bench_evaluate_sscr (the kernel's own time per call, timed in C++).
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "bind_common.hpp"
#include "sscr.hpp"

namespace nb = nanobind;

namespace pytdcr {

namespace {

using Out = nb::ndarray<nb::numpy, double>;
using In = nb::ndarray<const double, nb::c_contig, nb::device::cpu>;
using InInt = nb::ndarray<const std::int64_t, nb::c_contig, nb::device::cpu>;
using Inout = nb::ndarray<double, nb::c_contig, nb::device::cpu>;

// A new zeroed numpy array of this shape, owning its memory.
Out new_out(std::initializer_list<std::size_t> shape) { return bind::new_array(shape); }

// A numpy copy of the numbers at data, of this shape.
Out copy_out(const double* data, std::initializer_list<std::size_t> shape) { return bind::copy_array(data, shape); }

template <class A>
std::string shape_of(const A& a) {
  std::string s = "(";
  for (std::size_t d = 0; d < a.ndim(); ++d) s += (d ? ", " : "") + std::to_string(a.shape(d));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

std::string dims(std::initializer_list<std::size_t> shape) {
  std::string s = "(";
  std::size_t d = 0;
  for (std::size_t x : shape) s += (d++ ? ", " : "") + std::to_string(x);
  return s + (shape.size() == 1 ? ",)" : ")");
}

// Raise ValueError (std::invalid_argument) unless a has this shape.
template <class A>
void check_shape(const A& a, const char* where, const char* name, std::initializer_list<std::size_t> shape) {
  bool ok = a.ndim() == shape.size();
  std::size_t d = 0;
  for (std::size_t x : shape) ok = ok && a.shape(d++) == x;
  if (!ok)
    throw std::invalid_argument(std::string(where) + ": " + name + " must have shape " + dims(shape) + ", got " +
                                shape_of(a));
}

std::vector<double> to_vector(const In& a) { return std::vector<double>(a.data(), a.data() + a.size()); }

// The packed model from numpy arrays (layouts in sscr.hpp), with their shapes and values checked.
SscrModel make_model(In sub, In holes, InInt anchor, In fric, In tension, In grav, In pforce, In pmoment, In rod) {
  const char* where = "SscrModel";
  if (sub.ndim() != 2 || sub.shape(1) != 5 || sub.shape(0) < 1)
    throw std::invalid_argument("SscrModel: sub must have shape (N, 5) with N >= 1, got " + shape_of(sub));
  if (holes.ndim() != 2 || holes.shape(1) != 2)
    throw std::invalid_argument("SscrModel: holes must have shape (n_tendons, 2), got " + shape_of(holes));
  const std::size_t n = sub.shape(0), nt = holes.shape(0);
  check_shape(anchor, where, "anchor", {nt});
  check_shape(fric, where, "fric", {4});
  check_shape(tension, where, "tension", {nt});
  check_shape(grav, where, "grav", {3});
  check_shape(pforce, where, "pforce", {n, 3});
  check_shape(pmoment, where, "pmoment", {n, 3});
  check_shape(rod, where, "rod", {5});
  for (std::size_t c = 0; c < nt; ++c)
    if (anchor.data()[c] < 1 || anchor.data()[c] > static_cast<std::int64_t>(n))
      throw std::invalid_argument("SscrModel: anchor disks must be between 1 and " + std::to_string(n) + ", got " +
                                  std::to_string(anchor.data()[c]));
  const double steps = rod.data()[4];
  if (!(steps >= 1.0 && steps <= 1e6))
    throw std::invalid_argument("SscrModel: rod[4] (Runge-Kutta steps per subsegment) must be >= 1, got " +
                                std::to_string(steps));
  SscrModel model;
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
  model.rod = to_vector(rod);
  return model;
}

void check_q(const In& q, const SscrModel& model, const char* name) {
  if (q.ndim() != 1 || q.shape(0) != model.n_unknowns())
    throw std::invalid_argument(std::string("SscrModel: ") + name + " must have shape (" +
                                std::to_string(model.n_unknowns()) + ",), got " + shape_of(q));
}

// This thread's scratch, resized to the model's (allocates only when the size changes), and a Jacobian buffer.
struct Scratch {
  SscrWork work;
  std::vector<double> r, J;
};

Scratch& scratch(const SscrModel& model) {
  thread_local Scratch s;
  if (s.work.n_disks != model.n_disks || s.work.n_tendons != model.n_tendons || s.work.pos.empty()) {
    s.work = make_work(model);
    s.r.assign(model.n_unknowns(), 0.0);
    s.J.assign(model.n_unknowns() * model.n_unknowns(), 0.0);
  }
  return s;
}

// Evaluate with the Jacobian at q, full load, into this thread's scratch (for the chained sensitivities S).
SscrWork& evaluated(const SscrModel& model, const In& q) {
  Scratch& s = scratch(model);
  evaluate(q.data(), 1.0, model, true, s.r.data(), s.J.data(), s.work);
  return s.work;
}

}  // namespace

void bind_sscr(nb::module_& m) {
  nb::class_<SscrModel>(m, "SscrModel",
                        "The packed subsegment Cosserat rod (pytdcr.statics.kernels.sscr.SSCRPacked): a robot under\n"
                        "its loads, with copies of its arrays.")
      .def(nb::new_(&make_model), nb::arg("sub"), nb::arg("holes"), nb::arg("anchor"), nb::arg("fric"),
           nb::arg("tension"), nb::arg("grav"), nb::arg("pforce"), nb::arg("pmoment"), nb::arg("rod"),
           "sub (N, 5): length [m], EI [N m^2], GJ [N m^2], disk mass [kg], backbone piece mass [kg];\n"
           "holes (nt, 2) [m]; anchor (nt,) 1-based anchor disks; fric (4,): law code, mu0, decay [1/rad],\n"
           "mode; tension (nt,) [N]; grav (3,) [m/s^2]; pforce, pmoment (N, 3) [N, N m]; rod (5,): GA [N],\n"
           "EA [N], mass per length [kg/m], shear and extension (1) or not (0), Runge-Kutta steps per\n"
           "subsegment. Raises ValueError on a wrong shape.")
      .def_static(
          "from_packed",
          [](nb::handle p) {
            return make_model(nb::cast<In>(p.attr("sub")), nb::cast<In>(p.attr("holes")),
                              nb::cast<InInt>(p.attr("anchor")), nb::cast<In>(p.attr("fric")),
                              nb::cast<In>(p.attr("tension")), nb::cast<In>(p.attr("grav")),
                              nb::cast<In>(p.attr("pforce")), nb::cast<In>(p.attr("pmoment")),
                              nb::cast<In>(p.attr("rod")));
          },
          nb::arg("packed"), "The model of a numba SSCRPacked namedtuple (pytdcr.statics.kernels.sscr).")
      .def_prop_ro("n_disks", [](const SscrModel& s) { return s.n_disks; })
      .def_prop_ro("n_tendons", [](const SscrModel& s) { return s.n_tendons; })
      .def_prop_ro("n_unknowns", &SscrModel::n_unknowns)
      .def_prop_ro("tension", [](const SscrModel& s) { return copy_out(s.tension.data(), {s.n_tendons}); },
                   nb::rv_policy::move)
      .def_prop_ro("grav", [](const SscrModel& s) { return copy_out(s.grav.data(), {3}); }, nb::rv_policy::move)
      .def_prop_ro("pforce", [](const SscrModel& s) { return copy_out(s.pforce.data(), {s.n_disks, 3}); },
                   nb::rv_policy::move)
      .def_prop_ro("pmoment", [](const SscrModel& s) { return copy_out(s.pmoment.data(), {s.n_disks, 3}); },
                   nb::rv_policy::move)
      .def_prop_ro("rod", [](const SscrModel& s) { return copy_out(s.rod.data(), {5}); }, nb::rv_policy::move)
      .def(
          "evaluate",
          [](const SscrModel& s, In q, double lam, bool want_jac) {
            check_q(q, s, "q");
            const std::size_t mm = s.n_unknowns();
            Out r = new_out({mm});
            nb::object J = nb::none();
            double* Jp = nullptr;
            if (want_jac) {
              Out Ja = new_out({mm, mm});
              Jp = Ja.data();
              J = nb::cast(Ja);
            }
            SscrWork& work = scratch(s).work;
            evaluate(q.data(), lam, s, want_jac, r.data(), Jp, work);
            Out T = copy_out(work.T.data(), {s.n_disks + 2, s.n_tendons});
            return nb::make_tuple(r, J, T);
          },
          nb::arg("q"), nb::arg("lam") = 1.0, nb::arg("want_jac") = false,
          "Residual r (6N,) [N m] at q (6N,) with every load scaled by lam, the exact Jacobian (6N, 6N) if\n"
          "want_jac (else None) and the tendon tensions T (N+2, n_tendons) [N] (row i: piece i).")
      .def(
          "largest_angle",
          [](const SscrModel& s, In dq) {
            check_q(dq, s, "dq");
            return largest_angle(dq.data(), s);
          },
          nb::arg("dq"), "How far a change dq (6N,) of the base wrenches bends or twists a subsegment [rad].")
      .def(
          "tip_jacobian",
          [](const SscrModel& s, In q) {
            check_q(q, s, "q");
            SscrWork& work = evaluated(s, q);
            Out out = new_out({3, s.n_unknowns()});
            tip_jacobian_of(q.data(), s, work, out.data());
            return out;
          },
          nb::arg("q"), "Exact derivative of the tip position by the unknowns at q, (3, 6N) [m per unit of q].")
      .def(
          "pose_jacobians",
          [](const SscrModel& s, In q) {
            check_q(q, s, "q");
            SscrWork& work = evaluated(s, q);
            return copy_out(work.S.data(), {s.n_disks + 1, 6, s.n_unknowns()});
          },
          nb::arg("q"),
          "Exact derivatives of every disk's pose by the unknowns at q, (N+1, 6, 6N): position [m per unit of\n"
          "q], then rotation (the angular change w, base frame, dR = [w]x R) (SSCREquations.pose_jacobians).")
      .def(
          "record_shape",
          [](const SscrModel& s, In q) {
            check_q(q, s, "q");
            const std::size_t n = s.n_disks;
            const std::size_t steps = static_cast<std::size_t>(s.rod[4]);
            Out pos = new_out({n + 1, 3}), rot = new_out({n + 1, 3, 3}), curve = new_out({n * steps + 1, 3});
            record_shape(q.data(), s, pos.data(), rot.data(), curve.data());
            return nb::make_tuple(pos, rot, curve);
          },
          nb::arg("q"),
          "Disk positions (N+1, 3) [m], rotations (N+1, 3, 3) and backbone points (N steps + 1, 3) [m] at q.")
      .def(
          "wrenches_from_poses",
          [](const SscrModel& s, In pos, In rot) {
            check_shape(pos, "SscrModel.wrenches_from_poses", "pos", {s.n_disks + 1, 3});
            check_shape(rot, "SscrModel.wrenches_from_poses", "rot", {s.n_disks + 1, 3, 3});
            Out q = new_out({s.n_unknowns()});
            wrenches_from_poses(pos.data(), rot.data(), s, q.data());
            return q;
          },
          nb::arg("pos"), nb::arg("rot"),
          "Base wrenches q (6N,) that balance every disk at the poses pos (N+1, 3) [m], rot (N+1, 3, 3).")
      .def(
          "tangent_stiffness",
          [](const SscrModel& s, In q) {
            check_q(q, s, "q");
            const std::size_t mm = s.n_unknowns();
            Out K = new_out({mm, mm});
            tangent_stiffness(q.data(), s, scratch(s).work, K.data());
            return K;
          },
          nb::arg("q"),
          "The tangent stiffness (6N, 6N) [N m] of the disks' poses at the equilibrium q (6N,)\n"
          "(pytdcr.statics.kernels.sscr.tangent_stiffness).")
      .def(
          "with_tension",
          [](const SscrModel& s, In tension) {
            check_shape(tension, "SscrModel.with_tension", "tension", {s.n_tendons});
            SscrModel out;
            with_tension(s, tension.data(), out);
            return out;
          },
          nb::arg("tension"), "The model with other actuator tensions (n_tendons,) [N].")
      .def(
          "blend",
          [](const SscrModel& a, const SscrModel& b, double s) {
            if (a.n_disks != b.n_disks || a.n_tendons != b.n_tendons)
              throw std::invalid_argument("SscrModel.blend: the two models must be of the same robot");
            SscrModel out;
            blend(a, b, s, out);
            return out;
          },
          nb::arg("other"), nb::arg("s"),
          "The model other under the loads (1 - s) self + s other (tensions, gravity, point wrenches).");

  m.def(
      "stiffness_range_sscr",
      [](In q, const SscrModel& model, In tensions, InInt rows, std::size_t start, std::size_t stop,
         Inout out) {
        const char* where = "stiffness_range_sscr";
        const std::size_t mm = model.n_unknowns();
        if (q.ndim() != 2 || q.shape(1) != mm)
          throw std::invalid_argument(std::string(where) + ": q must have shape (B, " + std::to_string(mm) +
                                      "), got " + shape_of(q));
        const std::size_t batch = q.shape(0);
        check_shape(tensions, where, "tensions", {batch, model.n_tendons});
        if (rows.ndim() != 1) throw std::invalid_argument(std::string(where) + ": rows must be one-dimensional");
        if (start > stop || stop > rows.shape(0))
          throw std::invalid_argument(std::string(where) + ": need start <= stop <= len(rows)");
        if (out.ndim() != 3 || out.shape(0) < stop - start || out.shape(1) != mm || out.shape(2) != mm)
          throw std::invalid_argument(std::string(where) + ": out must have shape (>= stop - start, " +
                                      std::to_string(mm) + ", " + std::to_string(mm) + "), got " + shape_of(out));
        std::vector<long> idx(rows.shape(0));
        for (std::size_t k = 0; k < idx.size(); ++k) idx[k] = static_cast<long>(rows.data()[k]);
        for (std::size_t k = start; k < stop; ++k)
          if (idx[k] < 0 || idx[k] >= static_cast<long>(batch))
            throw std::invalid_argument(std::string(where) + ": rows[" + std::to_string(k) + "] = " +
                                        std::to_string(idx[k]) + " is outside 0.." + std::to_string(batch - 1));
        nb::gil_scoped_release release;
        stiffness_range(q.data(), model, tensions.data(), idx.data(), start, stop, out.data());
      },
      nb::arg("q"), nb::arg("model"), nb::arg("tensions"), nb::arg("rows"), nb::arg("start"), nb::arg("stop"),
      nb::arg("out").noconvert(),
      "For k in start <= k < stop: the tangent stiffness (6N, 6N) [N m] at the equilibrium q[rows[k]] (B, 6N)\n"
      "of model at the actuator tensions tensions[rows[k]] (B, nt) [N], into out[k - start] (the caller's\n"
      "C-contiguous float64 array; the GIL released).");

  m.def(
      "_bench_evaluate_sscr",
      [](const SscrModel& model, In q, double lam, bool want_jac, std::size_t repeats) {
        check_q(q, model, "q");
        const std::size_t mm = model.n_unknowns();
        std::vector<double> r(mm), J(want_jac ? mm * mm : 1);
        SscrWork work = make_work(model);
        nb::gil_scoped_release release;
        evaluate(q.data(), lam, model, want_jac, r.data(), J.data(), work);  // warm the caches
        const auto t0 = std::chrono::steady_clock::now();
        for (std::size_t j = 0; j < repeats; ++j) evaluate(q.data(), lam, model, want_jac, r.data(), J.data(), work);
        const auto t1 = std::chrono::steady_clock::now();
        return std::chrono::duration<double>(t1 - t0).count() / static_cast<double>(repeats ? repeats : 1);
      },
      nb::arg("model"), nb::arg("q"), nb::arg("lam"), nb::arg("want_jac"), nb::arg("repeats"),
      "Internal: seconds per call of the sscr evaluate, timed by a loop of `repeats` calls in C++ (GIL released).");
}

}  // namespace pytdcr
