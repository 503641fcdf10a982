// Helpers shared by the bindings (bind_*.cpp): numpy arrays of float64 that own their memory.
#pragma once

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <cstddef>
#include <initializer_list>

namespace pytdcr {
namespace bind {

namespace nb = nanobind;

using Array = nb::ndarray<nb::numpy, double>;

// A new zeroed numpy array of this shape, owning its memory.
inline Array new_array(std::initializer_list<std::size_t> shape) {
  std::size_t size = 1;
  for (std::size_t s : shape) size *= s;
  double* data = new double[size]();
  nb::capsule owner(data, [](void* p) noexcept { delete[] static_cast<double*>(p); });
  return Array(data, shape.size(), shape.begin(), owner);
}

// A numpy copy of the numbers at data, as many as the shape holds.
inline Array copy_array(const double* data, std::initializer_list<std::size_t> shape) {
  Array a = new_array(shape);
  for (std::size_t j = 0; j < a.size(); ++j) a.data()[j] = data[j];
  return a;
}

}  // namespace bind
}  // namespace pytdcr
