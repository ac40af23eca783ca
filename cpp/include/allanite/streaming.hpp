// Chunked (out-of-core) building blocks: the passes of build_phase (phase.hpp) one chunk of rows
// at a time, with the compensated sums carried between chunks as (hi, lo) states.
//
// A record too large for memory is read in chunks; each pass below consumes chunks in order
// and performs exactly the floating-point operations of build_phase on the same values in the
// same order, so the phase written chunk by chunk equals the in-memory phase bit for bit:
//   pass 1  block values of x                    -> mean1 = block_total / n
//   pass 2  block values of x - mean1            -> corr  = block_total / n, bases
//   rate/increment: pass 3  acc += (x - mean1) - corr, phase[k + 1] = acc (acc = base at
//                   each block start)
//   angle: pass 3  sxy += (k - kbar) ((x - mean1) - corr) -> slope = sxy / sxx
//          pass 4  phase[k] = double-double residual of x - mean1 - corr - slope (k - kbar)
// The variance side needs no code here: detail::add_diff_squares (variances.hpp) takes the taps
// of a difference estimator as separate windows, and its block grid makes sums split at
// multiples of detail::kSumBlock terms exact.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

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

/// Calls fn(k, len, g) for the pieces of a chunk (rows [k, k + len), first sample g = k0 + k)
/// that do not cross a kPhaseBlock boundary of the global grid.
template <class Fn>
void for_block_pieces(std::int64_t rows, std::int64_t k0, Fn&& fn) {
  for (std::int64_t k = 0; k < rows;) {
    const std::int64_t g = k0 + k;
    const std::int64_t len = std::min(rows - k, (g / kPhaseBlock + 1) * kPhaseBlock - g);
    fn(k, len, g);
    k += len;
  }
}

/// Pass 1 (a = b = 0) or 2 (b = 0) of a chunk whose first row is sample k0: partial[c] sums
/// (x(k, c) - a[c]) - b[c] over the current block (lanes by sample index), and at each block's
/// last sample its value goes to `done` (C values per block) and partial restarts: the block
/// values of detail::block_sums (phase.hpp), whatever the chunks.
template <class T>
void add_shifted(const StridedMap<T>& x, std::int64_t k0, const double* a, const double* b, LaneSum* partial,
                 std::vector<double>& done) {
  const Eigen::Index nc = x.cols();
  for_block_pieces(x.rows(), k0, [&](std::int64_t k, std::int64_t len, std::int64_t g) {
    for (Eigen::Index c = 0; c < nc; ++c)
      add_shifted_lanes(detail::column_start(x, c) + k * x.outerStride(), x.outerStride(), len, g, a[c], b[c],
                        partial[c]);
    if ((g + len) % kPhaseBlock == 0)
      for (Eigen::Index c = 0; c < nc; ++c) {
        done.push_back(partial[c].value());
        partial[c] = LaneSum{};
      }
  });
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

/// Rate/increment phase rows of a chunk whose first row is sample k0 (row-major, L x C): at
/// each block's first sample acc restarts from its base (bases (blocks, C, 2) from
/// phase_block_bases), then accumulate_block, as build_phase.
template <class T>
void prefix_rows(const StridedMap<T>& x, std::int64_t k0, const double* mean1, const double* corr,
                 const double* bases, NeumaierSum* acc, double* out) {
  const Eigen::Index nc = x.cols();
  for_block_pieces(x.rows(), k0, [&](std::int64_t k, std::int64_t len, std::int64_t g) {
    for (Eigen::Index c = 0; c < nc; ++c) {
      if (g % kPhaseBlock == 0) {
        const std::int64_t i = ((g / kPhaseBlock) * nc + c) * 2;
        acc[c] = NeumaierSum(bases[i], bases[i + 1]);
      }
      accumulate_block(detail::column_start(x, c) + k * x.outerStride(), x.outerStride(), len, mean1[c], corr[c],
                       acc[c], out + k * nc + c, nc);
    }
  });
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
