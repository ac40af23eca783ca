// Allan-family variance kernels on a detrended phase array (see phase.hpp).
//
// Every kernel works in "sample units": tau0 = 1, phase in rate * samples. The caller scales by
// 1 / tau0^2 where the phase carries angle units. Each averaging factor m costs O(M) work and
// one streaming pass over the phase rows; all channels are handled in the same pass.
//
// Definitions (x = phase, M rows, d2(k) = x[k+2m] - 2 x[k+m] + x[k]):
//   overlapping AVAR   sum_{k=0}^{M-2m-1} d2(k)^2 / (2 m^2 (M-2m))
//   standard AVAR      same over k = 0, m, 2m, ...; n = floor((M-1)/m) - 1 terms
//   modified AVAR      sum_{j=0}^{M-3m} (sum_{i=j}^{j+m-1} d2(i))^2 / (2 m^4 (M-3m+1))
//   overlapping HVAR   sum_{k=0}^{M-3m-1} d3(k)^2 / (6 m^2 (M-3m)),
//                      d3(k) = x[k+3m] - 3 x[k+2m] + 3 x[k+m] - x[k]
//   standard HVAR      same over k = 0, m, 2m, ...; n = floor((M-1)/m) - 2 terms
//   total variance     sum_{i=1}^{M-2} (x*[i-m] - 2 x[i] + x*[i+m])^2 / (2 m^2 (M-2)), x* the
//                      phase extended by point reflection at both ends (NIST SP1065 eq. 25):
//                      x*[-j] = 2 x[0] - x[j], x*[M-1+j] = 2 x[M-1] - x[M-1-j].
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "allanite/compensated.hpp"
#include "allanite/parallel.hpp"
#include "allanite/phase.hpp"

namespace allanite {

/// A read-only view of a row-major phase array (rows: time, columns: channels).
using PhaseRef = Eigen::Ref<const RowMatrix>;

enum class VarianceKind { Overlapping, Standard, Modified, Hadamard, StandardHadamard, Total };

inline VarianceKind parse_variance_kind(const std::string& s) {
  if (s == "overlapping") return VarianceKind::Overlapping;
  if (s == "standard") return VarianceKind::Standard;
  if (s == "modified") return VarianceKind::Modified;
  if (s == "hadamard") return VarianceKind::Hadamard;
  if (s == "standard_hadamard") return VarianceKind::StandardHadamard;
  if (s == "total") return VarianceKind::Total;
  throw std::invalid_argument(
      "kind must be one of 'overlapping', 'standard', 'modified', 'hadamard', "
      "'standard_hadamard', 'total'; got '" + s + "'");
}

/// Largest averaging factor the kind supports for M phase points (0 if none).
inline std::int64_t max_m(VarianceKind kind, std::int64_t M) {
  switch (kind) {
    case VarianceKind::Overlapping:
    case VarianceKind::Standard:
    case VarianceKind::Total:
      return (M - 1) / 2;
    case VarianceKind::Modified:
      return M / 3;
    case VarianceKind::Hadamard:
    case VarianceKind::StandardHadamard:
      return (M - 1) / 3;
  }
  return 0;
}

/// Number of difference terms the estimator averages for factor m.
inline std::int64_t n_terms(VarianceKind kind, std::int64_t M, std::int64_t m) {
  switch (kind) {
    case VarianceKind::Overlapping: return M - 2 * m;
    case VarianceKind::Standard: return (M - 1) / m - 1;
    case VarianceKind::Modified: return M - 3 * m + 1;
    case VarianceKind::Hadamard: return M - 3 * m;
    case VarianceKind::StandardHadamard: return (M - 1) / m - 2;
    case VarianceKind::Total: return M - 2;
  }
  return 0;
}

namespace detail {

/// Terms per summation block. Every sum of squared differences is accumulated in blocks of
/// kSumBlock consecutive terms (four interleaved partial sums by j mod 4, combined pairwise),
/// and the block sums are folded into a Neumaier total. The block grid is anchored at term 0,
/// so a sum split at multiples of kSumBlock (chunks of a file, see streaming.hpp) gives
/// exactly the same bits as one pass.
constexpr std::int64_t kSumBlock = 1024;
static_assert(kSumBlock % 4 == 0, "block must hold whole groups of four terms");

/// Add sum_{j<count} value(j, c)^2 to totals[c] for every channel c, blockwise (see kSumBlock).
/// Term j = 0 must sit on a block boundary of the whole sum.
template <class Fn>
void add_squares(std::int64_t count, Eigen::Index nc, Fn&& value, NeumaierSum* totals) {
  const auto unc = static_cast<std::size_t>(nc);
  std::vector<double> acc(4 * unc);
  for (std::int64_t start = 0; start < count; start += kSumBlock) {
    const std::int64_t end = std::min(count, start + kSumBlock);
    std::fill(acc.begin(), acc.end(), 0.0);
    for (std::int64_t j = start; j < end; ++j) {
      double* a = acc.data() + static_cast<std::size_t>((j - start) & 3) * unc;
      for (Eigen::Index c = 0; c < nc; ++c) {
        const double d = value(j, c);
        a[c] += d * d;
      }
    }
    for (std::size_t c = 0; c < unc; ++c)
      totals[c].add((acc[c] + acc[unc + c]) + (acc[2 * unc + c] + acc[3 * unc + c]));
  }
}

/// Second difference (x2 - 2 x1) + x0 and third difference ((x3 - 3 x2) + 3 x1) - x0: the
/// one place where the arithmetic of the Allan and Hadamard terms is written down.
inline double diff2(double x0, double x1, double x2) noexcept { return (x2 - 2.0 * x1) + x0; }
inline double diff3(double x0, double x1, double x2, double x3) noexcept {
  return ((x3 - 3.0 * x2) + 3.0 * x1) - x0;
}

/// Taps of a difference estimator: term j of channel c reads p[i][j * step + c] for tap i
/// (i = 0..order). In memory p[i] = x + i m * row_stride; out of core each tap is a window.
template <int Order>
struct Taps {
  const double* p[Order + 1];
  std::int64_t step;  // elements between consecutive terms (row stride x term stride)
};

template <int Order>
inline double tap_diff(const Taps<Order>& t, std::int64_t i) noexcept {
  if constexpr (Order == 2) {
    return diff2(t.p[0][i], t.p[1][i], t.p[2][i]);
  } else {
    return diff3(t.p[0][i], t.p[1][i], t.p[2][i], t.p[3][i]);
  }
}

// The hot loops are compiled twice, for AVX2 and for the baseline ISA, and picked at load time
// (GCC function multi-versioning). Each lane performs the same IEEE operations in the same
// order either way (no FMA contraction: -ffp-contract=off), so the clones agree bit for bit.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define ALLANITE_TARGET_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define ALLANITE_TARGET_CLONES
#endif

/// Single-channel, unit-step hot path of add_squares (same arithmetic and order, unrolled).
template <int Order>
inline void add_diff_squares_1ch_impl(const Taps<Order>& t, std::int64_t count, NeumaierSum& total) {
  for (std::int64_t start = 0; start < count; start += kSumBlock) {
    const std::int64_t end = std::min(count, start + kSumBlock);
    double a[4] = {0.0, 0.0, 0.0, 0.0};
    std::int64_t j = start;
    for (; j + 4 <= end; j += 4) {
      const double d0 = tap_diff(t, j);
      const double d1 = tap_diff(t, j + 1);
      const double d2 = tap_diff(t, j + 2);
      const double d3 = tap_diff(t, j + 3);
      a[0] += d0 * d0;
      a[1] += d1 * d1;
      a[2] += d2 * d2;
      a[3] += d3 * d3;
    }
    for (; j < end; ++j) {
      const double d = tap_diff(t, j);
      a[(j - start) & 3] += d * d;
    }
    total.add((a[0] + a[1]) + (a[2] + a[3]));
  }
}

ALLANITE_TARGET_CLONES static void add_diff_squares_1ch(const Taps<2>& t, std::int64_t count,
                                                        NeumaierSum& total) {
  add_diff_squares_1ch_impl(t, count, total);
}
ALLANITE_TARGET_CLONES static void add_diff_squares_1ch(const Taps<3>& t, std::int64_t count,
                                                        NeumaierSum& total) {
  add_diff_squares_1ch_impl(t, count, total);
}

/// Few-channel path of add_squares with the channel count known at compile time: the
/// 4 x NC partial sums live in registers (same arithmetic and order as add_squares).
template <int Order, int NC>
inline void add_diff_squares_nc_impl(const Taps<Order>& t, std::int64_t count, NeumaierSum* totals) {
  const std::int64_t step = t.step;
  for (std::int64_t start = 0; start < count; start += kSumBlock) {
    const std::int64_t end = std::min(count, start + kSumBlock);
    double a[4][NC] = {};
    std::int64_t j = start;
    if (step == NC) {
      // consecutive rows: four terms of every channel are 4 NC adjacent values, and a[r][c]
      // is laid out in the same order, so this loop vectorises
      double flat[4 * NC] = {};
      Taps<Order> local = t;  // pointers in registers: stores to flat cannot alias them
      for (; j + 4 <= end; j += 4) {
        for (int i = 0; i <= Order; ++i) local.p[i] = t.p[i] + j * NC;
        for (int k = 0; k < 4 * NC; ++k) {
          const double d = tap_diff(local, k);
          flat[k] += d * d;
        }
      }
      for (int k = 0; k < 4 * NC; ++k) a[k / NC][k % NC] = flat[k];
    }
    for (; j + 4 <= end; j += 4) {
      for (int r = 0; r < 4; ++r) {
        const std::int64_t i = (j + r) * step;
        for (int c = 0; c < NC; ++c) {
          const double d = tap_diff(t, i + c);
          a[r][c] += d * d;
        }
      }
    }
    for (; j < end; ++j) {
      const std::int64_t r = (j - start) & 3;
      for (int c = 0; c < NC; ++c) {
        const double d = tap_diff(t, j * step + c);
        a[r][c] += d * d;
      }
    }
    for (int c = 0; c < NC; ++c) totals[c].add((a[0][c] + a[1][c]) + (a[2][c] + a[3][c]));
  }
}

ALLANITE_TARGET_CLONES static void add_diff_squares_3ch(const Taps<2>& t, std::int64_t count,
                                                        NeumaierSum* totals) {
  add_diff_squares_nc_impl<2, 3>(t, count, totals);
}
ALLANITE_TARGET_CLONES static void add_diff_squares_3ch(const Taps<3>& t, std::int64_t count,
                                                        NeumaierSum* totals) {
  add_diff_squares_nc_impl<3, 3>(t, count, totals);
}

/// Add the squared differences of `count` terms to totals[0..nc).
template <int Order>
inline void add_diff_squares(const Taps<Order>& t, std::int64_t count, Eigen::Index nc,
                             NeumaierSum* totals) {
  if (nc == 1 && t.step == 1) {
    add_diff_squares_1ch(t, count, totals[0]);
    return;
  }
  switch (nc) {
    case 1: add_diff_squares_nc_impl<Order, 1>(t, count, totals); return;
    case 2: add_diff_squares_nc_impl<Order, 2>(t, count, totals); return;
    case 3: add_diff_squares_3ch(t, count, totals); return;
    case 4: add_diff_squares_nc_impl<Order, 4>(t, count, totals); return;
    default: break;
  }
  add_squares(count, nc, [&t](std::int64_t j, Eigen::Index c) { return tap_diff(t, j * t.step + c); },
              totals);
}

}  // namespace detail

/// Variance of the given kind for one averaging factor m, all channels, into out[0..nc).
inline void variance_one(const PhaseRef& phase, VarianceKind kind, std::int64_t m, double* out) {
  const std::int64_t M = phase.rows();
  const Eigen::Index nc = phase.cols();
  const double* x = phase.data();
  const Eigen::Index row_stride = phase.outerStride();
  const auto at = [x, row_stride](std::int64_t k, Eigen::Index c) { return x[k * row_stride + c]; };
  const std::int64_t n = n_terms(kind, M, m);
  if (m < 1 || m > max_m(kind, M) || n < 1)
    throw std::invalid_argument("averaging factor m = " + std::to_string(m) + " is outside [1, " +
                                std::to_string(max_m(kind, M)) + "] for " + std::to_string(M) +
                                " phase points");
  const double md = static_cast<double>(m);
  const double nd = static_cast<double>(n);
  switch (kind) {
    case VarianceKind::Overlapping:
    case VarianceKind::Standard: {
      const std::int64_t stride = kind == VarianceKind::Overlapping ? 1 : m;
      const detail::Taps<2> taps{{x, x + m * row_stride, x + 2 * m * row_stride}, stride * row_stride};
      std::vector<NeumaierSum> totals(static_cast<std::size_t>(nc));
      detail::add_diff_squares(taps, n, nc, totals.data());
      for (Eigen::Index c = 0; c < nc; ++c)
        out[c] = totals[static_cast<std::size_t>(c)].value() / (2.0 * md * md * nd);
      return;
    }
    case VarianceKind::Hadamard:
    case VarianceKind::StandardHadamard: {
      const std::int64_t stride = kind == VarianceKind::Hadamard ? 1 : m;
      const detail::Taps<3> taps{
          {x, x + m * row_stride, x + 2 * m * row_stride, x + 3 * m * row_stride}, stride * row_stride};
      std::vector<NeumaierSum> totals(static_cast<std::size_t>(nc));
      detail::add_diff_squares(taps, n, nc, totals.data());
      for (Eigen::Index c = 0; c < nc; ++c)
        out[c] = totals[static_cast<std::size_t>(c)].value() / (6.0 * md * md * nd);
      return;
    }
    case VarianceKind::Modified: {
      // sliding window of m second differences, kept compensated so that it does not drift
      const auto d2 = [&](std::int64_t i, Eigen::Index c) {
        return detail::diff2(at(i, c), at(i + m, c), at(i + 2 * m, c));
      };
      for (Eigen::Index c = 0; c < nc; ++c) {
        NeumaierSum window;
        for (std::int64_t i = 0; i < m; ++i) window.add(d2(i, c));
        BlockedSum total;
        for (std::int64_t j = 0; j < n; ++j) {
          const double w = window.value();
          total.add(w * w);
          if (j + 1 < n) {
            window.add(d2(j + m, c));
            window.add(-d2(j, c));
          }
        }
        out[c] = total.value() / (2.0 * md * md * md * md * nd);
      }
      return;
    }
    case VarianceKind::Total: {
      const std::int64_t last = M - 1;
      const auto ext = [&](std::int64_t j, Eigen::Index c) {
        if (j < 0) return 2.0 * at(0, c) - at(-j, c);
        if (j > last) return 2.0 * at(last, c) - at(2 * last - j, c);
        return at(j, c);
      };
      std::vector<NeumaierSum> totals(static_cast<std::size_t>(nc));
      detail::add_squares(n, nc, [&](std::int64_t j, Eigen::Index c) {
        const std::int64_t i = j + 1;
        return detail::diff2(ext(i - m, c), at(i, c), ext(i + m, c));
      }, totals.data());
      for (Eigen::Index c = 0; c < nc; ++c)
        out[c] = totals[static_cast<std::size_t>(c)].value() / (2.0 * md * md * nd);
      return;
    }
  }
}

namespace detail {

/// Terms per tile of the tau-blocked pass (a multiple of kSumBlock, so the block grid of
/// every factor is unchanged and the sums are bit-for-bit those of variance_one).
constexpr std::int64_t kTileTerms = 8 * kSumBlock;
/// Largest factor tiled: the tile's rows (kTileTerms + 3m) x channels stay in L2.
constexpr std::int64_t kTileMaxM = 8192;

/// Overlapping AVAR/HVAR of the factors ms[idx[...]] in one pass over the phase: tile by
/// tile, every factor adds the tile's terms to its own compensated sums.
inline void variance_tiled(const PhaseRef& phase, VarianceKind kind, const std::vector<std::int64_t>& ms,
                           const std::vector<std::size_t>& idx, RowMatrix& out) {
  const std::int64_t M = phase.rows();
  const Eigen::Index nc = phase.cols();
  const double* x = phase.data();
  const std::int64_t rs = phase.outerStride();
  const bool had = kind == VarianceKind::Hadamard;
  std::vector<std::vector<NeumaierSum>> totals(idx.size(), std::vector<NeumaierSum>(static_cast<std::size_t>(nc)));
  std::vector<std::int64_t> n(idx.size());
  std::int64_t longest = 0;
  for (std::size_t a = 0; a < idx.size(); ++a) {
    n[a] = n_terms(kind, M, ms[idx[a]]);
    longest = std::max(longest, n[a]);
  }
  for (std::int64_t k0 = 0; k0 < longest; k0 += kTileTerms) {
    const double* base = x + k0 * rs;
    for (std::size_t a = 0; a < idx.size(); ++a) {
      if (k0 >= n[a]) continue;
      const std::int64_t m = ms[idx[a]];
      const std::int64_t count = std::min(kTileTerms, n[a] - k0);
      if (had) {
        const Taps<3> t{{base, base + m * rs, base + 2 * m * rs, base + 3 * m * rs}, rs};
        add_diff_squares(t, count, nc, totals[a].data());
      } else {
        const Taps<2> t{{base, base + m * rs, base + 2 * m * rs}, rs};
        add_diff_squares(t, count, nc, totals[a].data());
      }
    }
  }
  const double norm = had ? 6.0 : 2.0;
  for (std::size_t a = 0; a < idx.size(); ++a) {
    const double md = static_cast<double>(ms[idx[a]]);
    const double nd = static_cast<double>(n[a]);
    for (Eigen::Index c = 0; c < nc; ++c)
      out(static_cast<Eigen::Index>(idx[a]), c) = totals[a][static_cast<std::size_t>(c)].value() / (norm * md * md * nd);
  }
}

}  // namespace detail

/// Variances for a list of averaging factors (rows of the result), threaded over factors.
/// Bit-for-bit independent of `threads`: each factor is computed by one thread.
inline RowMatrix variance(const PhaseRef& phase, const std::vector<std::int64_t>& ms,
                          VarianceKind kind, int threads) {
  const std::int64_t M = phase.rows();
  for (const std::int64_t m : ms) {
    if (m < 1 || m > max_m(kind, M) || n_terms(kind, M, m) < 1)
      throw std::invalid_argument("averaging factor m = " + std::to_string(m) +
                                  " is outside the supported range [1, " +
                                  std::to_string(max_m(kind, M)) + "] for " + std::to_string(M) +
                                  " phase points; use a shorter averaging time");
  }
  RowMatrix out(static_cast<Eigen::Index>(ms.size()), phase.cols());
  const int nthreads = resolve_threads(threads);
  // Cache blocking over taus: the overlapping estimators at small m read the same rows, so
  // they share passes (detail::variance_tiled); one group per thread, the other factors are
  // one task each. Longest tasks first keeps both cores busy to the end.
  std::vector<std::vector<std::size_t>> groups;
  std::vector<std::size_t> single;
  const bool tiled = (kind == VarianceKind::Overlapping || kind == VarianceKind::Hadamard);
  std::vector<std::size_t> small;
  for (std::size_t i = 0; i < ms.size(); ++i) {
    if (tiled && ms[i] <= detail::kTileMaxM)
      small.push_back(i);
    else
      single.push_back(i);
  }
  if (small.size() > 1) {
    const std::size_t ng = std::min<std::size_t>(static_cast<std::size_t>(nthreads), small.size());
    groups.resize(ng);
    for (std::size_t a = 0; a < small.size(); ++a) groups[a % ng].push_back(small[a]);
  } else {
    single.insert(single.begin(), small.begin(), small.end());
  }
  parallel_for(groups.size() + single.size(), nthreads, [&](std::size_t task) {
    if (task < groups.size()) {
      detail::variance_tiled(phase, kind, ms, groups[task], out);
    } else {
      const std::size_t i = single[task - groups.size()];
      variance_one(phase, kind, ms[i], out.data() + static_cast<Eigen::Index>(i) * phase.cols());
    }
  });
  return out;
}

}  // namespace allanite
