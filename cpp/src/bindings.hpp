// Shared declarations for the pybind11 bindings of allanite._core (bindings only: the
// numerics live in cpp/include/allanite).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <cstring>
#include <string>

namespace allanite::bind {

void register_variances(pybind11::module_& m);
void register_generators(pybind11::module_& m);
void register_streaming(pybind11::module_& m);

/// '<' on little-endian machines, '>' on big-endian ones.
inline char native_byteorder() {
  const std::uint16_t one = 1;
  unsigned char first = 0;
  std::memcpy(&first, &one, 1);
  return first == 1 ? '<' : '>';
}

/// Whether dt holds samples of the C++ type T: the same kind ('f', 'i') and item size in native
/// byte order. Compared by value, never by object identity: np.dtype('<f8') made through
/// newbyteorder is a float64 like any other.
template <class T>
bool holds(const pybind11::dtype& dt) {
  const pybind11::dtype want = pybind11::dtype::of<T>();
  return dt.kind() == want.kind() && dt.itemsize() == want.itemsize() &&
         (dt.byteorder() == '=' || dt.byteorder() == '|' || dt.byteorder() == native_byteorder());
}

/// Call fn(T{}) for the sample type of x (float64, float32, int16, int32 or int64, native byte
/// order); anything else is a TypeError that names the dtype and the fix.
template <class Fn>
decltype(auto) dispatch_dtype(const pybind11::array& x, Fn&& fn) {
  const pybind11::dtype dt = x.dtype();
  if (holds<double>(dt)) return fn(double{});
  if (holds<float>(dt)) return fn(float{});
  if (holds<std::int16_t>(dt)) return fn(std::int16_t{});
  if (holds<std::int32_t>(dt)) return fn(std::int32_t{});
  if (holds<std::int64_t>(dt)) return fn(std::int64_t{});
  const std::string name = pybind11::str(dt);
  const char order = dt.byteorder();
  if ((order == '<' || order == '>') && order != native_byteorder())
    throw pybind11::type_error("dtype " + name + " is not in native byte order; pass "
                               "x.astype(x.dtype.newbyteorder('='))");
  throw pybind11::type_error("unsupported dtype " + name +
                             "; use float64, float32, int16, int32 or int64");
}

}  // namespace allanite::bind
