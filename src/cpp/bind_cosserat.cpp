// Python binding of cosserat.hpp (pytdcr._core.cosserat_shoot), the Cosserat-rod model's shooting integration.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/tuple.h>

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "bind_common.hpp"
#include "cosserat.hpp"

namespace nb = nanobind;

namespace pytdcr {

namespace {
using In = nb::ndarray<const double, nb::c_contig, nb::device::cpu>;
using InI = nb::ndarray<const std::int64_t, nb::c_contig, nb::device::cpu>;
using bind::Array;

using bind::new_array;

void need(bool ok, const char* what) {
  if (!ok) throw std::invalid_argument(std::string("cosserat_shoot: ") + what);
}
}  // namespace

void bind_cosserat(nb::module_& m) {
  m.def(
      "cosserat_shoot",
      [](In m0, double lam, In lengths, In stiff, double mpl, In dmass, In holes, InI anchor, In tension, In grav,
         In pforce, In pmoment, bool ext, long nsub, bool record) {
        need(m0.ndim() == 1 && m0.shape(0) == 3, "m0 must be (3,)");
        need(lengths.ndim() == 1 && lengths.shape(0) >= 1, "lengths must be (N,)");
        const std::size_t n = lengths.shape(0);
        need(stiff.ndim() == 1 && stiff.shape(0) == 4, "stiff must be (4,)");
        need(dmass.ndim() == 1 && dmass.shape(0) == n, "dmass must be (N,)");
        need(holes.ndim() == 2 && holes.shape(1) == 3, "holes must be (nt, 3)");
        const std::size_t nt = holes.shape(0);
        need(anchor.ndim() == 1 && anchor.shape(0) == nt, "anchor must be (nt,)");
        need(tension.ndim() == 1 && tension.shape(0) == nt, "tension must be (nt,)");
        need(grav.ndim() == 1 && grav.shape(0) == 3, "grav must be (3,)");
        need(pforce.ndim() == 2 && pforce.shape(0) == n && pforce.shape(1) == 3, "pforce must be (N, 3)");
        need(pmoment.ndim() == 2 && pmoment.shape(0) == n && pmoment.shape(1) == 3, "pmoment must be (N, 3)");
        need(nsub >= 1, "nsub must be >= 1");
        cosserat::Rod rod;
        rod.n = n;
        rod.nt = nt;
        rod.lengths.assign(lengths.data(), lengths.data() + n);
        for (int k = 0; k < 4; ++k) rod.stiff[k] = stiff.data()[k];
        rod.mpl = mpl;
        rod.dmass.assign(dmass.data(), dmass.data() + n);
        rod.holes.assign(holes.data(), holes.data() + 3 * nt);
        rod.anchor.assign(anchor.data(), anchor.data() + nt);
        rod.tension.assign(tension.data(), tension.data() + nt);
        for (int k = 0; k < 3; ++k) rod.grav[k] = grav.data()[k];
        rod.pforce.assign(pforce.data(), pforce.data() + 3 * n);
        rod.pmoment.assign(pmoment.data(), pmoment.data() + 3 * n);
        rod.ext = ext;
        rod.nsub = nsub;
        const std::size_t npts = record ? n * static_cast<std::size_t>(nsub) + 1 : 1;
        Array res = new_array({6}), pos = new_array({record ? n + 1 : 1, 3}), rot = new_array({record ? n + 1 : 1, 3, 3}),
              curve = new_array({npts, 3});
        bool ok;
        {
          nb::gil_scoped_release release;
          ok = cosserat::shoot(m0.data(), lam, rod, record, pos.data(), rot.data(), curve.data(), res.data());
        }
        return nb::make_tuple(ok, res, pos, rot, curve);
      },
      nb::arg("m0"), nb::arg("lam"), nb::arg("lengths"), nb::arg("stiff"), nb::arg("mpl"), nb::arg("dmass"),
      nb::arg("holes"), nb::arg("anchor"), nb::arg("tension"), nb::arg("grav"), nb::arg("pforce"),
      nb::arg("pmoment"), nb::arg("ext"), nb::arg("nsub"), nb::arg("record"),
      "The Cosserat rod integrated from the base with total base moment m0 (3,) [N m], every load scaled by lam\n"
      "(src/cpp/cosserat.hpp; the rod as pytdcr.statics.kernels.cosserat.Rod, anchor int64). Returns (ok, res\n"
      "(6,): the total moment just past the tip [N m] then the tip [m] (NaN where not ok), pos (N+1, 3), rot\n"
      "(N+1, 3, 3) and curve (N nsub + 1, 3) when record (else placeholders of one row)).");
}

}  // namespace pytdcr
