// Lag-1 autocorrelation of decimated phase, the statistic of Stable32's noise identification.
//
// For an averaging factor m the series is the decimated phase z_k = x[k m] (phase data) or
// the frequency averaged over m samples z_k = (x[(k+1) m] - x[k m]) / m (frequency data), and
// its successive differences (levels d = 0, 1, ... of Riley & Greenhall 2004). For each level
// the lag-1 autocorrelation
//
//   r1 = (n-1)/n * sum_{i<n-1} (z_i - zbar)(z_{i+1} - zbar) / sum_i (z_i - zbar)^2
//
// is accumulated in one streaming pass over the strided rows, with no copy of the series
// (the factors of a thread's group share the pass: tiles of rows stay in L2 while every
// factor reads its points x[j m] from them):
// every level is centred on a value c_d known before the pass (the exact telescoped mean of a
// differenced series, (last - first) / (n - 1) of the level below, or for level 0 the
// telescoped mean of frequency data / the mid-range of phase data), and the sums of
// u = z - c_d, u^2 and u_i u_{i+1} are kept blockwise with compensated totals. The exact
// centring follows from delta = mean(u): sum (z - zbar)^2 = S2 - S1 delta and
// sum (z_i - zbar)(z_{i+1} - zbar) = C - delta (2 S1 - u_0 - u_{n-1}) + (n - 1) delta^2.
// Since c_d is the mean up to rounding (or within the spread of the data), no cancellation
// occurs. Memory: O(levels x channels) per factor; work O(rows / m) per factor.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "allanite/compensated.hpp"
#include "allanite/parallel.hpp"
#include "allanite/phase.hpp"
#include "allanite/variances.hpp"  // also ALLANITE_TARGET_CLONES

namespace allanite {

/// Most difference levels (dmax + 1 with dmax = 3 for the Hadamard family).
constexpr int kMaxAcfLevels = 4;

/// Which series the noise identification looks at.
enum class AcfSeries { Phase, Frequency };

inline AcfSeries parse_acf_series(const std::string& s) {
  if (s == "phase") return AcfSeries::Phase;
  if (s == "frequency") return AcfSeries::Frequency;
  throw std::invalid_argument("series must be 'phase' or 'frequency', got '" + s + "'");
}

/// Number of values of the level-0 series for factor m over `rows` phase rows.
inline std::int64_t acf_series_length(AcfSeries series, std::int64_t rows, std::int64_t m) {
  return series == AcfSeries::Phase ? (rows + m - 1) / m : (rows - 1) / m;
}

namespace detail {

/// Values per summation block (plain sums inside, compensated totals across blocks).
constexpr std::int64_t kAcfBlock = 1024;
/// Bytes of phase rows per tile: every factor of a group reads the tile while it is in L2.
constexpr std::int64_t kAcfTileBytes = 256 * 1024;

/// Sums of u = v[k] - centre, u^2 and u[k] u[k-1] over k in [lo, hi) (k = 0 has no
/// predecessor: v[-1] is never read), then v[k] = v[k+1] - v[k] for k < hi - 1: one level of
/// a block of the difference cascade. Four interleaved partial sums each, one Pack4 (lane r:
/// the terms k = r mod 4 after the start); compiled for AVX2 and the baseline ISA with the
/// same arithmetic.
ALLANITE_TARGET_CLONES static void acf_level(const double* v, std::int64_t lo, std::int64_t hi, double centre,
                                             double* sums) noexcept {
  Pack4 a1 = {}, a2 = {}, ac = {};
  std::int64_t k = lo;
  if (k == 0 && k < hi) {
    const double u = v[0] - centre;
    a1[0] += u;
    a2[0] += u * u;
    ++k;
  }
  const Pack4 c = {centre, centre, centre, centre};
  for (; k + 4 <= hi; k += 4) {  // lane r: value k + r and its predecessor
    Pack4 v0, v1;
    std::memcpy(&v0, v + k - 1, sizeof v0);
    std::memcpy(&v1, v + k, sizeof v1);
    const Pack4 u = v1 - c;
    const Pack4 p = v0 - c;
    a1 += u;
    a2 += u * u;
    ac += u * p;
  }
  for (; k < hi; ++k) {
    const double u = v[k] - centre;
    a1[0] += u;
    a2[0] += u * u;
    ac[0] += u * (v[k - 1] - centre);
  }
  sums[0] = (a1[0] + a1[1]) + (a1[2] + a1[3]);
  sums[1] = (a2[0] + a2[1]) + (a2[2] + a2[3]);
  sums[2] = (ac[0] + ac[1]) + (ac[2] + ac[3]);
}

/// acf_level of the first differences w[k] = v[(k + 1) s] - v[k s] of the points v[k s],
/// without storing them (the same operations on the same values, so the same sums as
/// acf_difference then acf_level): the frequency series' only level in the identification's
/// first pass. kUnit: s = 1 (a buffer or a contiguous column, vector loads), else s = step
/// (the points read in place in the phase rows, four gathered per vector).
template <bool kUnit>
ALLANITE_ALWAYS_INLINE void acf_level_of_difference_impl(const double* v, std::int64_t step, std::int64_t lo,
                                                         std::int64_t hi, double centre, double* sums) noexcept {
  const std::int64_t s = kUnit ? 1 : step;
  Pack4 a1 = {}, a2 = {}, ac = {};
  std::int64_t k = lo;
  if (k == 0 && k < hi) {
    const double u = (v[s] - v[0]) - centre;
    a1[0] += u;
    a2[0] += u * u;
    ++k;
  }
  const Pack4 c = {centre, centre, centre, centre};
  for (; k + 4 <= hi; k += 4) {  // lane r: difference k + r and its predecessor
    Pack4 v0, v1, v2;
    const double* q = v + (k - 1) * s;
    if constexpr (kUnit) {
      std::memcpy(&v0, q, sizeof v0);
      std::memcpy(&v1, q + 1, sizeof v1);
      std::memcpy(&v2, q + 2, sizeof v2);
    } else {
      const double p0 = q[0], p1 = q[s], p2 = q[2 * s], p3 = q[3 * s], p4 = q[4 * s], p5 = q[5 * s];
      v0 = Pack4{p0, p1, p2, p3};
      v1 = Pack4{p1, p2, p3, p4};
      v2 = Pack4{p2, p3, p4, p5};
    }
    const Pack4 u = (v2 - v1) - c;
    const Pack4 p = (v1 - v0) - c;
    a1 += u;
    a2 += u * u;
    ac += u * p;
  }
  for (; k < hi; ++k) {
    const double u = (v[(k + 1) * s] - v[k * s]) - centre;
    a1[0] += u;
    a2[0] += u * u;
    ac[0] += u * ((v[k * s] - v[(k - 1) * s]) - centre);
  }
  sums[0] = (a1[0] + a1[1]) + (a1[2] + a1[3]);
  sums[1] = (a2[0] + a2[1]) + (a2[2] + a2[3]);
  sums[2] = (ac[0] + ac[1]) + (ac[2] + ac[3]);
}

ALLANITE_TARGET_CLONES static void acf_level_of_difference(const double* v, std::int64_t lo, std::int64_t hi,
                                                           double centre, double* sums) noexcept {
  acf_level_of_difference_impl<true>(v, 1, lo, hi, centre, sums);
}
ALLANITE_TARGET_CLONES static void acf_level_of_difference_strided(const double* v, std::int64_t step,
                                                                   std::int64_t lo, std::int64_t hi, double centre,
                                                                   double* sums) noexcept {
  acf_level_of_difference_impl<false>(v, step, lo, hi, centre, sums);
}

ALLANITE_TARGET_CLONES static void acf_difference(double* v, std::int64_t len) noexcept {
  for (std::int64_t k = 0; k + 1 < len; ++k) v[k] = v[k + 1] - v[k];
}

/// dst[i] = in[i * step], i < n: the decimated points of a run. Strides 1 to 4 (the
/// factors with the most points) are compile-time constants, so that the copy is vectorised
/// (loads of whole rows, shuffled); others one by one. A plain copy: the same values.
template <std::int64_t S>
ALLANITE_ALWAYS_INLINE void gather_fixed(const double* in, std::int64_t n, double* dst) noexcept {
  for (std::int64_t i = 0; i < n; ++i) dst[i] = in[i * S];
}
ALLANITE_TARGET_CLONES static void gather_points(const double* in, std::int64_t step, std::int64_t n,
                                                 double* dst) noexcept {
  switch (step) {
    case 1: gather_fixed<1>(in, n, dst); return;
    case 2: gather_fixed<2>(in, n, dst); return;
    case 3: gather_fixed<3>(in, n, dst); return;
    case 4: gather_fixed<4>(in, n, dst); return;
    default:
      for (std::int64_t i = 0; i < n; ++i) dst[i] = in[i * step];
  }
}

/// Streaming lag-1 statistics of one channel at one factor. The decimated points
/// p_j = x[j m] (j < J) enter a cascade of differences of depth Off + L; levels
/// Off ... Off + L - 1 are accumulated (Off = 0: phase series, Off = 1: frequency series,
/// whose values p_{j+1} - p_j are the m-sample averages times m; r1 is scale free).
/// Points are collected in blocks of kAcfBlock behind the last D points of the previous
/// block; a full block is differenced level by level in place and summed (vectorised),
/// the block sums go to compensated totals.
template <int L, int Off>
struct AcfState {
  static constexpr int D = L + Off;
  std::int64_t J = 0;  // decimated points
  std::int64_t j = 0;  // points fed so far
  double centre[L] = {};
  double first[L] = {}, last[L] = {};
  NeumaierSum s1[L], s2[L], cross[L];
  std::vector<double> buf;  // history (D points after the first block), then pending points
  std::int64_t history = 0, size = 0;
  // the frequency series' first pass (L = 1, Off = 1) on float64 rows: the pending points are
  // read in place, point i at direct[i * direct_step], and buf is not filled (see fold)
  const double* direct = nullptr;
  std::int64_t direct_step = 0;

  /// Centres and end values of every level from the first and last D points.
  template <class Point>
  void start(std::int64_t points, Point&& point) {
    J = points;
    buf.assign(static_cast<std::size_t>(kAcfBlock + D), 0.0);
    double head[D][D], tail[D][D];
    for (int i = 0; i < D; ++i) {
      head[0][i] = point(i);
      tail[0][i] = point(J - D + i);
    }
    for (int d = 1; d < D; ++d)
      for (int i = 0; i + d < D; ++i) {
        head[d][i] = head[d - 1][i + 1] - head[d - 1][i];
        tail[d][i] = tail[d - 1][i + 1] - tail[d - 1][i];
      }
    for (int a = 0; a < L; ++a) {
      const int d = a + Off;
      first[a] = head[d][0];
      last[a] = tail[d][D - 1 - d];
      // exact (telescoped) mean of a differenced level; mid-range of the phase itself
      centre[a] = d == 0 ? 0.5 * head[0][0] + 0.5 * tail[0][D - 1]
                         : (tail[d - 1][D - d] - head[d - 1][0]) / static_cast<double>(J - d);
    }
  }

  /// Difference and sum the pending points in place; keep the last D points as history.
  void fold() noexcept {
    if (size == history) return;
    if constexpr (L == 1 && Off == 1) {
      if (direct != nullptr) {  // buf[k] would hold point j - size + k: read it in place
        const double* v = direct + (j - size) * direct_step;
        const std::int64_t from = std::max<std::int64_t>(0, history - 1);
        double sums[3];
        if (direct_step == 1) {
          acf_level_of_difference(v, from, size - 1, centre[0], sums);
        } else {
          acf_level_of_difference_strided(v, direct_step, from, size - 1, centre[0], sums);
        }
        s1[0].add(sums[0]);
        s2[0].add(sums[1]);
        cross[0].add(sums[2]);
        history = size = std::min<std::int64_t>(D, size);  // the last points, still in place
        return;
      }
    }
    double tail[D];
    const std::int64_t keep = std::min<std::int64_t>(D, size);
    std::copy(buf.begin() + (size - keep), buf.begin() + size, tail);
    double* v = buf.data();
    std::int64_t len = size;
    if constexpr (L == 1 && Off == 1) {  // level 1 alone: summed straight from the points
      double sums[3];
      acf_level_of_difference(v, std::max<std::int64_t>(0, history - 1), len - 1, centre[0], sums);
      s1[0].add(sums[0]);
      s2[0].add(sums[1]);
      cross[0].add(sums[2]);
      std::copy(tail, tail + keep, buf.begin());
      history = size = keep;
      return;
    }
    for (int d = 0; d < D; ++d) {
      if (d >= Off) {
        // level d entry k is value j0 - history + k; new are k >= history - d (>= 0 at first)
        const int a = d - Off;
        double sums[3];
        acf_level(v, std::max<std::int64_t>(0, history - d), len, centre[a], sums);
        s1[a].add(sums[0]);
        s2[a].add(sums[1]);
        cross[a].add(sums[2]);
      }
      if (d + 1 < D) acf_difference(v, len);
      --len;
    }
    std::copy(tail, tail + keep, buf.begin());
    history = size = keep;
  }

  void finish(double* r1) {
    fold();
    for (int a = 0; a < L; ++a) {
      const double n = static_cast<double>(J - (a + Off));
      const double sum1 = s1[a].value();
      const double delta = sum1 / n;
      const double den = s2[a].value() - sum1 * delta;
      const double u_first = first[a] - centre[a];
      const double u_last = last[a] - centre[a];
      const double num = cross[a].value() - delta * ((2.0 * sum1 - u_first) - u_last) +
                         (n - 1.0) * delta * delta;
      r1[a] = den > 0.0 ? num / den * (n - 1.0) / n : 0.0;
    }
  }
};

/// One group of factors in one pass over tiles of rows (each factor's points in order).
template <int L, int Off, class T>
void lag1_acf_group(const StridedMap<T>& x, const std::vector<std::int64_t>& ms,
                    const std::vector<std::size_t>& group, RowMatrix& out) {
  const std::int64_t rows = x.rows();
  const Eigen::Index nc = x.cols();
  std::vector<AcfState<L, Off>> states(group.size() * static_cast<std::size_t>(nc));
  for (std::size_t g = 0; g < group.size(); ++g) {
    const std::int64_t m = ms[group[g]];
    for (Eigen::Index c = 0; c < nc; ++c) {
      auto& s = states[g * static_cast<std::size_t>(nc) + static_cast<std::size_t>(c)];
      s.start((rows + m - 1) / m, [&](std::int64_t i) { return static_cast<double>(x(i * m, c)); });
      if constexpr (L == 1 && Off == 1 && std::is_same_v<T, double>) {
        s.direct = x.data() + c * x.colStride();  // the points are read where they are
        s.direct_step = m * x.rowStride();
      }
    }
  }
  const std::int64_t tile = std::max<std::int64_t>(
      1, kAcfTileBytes / static_cast<std::int64_t>(sizeof(T) * static_cast<std::size_t>(nc)));
  for (std::int64_t r0 = 0; r0 < rows; r0 += tile) {
    const std::int64_t r1 = std::min(rows, r0 + tile);
    for (std::size_t g = 0; g < group.size(); ++g) {
      const std::int64_t m = ms[group[g]];
      for (Eigen::Index c = 0; c < nc; ++c) {
        auto& s = states[g * static_cast<std::size_t>(nc) + static_cast<std::size_t>(c)];
        const T* col = x.data() + c * x.colStride();
        const std::int64_t step = m * x.rowStride();
        for (std::int64_t row = s.j * m; row < r1;) {
          // a run of points up to the block's end or the tile's, copied without checks
          const std::int64_t n = std::min((r1 - row + m - 1) / m, kAcfBlock - (s.size - s.history));
          double* dst = s.buf.data() + s.size;
          const T* in = col + row * x.rowStride();
          if constexpr (std::is_same_v<T, double>) {
            if (s.direct == nullptr) gather_points(in, step, n, dst);  // else read in place
          } else {
            for (std::int64_t i = 0; i < n; ++i) dst[i] = static_cast<double>(in[i * step]);
          }
          s.size += n;
          s.j += n;
          row += n * m;
          if (s.size - s.history == kAcfBlock) s.fold();
        }
      }
    }
  }
  for (std::size_t g = 0; g < group.size(); ++g)
    for (Eigen::Index c = 0; c < nc; ++c)
      states[g * static_cast<std::size_t>(nc) + static_cast<std::size_t>(c)].finish(
          out.data() + static_cast<Eigen::Index>(group[g]) * nc * L + c * L);
}

template <int L, class T>
void lag1_acf_dispatch_off(AcfSeries series, const StridedMap<T>& x, const std::vector<std::int64_t>& ms,
                           const std::vector<std::size_t>& group, RowMatrix& out) {
  if (series == AcfSeries::Phase)
    lag1_acf_group<L, 0>(x, ms, group, out);
  else
    lag1_acf_group<L, 1>(x, ms, group, out);
}

}  // namespace detail

/// Lag-1 autocorrelation of `levels` difference levels of the series at every factor in ms,
/// every channel: result (len(ms), C * levels), entry (t, c * levels + d). The factors are
/// split into at most `threads` groups of about equal work (points ~ rows / m, assigned
/// greedily, largest first); each group reads the rows once, tile by tile. Every factor's sums
/// run in the same order whatever the grouping, so the result does not depend on threads.
template <class T>
RowMatrix lag1_acf_levels(const StridedMap<T>& x, const std::vector<std::int64_t>& ms,
                          AcfSeries series, int levels, int threads) {
  if (levels < 1 || levels > kMaxAcfLevels)
    throw std::invalid_argument("levels must be between 1 and " + std::to_string(kMaxAcfLevels) +
                                ", got " + std::to_string(levels));
  const std::int64_t rows = x.rows();
  for (const std::int64_t m : ms) {
    if (m < 1)
      throw std::invalid_argument("averaging factor m must be at least 1, got " + std::to_string(m));
    const std::int64_t n0 = acf_series_length(series, rows, m);
    if (n0 < levels + 1)
      throw std::invalid_argument("averaging factor m = " + std::to_string(m) + " leaves " +
                                  std::to_string(n0) + " values for " + std::to_string(levels) +
                                  " difference levels; need at least " +
                                  std::to_string(levels + 1));
  }
  const Eigen::Index nc = x.cols();
  RowMatrix out(static_cast<Eigen::Index>(ms.size()), nc * levels);
  if (ms.empty()) return out;
  // greedy balanced groups over the work rows / m, heaviest factors first
  const std::size_t ng = std::min<std::size_t>(static_cast<std::size_t>(resolve_threads(threads)), ms.size());
  std::vector<std::size_t> order(ms.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return ms[a] < ms[b]; });
  std::vector<std::vector<std::size_t>> groups(ng);
  std::vector<double> load(ng, 0.0);
  for (const std::size_t i : order) {
    const auto g = static_cast<std::size_t>(std::min_element(load.begin(), load.end()) - load.begin());
    groups[g].push_back(i);
    load[g] += 1.0 / static_cast<double>(ms[i]);
  }
  parallel_for(ng, static_cast<int>(ng), [&](std::size_t g) {
    switch (levels) {
      case 1: detail::lag1_acf_dispatch_off<1>(series, x, ms, groups[g], out); return;
      case 2: detail::lag1_acf_dispatch_off<2>(series, x, ms, groups[g], out); return;
      case 3: detail::lag1_acf_dispatch_off<3>(series, x, ms, groups[g], out); return;
      default: detail::lag1_acf_dispatch_off<4>(series, x, ms, groups[g], out); return;
    }
  });
  return out;
}

/// R(n) = MVAR(m) / AVAR(m) (overlapping) of every channel at each factor, the ratio that
/// separates white from flicker phase noise (SP1065 section 5.6): the two variances from
/// variance() (modified: prefix sums, O(1) per term; see variances.hpp), so the ratio is
/// sum w_j^2 / (m^2 (M - 3m + 1)) over sum d2(k)^2 / (M - 2m), w_j the window of m second
/// differences. Result (len(ms), C); NaN where the Allan variance is zero. Each factor is
/// computed by one thread, so the result does not depend on `threads`.
inline RowMatrix mvar_avar_ratio(const PhaseRef& phase, const std::vector<std::int64_t>& ms, int threads) {
  const std::int64_t M = phase.rows();
  for (const std::int64_t m : ms)
    if (m < 1 || 3 * m > M)
      throw std::invalid_argument("averaging factor m = " + std::to_string(m) + " is outside [1, " +
                                  std::to_string(M / 3) + "] for " + std::to_string(M) +
                                  " phase points (R(n) needs 3m <= M)");
  RowMatrix out = variance(phase, ms, VarianceKind::Modified, threads);
  const RowMatrix avar = variance(phase, ms, VarianceKind::Overlapping, threads);
  for (Eigen::Index t = 0; t < out.rows(); ++t)
    for (Eigen::Index c = 0; c < out.cols(); ++c)
      out(t, c) = avar(t, c) > 0.0 ? out(t, c) / avar(t, c) : std::numeric_limits<double>::quiet_NaN();
  return out;
}

}  // namespace allanite
