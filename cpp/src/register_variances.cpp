// Bindings for prefix sums (phase) and the Allan-family variance kernels.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <string>
#include <vector>

#include "allanite/noise_id.hpp"
#include "allanite/phase.hpp"
#include "allanite/variances.hpp"
#include "bindings.hpp"

namespace py = pybind11;

namespace allanite::bind {
namespace {

template <class T>
RowMatrix phase_typed(const py::array& x, InputKind kind, int threads) {
  const auto itemsize = static_cast<py::ssize_t>(sizeof(T));
  const py::ssize_t s0 = x.strides(0), s1 = x.strides(1);
  if (s0 % itemsize != 0 || s1 % itemsize != 0)
    throw py::type_error("array strides are not a multiple of the item size (an exotic view); "
                         "pass np.ascontiguousarray(x) instead");
  StridedMap<T> view(static_cast<const T*>(x.data()), x.shape(0), x.shape(1),
                     Strides(s0 / itemsize, s1 / itemsize));
  py::gil_scoped_release release;
  return build_phase<T>(view, kind, threads);
}

RowMatrix phase(const py::array& x, const std::string& input, int threads) {
  const InputKind kind = parse_input_kind(input);
  if (x.ndim() != 2)
    throw py::value_error("phase() expects a 2-D (samples, channels) array, got " +
                          std::to_string(x.ndim()) + " dimensions");
  return dispatch_dtype(x, [&](auto tag) { return phase_typed<decltype(tag)>(x, kind, threads); });
}

RowMatrix variance(const Eigen::Ref<const RowMatrix>& phase_ref, const std::vector<std::int64_t>& ms,
                   const std::string& kind, int threads) {
  const VarianceKind k = parse_variance_kind(kind);
  py::gil_scoped_release release;
  return allanite::variance(phase_ref, ms, k, threads);
}

template <class T>
RowMatrix lag1_acf_typed(const py::array& x, const std::vector<std::int64_t>& ms, AcfSeries series,
                         int levels, int threads) {
  const auto itemsize = static_cast<py::ssize_t>(sizeof(T));
  const py::ssize_t s0 = x.strides(0), s1 = x.strides(1);
  if (s0 % itemsize != 0 || s1 % itemsize != 0)
    throw py::type_error("array strides are not a multiple of the item size (an exotic view); "
                         "pass np.ascontiguousarray(x) instead");
  StridedMap<T> view(static_cast<const T*>(x.data()), x.shape(0), x.shape(1),
                     Strides(s0 / itemsize, s1 / itemsize));
  py::gil_scoped_release release;
  return lag1_acf_levels<T>(view, ms, series, levels, threads);
}

RowMatrix lag1_acf(const py::array& x, const std::vector<std::int64_t>& ms, const std::string& series,
                   int levels, int threads) {
  const AcfSeries s = parse_acf_series(series);
  if (x.ndim() != 2)
    throw py::value_error("lag1_acf() expects a 2-D (samples, channels) array, got " +
                          std::to_string(x.ndim()) + " dimensions");
  return dispatch_dtype(x, [&](auto tag) { return lag1_acf_typed<decltype(tag)>(x, ms, s, levels, threads); });
}

}  // namespace

void register_variances(py::module_& m) {
  m.def("phase", &phase, py::arg("x"), py::arg("input"), py::arg("threads") = 0,
        "Detrended, compensated phase (prefix sums) of a (N, C) record of rate, increment or "
        "angle samples; returns (N+1, C) for rate/increment, (N, C) for angle. The same bits for "
        "any number of threads (0: all cores).");
  m.def("variance", &variance, py::arg("phase"), py::arg("m"), py::arg("kind"),
        py::arg("threads") = 0,
        "Allan-family variance (tau0 = 1, phase units) for each averaging factor in m; "
        "returns (len(m), C).");
  m.def("lag1_acf", &lag1_acf, py::arg("x"), py::arg("m"), py::arg("series"), py::arg("levels"),
        py::arg("threads") = 0,
        "Lag-1 autocorrelation of the decimated phase x[::m] (series='phase') or of the "
        "m-sample frequency averages (series='frequency') and of their first levels-1 "
        "differences, one streaming pass per factor; returns (len(m), C * levels).");
  m.def("mvar_avar_ratio",
        [](const Eigen::Ref<const RowMatrix>& phase_ref, const std::vector<std::int64_t>& ms, int threads) {
          py::gil_scoped_release release;
          return allanite::mvar_avar_ratio(phase_ref, ms, threads);
        },
        py::arg("phase"), py::arg("m"), py::arg("threads") = 0,
        "R(n) = modified / overlapping Allan variance of each channel at each factor (3m <= "
        "rows), both from variance(); NaN where the Allan variance is zero. Returns (len(m), C).");
  m.def("n_terms",
        [](const std::string& kind, std::int64_t M, std::int64_t mm) {
          return allanite::n_terms(parse_variance_kind(kind), M, mm);
        },
        py::arg("kind"), py::arg("n_phase"), py::arg("m"));
  m.def("max_m",
        [](const std::string& kind, std::int64_t M) { return allanite::max_m(parse_variance_kind(kind), M); },
        py::arg("kind"), py::arg("n_phase"));
}

}  // namespace allanite::bind
