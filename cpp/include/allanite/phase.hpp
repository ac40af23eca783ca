// Compensated prefix sums: from a record of rate, angle increments or angle to a detrended
// "phase" array (the integrated signal in units of sample-rate * samples), the common input
// of every Allan-family kernel.
//
// rate / increment: subtract the mean (two-stage compensated mean, so a bias of 1e10 leaves an
//   offset of about one rounding of the noise), then accumulate with Neumaier summation:
//   phase[0] = 0, phase[k+1] = sum_{i<=k} (y[i] - mean). Length N + 1.
//   Blocks: the samples are cut into blocks of kPhaseBlock (a grid anchored at sample 0, fixed
//   whatever the threads or chunks). Each mean stage sums every block on its own (a LaneSum)
//   and the block values in order (Neumaier); the accumulation restarts each block from its
//   base, the block values' running total minus the mean's share (phase_block_bases). So the
//   blocks are independent tasks (two threads, same bits for any thread count), and the
//   chunked passes of streaming.hpp do the same arithmetic.
// angle: subtract the least-squares line theta[k] - (a + b (k - kbar)), evaluated in
//   double-double arithmetic so that a large linear drift leaves only the rounding of the
//   residual. Length N.
// Removing a mean rate (a linear phase) leaves every Allan-family statistic unchanged in exact
// arithmetic; it only protects the finite-precision differences.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "allanite/compensated.hpp"
#include "allanite/parallel.hpp"

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

}  // namespace detail

/// Samples per block of the phase build (see the header comment).
constexpr std::int64_t kPhaseBlock = std::int64_t{1} << 15;

/// Number of blocks of kPhaseBlock samples (the last may be partial) in n samples.
inline std::int64_t phase_blocks(std::int64_t n) { return (n + kPhaseBlock - 1) / kPhaseBlock; }

/// Total of block values v[b * nc + c] (b < nb) of channel c: Neumaier in block order.
inline double block_total(const double* v, std::int64_t nb, Eigen::Index nc, Eigen::Index c) {
  NeumaierSum total;
  for (std::int64_t b = 0; b < nb; ++b) total.add(v[b * nc + c]);
  return total.value();
}

/// Starting states (hi, lo) of the accumulation in every block: for block b and channel c,
/// bases[(b * nc + c) * 2 + {0, 1}] = sum_{b' < b} v[b' * nc + c] - b kPhaseBlock corr[c]
/// (Neumaier, the product split exactly), v the block values of x - mean1.
inline std::vector<double> phase_block_bases(const double* v, std::int64_t nb, Eigen::Index nc,
                                             const double* corr) {
  std::vector<double> bases(static_cast<std::size_t>(2 * nb * nc));
  for (Eigen::Index c = 0; c < nc; ++c) {
    NeumaierSum run;
    for (std::int64_t b = 0; b < nb; ++b) {
      NeumaierSum base = run;
      if (b > 0) {
        double p, pe;
        two_prod(static_cast<double>(b * kPhaseBlock), corr[c], p, pe);
        base.add(-p);
        base.add(-pe);
      }
      bases[static_cast<std::size_t>((b * nc + c) * 2)] = base.hi();
      bases[static_cast<std::size_t>((b * nc + c) * 2 + 1)] = base.lo();
      run.add(v[b * nc + c]);
    }
  }
  return bases;
}

/// Rate/increment phase of rows [k, k + len) of one block of one channel (samples x[k * stride],
/// k the global index): acc starts from the block's base, out[(k - k_first) * ostride] = acc
/// after sample k. The one place of the accumulation's arithmetic.
template <class T>
void accumulate_block(const T* x, std::ptrdiff_t stride, std::int64_t len, double mean1, double corr,
                      NeumaierSum& acc, double* out, std::ptrdiff_t ostride) noexcept {
  for (std::int64_t k = 0; k < len; ++k) {
    acc.add((static_cast<double>(x[k * stride]) - mean1) - corr);
    out[k * ostride] = acc.value();
  }
}

/// accumulate_block on four blocks side by side, lane r the block whose samples start at x[r]
/// (contiguous) and whose phase goes to out[r] (row stride ostride): each lane performs
/// NeumaierSum::add as TwoSum, which yields the same error term, so every lane gives the bits
/// of accumulate_block; four chains in one vector instead of one latency-bound chain.
/// hi/lo: the lanes' states in and out.
[[maybe_unused]] ALLANITE_TARGET_CLONES static void accumulate_blocks4(const double* const* x, std::int64_t len,
                                                                       double mean1, double corr, double* hi,
                                                                       double* lo, double* const* out,
                                                                       std::ptrdiff_t ostride) noexcept {
  Pack4 s, e;
  std::memcpy(&s, hi, sizeof s);
  std::memcpy(&e, lo, sizeof e);
  const Pack4 pm = {mean1, mean1, mean1, mean1}, pc = {corr, corr, corr, corr};
  for (std::int64_t k = 0; k < len; ++k) {
    Pack4 v = {x[0][k], x[1][k], x[2][k], x[3][k]};
    v = (v - pm) - pc;
    const Pack4 t = s + v;
    const Pack4 bb = t - s;
    e += (s - (t - bb)) + (v - bb);
    s = t;
    const Pack4 value = s + e;
    for (int r = 0; r < 4; ++r) out[r][k * ostride] = value[r];
  }
  std::memcpy(hi, &s, sizeof s);
  std::memcpy(lo, &e, sizeof e);
}

namespace detail {

/// LaneSum values of (x - a[c]) - b[c] over each block of every channel, v[blk * nc + c]
/// (blocks are independent tasks on `threads` threads; the values do not depend on them).
template <class T>
std::vector<double> block_sums(const StridedMap<T>& x, const double* a, const double* b, int threads) {
  const std::int64_t n = x.rows();
  const Eigen::Index nc = x.cols();
  const std::int64_t nb = phase_blocks(n);
  std::vector<double> v(static_cast<std::size_t>(nb * nc));
  parallel_for(static_cast<std::size_t>(nb), threads, [&](std::size_t task) {
    const auto blk = static_cast<std::int64_t>(task);
    const std::int64_t k0 = blk * kPhaseBlock, len = std::min(kPhaseBlock, n - k0);
    for (Eigen::Index c = 0; c < nc; ++c) {
      LaneSum s;
      add_shifted_lanes(column_start(x, c) + k0 * x.outerStride(), x.outerStride(), len, k0, a[c], b[c], s);
      v[static_cast<std::size_t>(blk * nc + c)] = s.value();
    }
  });
  return v;
}

/// Two-stage compensated mean of every channel: mean1 = block total of x / n, corr = block
/// total of x - mean1 / n; `v2` receives the second stage's block values.
template <class T>
void column_means(const StridedMap<T>& x, int threads, std::vector<double>& mean1, std::vector<double>& corr,
                  std::vector<double>& v2) {
  const std::int64_t n = x.rows(), nb = phase_blocks(n);
  const Eigen::Index nc = x.cols();
  const auto unc = static_cast<std::size_t>(nc);
  const std::vector<double> zeros(unc, 0.0);
  mean1.assign(unc, 0.0);
  corr.assign(unc, 0.0);
  const std::vector<double> v1 = block_sums(x, zeros.data(), zeros.data(), threads);
  for (Eigen::Index c = 0; c < nc; ++c)
    mean1[static_cast<std::size_t>(c)] = block_total(v1.data(), nb, nc, c) / static_cast<double>(n);
  v2 = block_sums(x, mean1.data(), zeros.data(), threads);
  for (Eigen::Index c = 0; c < nc; ++c)
    corr[static_cast<std::size_t>(c)] = block_total(v2.data(), nb, nc, c) / static_cast<double>(n);
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

/// Build the detrended phase array (rows: time, columns: channels) from a strided record, the
/// blocks of the rate/increment build on `threads` threads (0: all cores; same bits for any).
template <class T>
RowMatrix build_phase(const StridedMap<T>& x, InputKind kind, int threads = 1) {
  const Eigen::Index n = x.rows();
  const Eigen::Index nc = x.cols();
  if (n < 3) throw std::invalid_argument("record too short: need at least 3 samples, got " + std::to_string(n));
  if (nc < 1) throw std::invalid_argument("record has no channels");
  const int nthreads = resolve_threads(threads);
  std::vector<double> mean1, corr, v2;
  // the mean passes run vectorised at about memory speed on one thread: a second one would
  // mostly add its start-up (a thread per pass) to them
  detail::column_means(x, 1, mean1, corr, v2);
  // no separate pass for finiteness: a NaN or inf makes a channel's compensated mean NaN
  // (TwoSum's error gets inf - inf), and only then the record is searched for it
  for (Eigen::Index c = 0; c < nc; ++c)
    if (!std::isfinite(mean1[static_cast<std::size_t>(c)]) || !std::isfinite(corr[static_cast<std::size_t>(c)]))
      detail::check_finite(x);

  if (kind == InputKind::Angle) {
    RowMatrix phase(n, nc);
    detail::advise_huge_pages(phase.data(), static_cast<std::size_t>(phase.size()));
    const double kbar = 0.5 * static_cast<double>(n - 1);
    // sum (k - kbar)^2 = n (n^2 - 1) / 12, exact enough in double for n < 2^50
    const double nn = static_cast<double>(n);
    const double sxx = nn * (nn * nn - 1.0) / 12.0;
    for (Eigen::Index c = 0; c < nc; ++c) {
      const double m1 = mean1[static_cast<std::size_t>(c)], cr = corr[static_cast<std::size_t>(c)];
      NeumaierSum sxy;
      for (Eigen::Index k = 0; k < n; ++k) {
        const double u = (static_cast<double>(x(k, c)) - m1) - cr;
        sxy.add((static_cast<double>(k) - kbar) * u);
      }
      const double slope = sxy.value() / sxx;
      for (Eigen::Index k = 0; k < n; ++k) {
        // residual = x - mean1 - corr - slope * (k - kbar), in double-double
        double s, e;
        two_sum(static_cast<double>(x(k, c)), -m1, s, e);
        double p, pe;
        two_prod(slope, static_cast<double>(k) - kbar, p, pe);
        double s2, e2;
        two_sum(s, -p, s2, e2);
        phase(k, c) = s2 + (((e + e2) - pe) - cr);
      }
    }
    return phase;
  }

  RowMatrix phase(n + 1, nc);
  detail::advise_huge_pages(phase.data(), static_cast<std::size_t>(phase.size()));
  phase.row(0).setZero();
  const std::int64_t nb = phase_blocks(n);
  const std::vector<double> bases = phase_block_bases(v2.data(), nb, nc, corr.data());
  // tasks of four blocks, side by side in one vector where the samples are contiguous float64
  // (accumulate_blocks4), else one after the other; the same bits either way
  constexpr std::int64_t kSide = 4;
  parallel_for(static_cast<std::size_t>((nb + kSide - 1) / kSide), nthreads, [&](std::size_t task) {
    const std::int64_t b0 = static_cast<std::int64_t>(task) * kSide, b1 = std::min(nb, b0 + kSide);
    for (Eigen::Index c = 0; c < nc; ++c) {
      const double m1 = mean1[static_cast<std::size_t>(c)], cr = corr[static_cast<std::size_t>(c)];
      const T* col = detail::column_start(x, c);
      const std::int64_t rs = x.outerStride();
      NeumaierSum acc[kSide];
      std::int64_t done = 0;  // samples of every block of the task already accumulated
      for (std::int64_t b = b0; b < b1; ++b) {
        const auto i = static_cast<std::size_t>((b * nc + c) * 2);
        acc[b - b0] = NeumaierSum(bases[i], bases[i + 1]);
      }
      if constexpr (std::is_same_v<T, double>) {
        if (rs == 1 && b1 - b0 == kSide) {
          const std::int64_t common = std::min(kPhaseBlock, n - (b1 - 1) * kPhaseBlock);
          const double* xs[kSide];
          double* outs[kSide];
          double hi[kSide], lo[kSide];
          for (int r = 0; r < kSide; ++r) {
            xs[r] = col + (b0 + r) * kPhaseBlock;
            outs[r] = phase.data() + ((b0 + r) * kPhaseBlock + 1) * nc + c;
            hi[r] = acc[r].hi();
            lo[r] = acc[r].lo();
          }
          accumulate_blocks4(xs, common, m1, cr, hi, lo, outs, nc);
          for (int r = 0; r < kSide; ++r) acc[r] = NeumaierSum(hi[r], lo[r]);
          done = common;
        }
      }
      for (std::int64_t b = b0; b < b1; ++b) {
        const std::int64_t k0 = b * kPhaseBlock + done, len = std::min(kPhaseBlock - done, n - k0);
        accumulate_block(col + k0 * rs, rs, len, m1, cr, acc[b - b0], phase.data() + (k0 + 1) * nc + c, nc);
      }
    }
  });
  return phase;
}

}  // namespace allanite
