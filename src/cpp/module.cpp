// pytdcr._core: the compiled kernels, built ahead of time at install (CMakeLists.txt).
#include <nanobind/nanobind.h>

namespace nb = nanobind;

namespace pytdcr {
void bind_kinematics(nb::module_& m);
void bind_pcc(nb::module_& m);
void bind_sscr(nb::module_& m);
void bind_loading_path(nb::module_& m);
void bind_stiffness(nb::module_& m);
void bind_box_lsq(nb::module_& m);
void bind_cosserat(nb::module_& m);
}  // namespace pytdcr

NB_MODULE(_core, m) {
  m.doc() = "The compiled kernels of pytdcr, built ahead of time at install.";
  pytdcr::bind_kinematics(m);
  pytdcr::bind_pcc(m);
  pytdcr::bind_sscr(m);
  pytdcr::bind_loading_path(m);
  pytdcr::bind_stiffness(m);
  pytdcr::bind_box_lsq(m);
  pytdcr::bind_cosserat(m);
}
