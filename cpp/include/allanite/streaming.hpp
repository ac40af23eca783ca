// Chunked (out-of-core) building blocks: the passes of build_phase (phase.hpp) one chunk of rows
// at a time, with the compensated sums carried between chunks as (hi, lo) states.
//
// A record too large for memory is read in chunks; each pass below consumes chunks in order
// and performs exactly the floating-point operations of build_phase on the same values in the
// same order, so the phase written chunk by chunk equals the in-memory phase bit for bit:
//   pass 1  s1 += x                              -> mean1 = s1 / n   (LaneSum, lanes by sample)
//   pass 2  s2 += x - mean1                      -> corr  = s2 / n   (LaneSum)
//   rate/increment: pass 3  acc += (x - mean1) - corr, phase[k + 1] = acc
//   angle: pass 3  sxy += (k - kbar) ((x - mean1) - corr) -> slope = sxy / sxx
//          pass 4  phase[k] = double-double residual of x - mean1 - corr - slope (k - kbar)
// The variance side needs no code here: detail::add_diff_squares (variances.hpp) takes the taps
// of a difference estimator as separate windows, and its block grid makes sums split at
// multiples of detail::kSumBlock terms exact.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "allanite/compensated.hpp"
#include "allanite/phase.hpp"

namespace allanite::stream {

/// Throw if the chunk holds NaN/inf, naming the global sample index (first row is sample k0).
template <class T>
void check_finite_chunk(const StridedMap<T>& x, std::int64_t k0) {
  if constexpr (std::is_floating_point_v<T>) {
    for (Eigen::Index k = 0; k < x.rows(); ++k)
      for (Eigen::Index c = 0; c < x.cols(); ++c)
        if (!std::isfinite(x(k, c)))
          throw std::invalid_argument("input contains NaN or inf at sample " + std::to_string(k0 + k) +
                                      ", channel " + std::to_string(c) +
                                      "; remove or interpolate non-finite samples first");
  }
}

/// acc[c] += (x(k, c) - a[c]) - b[c] for every row k (pass 1 with a = b = 0, pass 2 with b = 0),
/// row k in lane k0 + k of the LaneSum (the first row of the chunk is sample k0).
template <class T>
void add_shifted(const StridedMap<T>& x, std::int64_t k0, const double* a, const double* b, LaneSum* acc) {
  for (Eigen::Index c = 0; c < x.cols(); ++c)
    add_shifted_lanes(detail::column_start(x, c), x.outerStride(), x.rows(), k0, a[c], b[c], acc[c]);
}

/// acc[c] += (k - kbar) ((x(k, c) - mean1[c]) - corr[c]), k = k0 + row (angle slope, pass 3).
template <class T>
void add_moment(const StridedMap<T>& x, std::int64_t k0, double kbar, const double* mean1,
                const double* corr, NeumaierSum* acc) {
  for (Eigen::Index c = 0; c < x.cols(); ++c)
    for (Eigen::Index k = 0; k < x.rows(); ++k) {
      const double u = (static_cast<double>(x(k, c)) - mean1[c]) - corr[c];
      acc[c].add((static_cast<double>(k0 + k) - kbar) * u);
    }
}

/// Rate/increment phase rows: acc += (x - mean1) - corr; out(k, c) = acc (row-major, L x C).
template <class T>
void prefix_rows(const StridedMap<T>& x, const double* mean1, const double* corr, NeumaierSum* acc,
                 double* out) {
  const Eigen::Index nc = x.cols();
  for (Eigen::Index c = 0; c < nc; ++c)
    for (Eigen::Index k = 0; k < x.rows(); ++k) {
      acc[c].add((static_cast<double>(x(k, c)) - mean1[c]) - corr[c]);
      out[k * nc + c] = acc[c].value();
    }
}

/// Angle phase rows: the least-squares residual in double-double arithmetic (as build_phase).
template <class T>
void detrend_rows(const StridedMap<T>& x, std::int64_t k0, double kbar, const double* mean1,
                  const double* corr, const double* slope, double* out) {
  const Eigen::Index nc = x.cols();
  for (Eigen::Index c = 0; c < nc; ++c)
    for (Eigen::Index k = 0; k < x.rows(); ++k) {
      double s, e;
      two_sum(static_cast<double>(x(k, c)), -mean1[c], s, e);
      double p, pe;
      two_prod(slope[c], static_cast<double>(k0 + k) - kbar, p, pe);
      double s2, e2;
      two_sum(s, -p, s2, e2);
      out[k * nc + c] = s2 + (((e + e2) - pe) - corr[c]);
    }
}

}  // namespace allanite::stream
