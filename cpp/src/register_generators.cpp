// Bindings for the recursive noise generators used by simulation (AR(1) banks, random walks).
#include <pybind11/numpy.h>

#include <cstddef>
#include <string>

#include "allanite/generators.hpp"
#include "bindings.hpp"

namespace py = pybind11;

namespace allanite::bind {
namespace {

using CArray = py::array_t<double, py::array::c_style>;

void check_1d(const CArray& v, py::ssize_t n, const char* name) {
  if (v.ndim() != 1 || v.shape(0) != n)
    throw py::value_error(std::string("ar1_bank: ") + name + " must be a 1-D array of length J = " +
                          std::to_string(n));
}

CArray ar1_bank(py::array_t<double> state, const CArray& phi, const CArray& q, const CArray& a,
                const CArray& b, const CArray& z, int threads) {
  if (state.ndim() != 2)
    throw py::value_error("ar1_bank: state must be a 2-D (components, channels) float64 array");
  if (!(state.flags() & py::array::c_style) || !state.writeable())
    throw py::value_error("ar1_bank: state must be a writeable C-contiguous float64 array");
  const py::ssize_t J = state.shape(0), C = state.shape(1);
  if (z.ndim() != 3 || z.shape(1) != J || z.shape(2) != C)
    throw py::value_error("ar1_bank: z must have shape (samples, " + std::to_string(J) + ", " +
                          std::to_string(C) + ")");
  check_1d(phi, J, "phi");
  check_1d(q, J, "q");
  check_1d(a, J, "a");
  check_1d(b, J, "b");
  const py::ssize_t B = z.shape(0);
  CArray out({B, C});
  double* st = state.mutable_data();
  const double *pphi = phi.data(), *pq = q.data(), *pa = a.data(), *pb = b.data(), *pz = z.data();
  double* po = out.mutable_data();
  const BankShape shape{static_cast<std::size_t>(B), static_cast<std::size_t>(J),
                        static_cast<std::size_t>(C)};
  {
    py::gil_scoped_release release;
    allanite::ar1_bank(st, pphi, pq, pa, pb, pz, po, shape, threads);
  }
  return out;
}

CArray running_sum(py::array_t<double> hi, py::array_t<double> lo, const CArray& x) {
  if (x.ndim() != 2)
    throw py::value_error("running_sum: x must be a 2-D (samples, channels) float64 array");
  const py::ssize_t B = x.shape(0), C = x.shape(1);
  for (const auto* state : {&hi, &lo}) {
    if (state->ndim() != 1 || state->shape(0) != C || !(state->flags() & py::array::c_style) ||
        !state->writeable())
      throw py::value_error("running_sum: hi and lo must be writeable float64 arrays of length " +
                            std::to_string(C));
  }
  CArray out({B, C});
  double* phi = hi.mutable_data();
  double* plo = lo.mutable_data();
  const double* px = x.data();
  double* po = out.mutable_data();
  {
    py::gil_scoped_release release;
    allanite::running_sum(phi, plo, px, po, static_cast<std::size_t>(B), static_cast<std::size_t>(C));
  }
  return out;
}

}  // namespace

void register_generators(py::module_& m) {
  m.def("ar1_bank", &ar1_bank, py::arg("state").noconvert(), py::arg("phi"), py::arg("q"), py::arg("a"),
        py::arg("b"), py::arg("z"), py::arg("threads") = 1,
        "Bank of first-order recursions: for each sample k, component j, channel c, with "
        "e = q[j] z[k, j, c]: out[k, c] += a[j] state[j, c] + b[j] e; state[j, c] = phi[j] "
        "state[j, c] + e. state (J, C) is updated in place; z is (B, J, C); returns (B, C).");
  m.def("running_sum", &running_sum, py::arg("hi").noconvert(), py::arg("lo").noconvert(),
        py::arg("x"),
        "Compensated (Neumaier) running sum of x (B, C) down the samples, continuing from the "
        "state (hi, lo) of length C, which is updated in place; returns (B, C).");
}

}  // namespace allanite::bind
