// Compensated prefix sums: from a record of rate, angle increments or angle to a detrended
// "phase" array (the integrated signal in units of sample-rate * samples), the common input
// of every Allan-family kernel.
//
// rate / increment: subtract the mean (two-stage compensated mean, LaneSum, so a bias of 1e10 leaves an
//   offset of about one rounding of the noise), then accumulate with Neumaier summation:
//   phase[0] = 0, phase[k+1] = sum_{i<=k} (y[i] - mean). Length N + 1.
// angle: subtract the least-squares line theta[k] - (a + b (k - kbar)), evaluated in
//   double-double arithmetic so that a large linear drift leaves only the rounding of the
//   residual. Length N.
// Removing a mean rate (a linear phase) leaves every Allan-family statistic unchanged in exact
// arithmetic; it only protects the finite-precision differences.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "allanite/compensated.hpp"

namespace allanite {

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using Strides = Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>;
template <class T>
using StridedMap = Eigen::Map<const Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>,
                              Eigen::Unaligned, Strides>;

enum class InputKind { Rate, Increment, Angle };

inline InputKind parse_input_kind(const std::string& s) {
  if (s == "rate") return InputKind::Rate;
  if (s == "increment") return InputKind::Increment;
  if (s == "angle") return InputKind::Angle;
  throw std::invalid_argument("input must be 'rate', 'increment' or 'angle', got '" + s + "'");
}

namespace detail {

/// First sample of column c and the step between its rows, for add_shifted_lanes.
template <class T>
const T* column_start(const StridedMap<T>& x, Eigen::Index c) noexcept {
  return x.data() + c * x.innerStride();
}

/// Two-stage compensated mean of column c: mean1 + correction, both returned. Each stage is a
/// LaneSum over the samples (lanes by sample index, as the chunked passes of streaming.hpp).
template <class T>
void column_mean(const StridedMap<T>& x, Eigen::Index c, double& mean1, double& corr) {
  const Eigen::Index n = x.rows();
  const T* p = column_start(x, c);
  LaneSum s1;
  add_shifted_lanes(p, x.outerStride(), n, 0, 0.0, 0.0, s1);
  mean1 = s1.value() / static_cast<double>(n);
  LaneSum s2;
  add_shifted_lanes(p, x.outerStride(), n, 0, mean1, 0.0, s2);
  corr = s2.value() / static_cast<double>(n);
}

/// Ask for transparent huge pages on a large array about to be written for the first time
/// (Linux, where THP is in "madvise" mode): one page fault per 2 MiB instead of per 4 KiB,
/// which is a quarter of the phase build at 1e7 samples. Only a hint; ignored elsewhere.
inline void advise_huge_pages(double* data, std::size_t count) noexcept {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr std::uintptr_t kHuge = std::uintptr_t{1} << 21;
  const auto begin = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t end = begin + count * sizeof(double);
  const std::uintptr_t first = (begin + kHuge - 1) & ~(kHuge - 1);
  if (end >= first + kHuge)
    madvise(reinterpret_cast<void*>(first), (end - first) & ~(kHuge - 1), MADV_HUGEPAGE);
#else
  (void)data;
  (void)count;
#endif
}

template <class T>
void check_finite(const StridedMap<T>& x) {
  if constexpr (std::is_floating_point_v<T>) {
    for (Eigen::Index k = 0; k < x.rows(); ++k)
      for (Eigen::Index c = 0; c < x.cols(); ++c)
        if (!std::isfinite(x(k, c)))
          throw std::invalid_argument("input contains NaN or inf at sample " + std::to_string(k) +
                                      ", channel " + std::to_string(c) +
                                      "; remove or interpolate non-finite samples first");
  }
}

}  // namespace detail

/// Build the detrended phase array (rows: time, columns: channels) from a strided record.
template <class T>
RowMatrix build_phase(const StridedMap<T>& x, InputKind kind) {
  const Eigen::Index n = x.rows();
  const Eigen::Index nc = x.cols();
  if (n < 3) throw std::invalid_argument("record too short: need at least 3 samples, got " + std::to_string(n));
  if (nc < 1) throw std::invalid_argument("record has no channels");
  // no separate pass for finiteness: a NaN or inf makes a column's compensated mean NaN
  // (Neumaier's correction gets inf - inf), and only then the record is searched for it
  const auto column_mean = [&x](Eigen::Index c, double& mean1, double& corr) {
    detail::column_mean(x, c, mean1, corr);
    if (!std::isfinite(mean1) || !std::isfinite(corr)) detail::check_finite(x);
  };

  if (kind == InputKind::Angle) {
    RowMatrix phase(n, nc);
    detail::advise_huge_pages(phase.data(), static_cast<std::size_t>(phase.size()));
    const double kbar = 0.5 * static_cast<double>(n - 1);
    // sum (k - kbar)^2 = n (n^2 - 1) / 12, exact enough in double for n < 2^50
    const double nn = static_cast<double>(n);
    const double sxx = nn * (nn * nn - 1.0) / 12.0;
    for (Eigen::Index c = 0; c < nc; ++c) {
      double mean1 = 0.0, corr = 0.0;
      column_mean(c, mean1, corr);
      NeumaierSum sxy;
      for (Eigen::Index k = 0; k < n; ++k) {
        const double u = (static_cast<double>(x(k, c)) - mean1) - corr;
        sxy.add((static_cast<double>(k) - kbar) * u);
      }
      const double slope = sxy.value() / sxx;
      for (Eigen::Index k = 0; k < n; ++k) {
        // residual = x - mean1 - corr - slope * (k - kbar), in double-double
        double s, e;
        two_sum(static_cast<double>(x(k, c)), -mean1, s, e);
        double p, pe;
        two_prod(slope, static_cast<double>(k) - kbar, p, pe);
        double s2, e2;
        two_sum(s, -p, s2, e2);
        phase(k, c) = s2 + (((e + e2) - pe) - corr);
      }
    }
    return phase;
  }

  RowMatrix phase(n + 1, nc);
  detail::advise_huge_pages(phase.data(), static_cast<std::size_t>(phase.size()));
  phase.row(0).setZero();
  for (Eigen::Index c = 0; c < nc; ++c) {
    double mean1 = 0.0, corr = 0.0;
    column_mean(c, mean1, corr);
    NeumaierSum acc;
    for (Eigen::Index k = 0; k < n; ++k) {
      acc.add((static_cast<double>(x(k, c)) - mean1) - corr);
      phase(k + 1, c) = acc.value();
    }
  }
  return phase;
}

}  // namespace allanite
