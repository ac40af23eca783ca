// Allan-family variance kernels on a detrended phase array (see phase.hpp).
//
// Every kernel works in "sample units": tau0 = 1, phase in rate * samples. The caller scales by
// 1 / tau0^2 where the phase carries angle units. Each averaging factor m costs O(M) work and
// one streaming pass over the phase rows (factors up to kTileMaxM share passes, tile by tile);
// all channels are handled in the same pass. Every term is O(1): the modified AVAR's window of
// m second differences moves on by the third difference of the phase, w(j+1) = w(j) + d3(j),
// in lanes started from the exact prefix sums of the phase (detail::add_modified_lanes,
// detail::add_modified_single, detail::PrefixPlan), and the total variance is the overlapping
// AVAR's sum plus the 2 (m - 1) end terms that read the reflected extension
// (detail::add_total_ends), so no extended series is built.
//
// One channel's Hadamard factors run four side by side in a tile, the loads of their common
// first tap shared (detail::add_hadamard_side_by_side); every factor keeps its own sums.
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
#include <cmath>
#include <optional>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "allanite/compensated.hpp"
#include "allanite/parallel.hpp"
#include "allanite/phase.hpp"

// The hot loops: ALLANITE_TARGET_CLONES and friends (simd.hpp, via compensated.hpp).

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
/// kSumBlock consecutive terms (P interleaved partial sums by j mod P, combined pairwise; P =
/// kPartials<Taps> of the estimator's taps), and the block sums are folded into a Neumaier
/// total. The block grid is anchored at term 0, so a sum split at multiples of kSumBlock
/// (chunks of a file, see streaming.hpp) gives exactly the same bits as one pass.
constexpr std::int64_t kSumBlock = 1024;
static_assert(kSumBlock % 8 == 0, "block must hold whole groups of partial sums");

/// The block sum of P partial sums a[0], a[stride], ..., combined pairwise.
template <int P>
ALLANITE_ALWAYS_INLINE double combine_partials(const double* a, std::size_t stride = 1) noexcept {
  static_assert(P == 4 || P == 8, "4 or 8 partial sums");
  const double low = (a[0] + a[stride]) + (a[2 * stride] + a[3 * stride]);
  if constexpr (P == 4) {
    return low;
  } else {
    return low + ((a[4 * stride] + a[5 * stride]) + (a[6 * stride] + a[7 * stride]));
  }
}

/// Add sum_{j<count} value(j, c)^2 to totals[c] for every channel c, blockwise (see kSumBlock)
/// with P partial sums. Term j = 0 must sit on a block boundary of the whole sum.
template <int P, class Fn>
void add_squares(std::int64_t count, Eigen::Index nc, Fn&& value, NeumaierSum* totals) {
  const auto unc = static_cast<std::size_t>(nc);
  std::vector<double> acc(P * unc);
  for (std::int64_t start = 0; start < count; start += kSumBlock) {
    const std::int64_t end = std::min(count, start + kSumBlock);
    std::fill(acc.begin(), acc.end(), 0.0);
    for (std::int64_t j = start; j < end; ++j) {
      double* a = acc.data() + static_cast<std::size_t>((j - start) % P) * unc;
      for (Eigen::Index c = 0; c < nc; ++c) {
        const double d = value(j, c);
        a[c] += d * d;
      }
    }
    for (std::size_t c = 0; c < unc; ++c) totals[c].add(combine_partials<P>(acc.data() + c, unc));
  }
}

/// Second difference (x2 - 2 x1) + x0 and third difference ((x3 - 3 x2) + 3 x1) - x0: the
/// one place where the arithmetic of the Allan and Hadamard terms is written down.
ALLANITE_ALWAYS_INLINE double diff2(double x0, double x1, double x2) noexcept { return (x2 - 2.0 * x1) + x0; }
/// diff3 into `out`, for doubles (three = 3.0) or lane by lane for four terms in Pack4s
/// (three = {3, 3, 3, 3}; a Pack4 is not returned by value, see simd.hpp).
template <class V>
ALLANITE_ALWAYS_INLINE void diff3_into(V& out, const V& x0, const V& x1, const V& x2, const V& x3,
                                       const V& three) noexcept {
  out = ((x3 - three * x2) + three * x1) - x0;
}
ALLANITE_ALWAYS_INLINE double diff3(double x0, double x1, double x2, double x3) noexcept {
  double out;
  diff3_into(out, x0, x1, x2, x3, 3.0);
  return out;
}

/// Taps of a difference estimator: term j of channel c reads p[i][j * step + c] for tap i
/// (i = 0..order). In memory p[i] = x + i m * row_stride; out of core each tap is a window.
template <int Order>
struct Taps {
  const double* p[Order + 1];
  std::int64_t step;  // elements between consecutive terms (row stride x term stride)
};

/// Taps of the modified estimator's exact window: the third difference at lag m of the prefix
/// sums S = H + L of the phase (see PrefixPlan), term j of channel c at h[i][j * step + c] and
/// l[i][j * step + c] (read where a lane starts, see add_modified_lanes).
struct SplitTaps {
  const double* h[4];
  const double* l[4];
  std::int64_t step;
};

/// Partial sums per block of an estimator's squares: eight (two AVX2 vectors, so that the adds
/// of two chains overlap instead of each waiting on the last).
template <class TapsT>
constexpr int kPartials = 8;

template <int Order>
ALLANITE_ALWAYS_INLINE double tap_diff(const Taps<Order>& t, std::int64_t i) noexcept {
  if constexpr (Order == 2) {
    return diff2(t.p[0][i], t.p[1][i], t.p[2][i]);
  } else {
    return diff3(t.p[0][i], t.p[1][i], t.p[2][i], t.p[3][i]);
  }
}

/// diff3 of H is exact (multiples of one power of two below 2^51 of it), so the term is the
/// third difference of S rounded about once: no cancellation of the large prefix sums.
ALLANITE_ALWAYS_INLINE double tap_diff(const SplitTaps& t, std::int64_t i) noexcept {
  return diff3(t.h[0][i], t.h[1][i], t.h[2][i], t.h[3][i]) +
         diff3(t.l[0][i], t.l[1][i], t.l[2][i], t.l[3][i]);
}

/// The taps moved on by k elements.
template <int Order>
ALLANITE_ALWAYS_INLINE Taps<Order> advanced(const Taps<Order>& t, std::int64_t k) noexcept {
  Taps<Order> out = t;
  for (int i = 0; i <= Order; ++i) out.p[i] = t.p[i] + k;
  return out;
}


/// Single-channel, unit-step hot path of add_squares (same arithmetic and order, unrolled).
template <class TapsT>
ALLANITE_ALWAYS_INLINE void add_diff_squares_1ch_impl(const TapsT& t, std::int64_t count, NeumaierSum& total) {
  constexpr int P = kPartials<TapsT>;
  for (std::int64_t start = 0; start < count; start += kSumBlock) {
    const std::int64_t end = std::min(count, start + kSumBlock);
    double a[P] = {};
    std::int64_t j = start;
    for (; j + P <= end; j += P) {
      double d[P];
      for (int r = 0; r < P; ++r) d[r] = tap_diff(t, j + r);
      for (int r = 0; r < P; ++r) a[r] += d[r] * d[r];
    }
    for (; j < end; ++j) {
      const double d = tap_diff(t, j);
      a[(j - start) % P] += d * d;
    }
    total.add(combine_partials<P>(a));
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
/// P x NC partial sums live in registers (same arithmetic and order as add_squares).
template <int NC, class TapsT>
ALLANITE_ALWAYS_INLINE void add_diff_squares_nc_impl(const TapsT& t, std::int64_t count, NeumaierSum* totals) {
  constexpr int P = kPartials<TapsT>;
  const std::int64_t step = t.step;
  for (std::int64_t start = 0; start < count; start += kSumBlock) {
    const std::int64_t end = std::min(count, start + kSumBlock);
    double a[P][NC] = {};
    std::int64_t j = start;
    if (step == NC) {
      // consecutive rows: P terms of every channel are P NC adjacent values, and a[r][c]
      // is laid out in the same order, so this loop vectorises
      double flat[P * NC] = {};
      for (; j + P <= end; j += P) {
        const TapsT local = advanced(t, j * NC);  // in registers: stores to flat cannot alias
        for (int k = 0; k < P * NC; ++k) {
          const double d = tap_diff(local, k);
          flat[k] += d * d;
        }
      }
      for (int k = 0; k < P * NC; ++k) a[k / NC][k % NC] = flat[k];
    }
    for (; j + P <= end; j += P) {
      for (int r = 0; r < P; ++r) {
        const std::int64_t i = (j + r) * step;
        for (int c = 0; c < NC; ++c) {
          const double d = tap_diff(t, i + c);
          a[r][c] += d * d;
        }
      }
    }
    for (; j < end; ++j) {
      const std::int64_t r = (j - start) % P;
      for (int c = 0; c < NC; ++c) {
        const double d = tap_diff(t, j * step + c);
        a[r][c] += d * d;
      }
    }
    for (int c = 0; c < NC; ++c) totals[c].add(combine_partials<P>(&a[0][c], NC));
  }
}

ALLANITE_TARGET_CLONES static void add_diff_squares_3ch(const Taps<2>& t, std::int64_t count,
                                                        NeumaierSum* totals) {
  add_diff_squares_nc_impl<3>(t, count, totals);
}
ALLANITE_TARGET_CLONES static void add_diff_squares_3ch(const Taps<3>& t, std::int64_t count,
                                                        NeumaierSum* totals) {
  add_diff_squares_nc_impl<3>(t, count, totals);
}

/// F Hadamard factors of one channel (unit row stride) side by side over `count` terms, a
/// multiple of kSumBlock: the factors' first taps read the same rows (x0), loaded once for
/// all of them; tap i of factor f reads p[f][i - 1]. Each factor's block sums are those of
/// add_diff_squares_1ch_impl (the same terms, partial sums and order), so its result does not
/// depend on the factors it runs beside.
template <int F>
ALLANITE_ALWAYS_INLINE void add_hadamard_side_by_side_impl(const double* x0, const double* const (*p)[3],
                                                           std::int64_t count, NeumaierSum* const* totals) {
  static_assert(kPartials<Taps<3>> == 8, "two Pack4 of partial sums per factor");
  const Pack4 three = {3.0, 3.0, 3.0, 3.0};
  for (std::int64_t start = 0; start < count; start += kSumBlock) {
    Pack4 lo[F], hi[F];  // partial sums r = 0..3 and 4..7 of each factor
    for (int f = 0; f < F; ++f) lo[f] = hi[f] = Pack4{0.0, 0.0, 0.0, 0.0};
    for (std::int64_t j = start; j < start + kSumBlock; j += 8) {
      Pack4 u0, w0;  // tap 0 of terms j .. j + 3 and j + 4 .. j + 7, shared
      std::memcpy(&u0, x0 + j, sizeof u0);
      std::memcpy(&w0, x0 + j + 4, sizeof w0);
      for (int f = 0; f < F; ++f) {
        Pack4 u1, u2, u3, w1, w2, w3;
        std::memcpy(&u1, p[f][0] + j, sizeof u1);
        std::memcpy(&u2, p[f][1] + j, sizeof u2);
        std::memcpy(&u3, p[f][2] + j, sizeof u3);
        std::memcpy(&w1, p[f][0] + j + 4, sizeof w1);
        std::memcpy(&w2, p[f][1] + j + 4, sizeof w2);
        std::memcpy(&w3, p[f][2] + j + 4, sizeof w3);
        Pack4 u, w;
        diff3_into(u, u0, u1, u2, u3, three);
        diff3_into(w, w0, w1, w2, w3, three);
        lo[f] += u * u;
        hi[f] += w * w;
      }
    }
    for (int f = 0; f < F; ++f) {
      double a[8];
      std::memcpy(a, &lo[f], sizeof lo[f]);
      std::memcpy(a + 4, &hi[f], sizeof hi[f]);
      totals[f]->add(combine_partials<8>(a));
    }
  }
}

ALLANITE_TARGET_CLONES static void add_hadamard_side_by_side(int factors, const double* x0,
                                                             const double* const (*p)[3], std::int64_t count,
                                                             NeumaierSum* const* totals) {
  switch (factors) {
    case 2: add_hadamard_side_by_side_impl<2>(x0, p, count, totals); return;
    case 3: add_hadamard_side_by_side_impl<3>(x0, p, count, totals); return;
    default: add_hadamard_side_by_side_impl<4>(x0, p, count, totals); return;
  }
}

/// Add the squared differences of `count` terms to totals[0..nc).
template <class TapsT>
inline void add_diff_squares(const TapsT& t, std::int64_t count, Eigen::Index nc,
                             NeumaierSum* totals) {
  if (nc == 1 && t.step == 1) {
    add_diff_squares_1ch(t, count, totals[0]);
    return;
  }
  switch (nc) {
    case 1: add_diff_squares_nc_impl<1>(t, count, totals); return;
    case 2: add_diff_squares_nc_impl<2>(t, count, totals); return;
    case 3: add_diff_squares_3ch(t, count, totals); return;
    case 4: add_diff_squares_nc_impl<4>(t, count, totals); return;
    default: break;
  }
  add_squares<kPartials<TapsT>>(
      count, nc, [&t](std::int64_t j, Eigen::Index c) { return tap_diff(t, j * t.step + c); }, totals);
}

/// Prefix sums S[k] = sum_{i<k} x[i] of the phase (rows 0..M) for the modified estimator:
/// sum_{i=j}^{j+m-1} d2(i) = S[j+3m] - 3 S[j+2m] + 3 S[j+m] - S[j], so a term costs O(1) and
/// the factors share passes as the Hadamard ones do. S is accumulated with TwoSum (value
/// sum + comp) and handed to the kernel split per channel as S = H + L: H is sum rounded to a
/// multiple of a power of two q with |H| <= 2^48 q, so every third difference of H is exact,
/// and L = (sum - H) + comp carries the rest to O(eps |L|); no cancellation of the large S.
/// Nothing of size M is stored: the plan keeps the state every kSumBlock rows (one pass, eight
/// segments of whole blocks summed side by side from zero, then joined to the running total
/// with TwoSum), and a cursor regenerates S from the mark below its start row, so every S a
/// factor reads depends only on the factor, never on the threads.
struct PrefixPlan {
  Eigen::Index nc = 0;
  std::vector<double> sum, comp;  // state at rows 0, kSumBlock, 2 kSumBlock, ... (x nc)
  std::vector<double> big;        // per channel: (v + big) - big rounds v to a multiple of q
};

/// TwoSum states of kPlanSegments segments of one channel's rows side by side (two vectors;
/// unit row stride: four rows of four segments loaded and transposed in registers):
/// segment s covers rows [s seg, (s + 1) seg) and starts from zero. Its local state at each
/// kSumBlock rows goes to mark s seg / kSumBlock + b (entries `stride` apart, marks with
/// row <= M), its end state to end_sum/end_comp, its largest |local sum| to top.
/// (S of them from x on; plan_segments_half runs four and four, on two threads, with the same
/// arithmetic per segment.)
constexpr int kPlanSegments = 8;
template <int S>
ALLANITE_ALWAYS_INLINE void plan_segments_impl(const double* x, std::int64_t rs, std::int64_t M, std::int64_t seg,
                                               double* sum_at, double* comp_at, std::int64_t stride,
                                               double* end_sum, double* end_comp, double* top_out) noexcept {
  double sum[S] = {}, comp[S] = {}, top[S] = {};
  const std::int64_t seg_blocks = seg / kSumBlock;
  // rows that every segment has (the last ones may be shorter): the four chains at once
  const std::int64_t common = std::clamp<std::int64_t>(M - (S - 1) * seg, 0, seg);
  for (std::int64_t r0 = 0; r0 < seg; r0 += kSumBlock) {
    for (int s = 0; s < S; ++s)
      if (s * seg + r0 <= M) {
        sum_at[(s * seg_blocks + r0 / kSumBlock) * stride] = sum[s];
        comp_at[(s * seg_blocks + r0 / kSumBlock) * stride] = comp[s];
      }
    const std::int64_t r1 = std::min(seg, r0 + kSumBlock);
    const std::int64_t both = std::min(r1, std::max(r0, common));
    std::int64_t done = r0;  // rows of every segment summed
#if defined(__GNUC__) && !defined(__clang__) && !defined(ALLANITE_SCALAR_LANES)
    if constexpr (S % 4 == 0) {  // four segments in a vector, four rows of each transposed in registers
      if (rs == 1 && both - r0 >= 4) {
        typedef double v4d __attribute__((vector_size(32)));
        typedef double v4u __attribute__((vector_size(32), aligned(8), may_alias));  // unaligned access
        typedef long long v4i __attribute__((vector_size(32)));
        const v4i lo2 = {0, 4, 2, 6}, hi2 = {1, 5, 3, 7}, lo4 = {0, 1, 4, 5}, hi4 = {2, 3, 6, 7};
        const v4i no_sign = {~(1LL << 63), ~(1LL << 63), ~(1LL << 63), ~(1LL << 63)};
        done = r0 + (both - r0) / 4 * 4;
        for (int g = 0; g < S; g += 4) {
          v4d sv = *reinterpret_cast<const v4u*>(sum + g), cv = *reinterpret_cast<const v4u*>(comp + g);
          v4d tv = *reinterpret_cast<const v4u*>(top + g);
          const double* p0 = x + g * seg;
          for (std::int64_t q = r0; q < done; q += 4) {
            const v4d a0 = *reinterpret_cast<const v4u*>(p0 + q), a1 = *reinterpret_cast<const v4u*>(p0 + seg + q);
            const v4d a2 = *reinterpret_cast<const v4u*>(p0 + 2 * seg + q);
            const v4d a3 = *reinterpret_cast<const v4u*>(p0 + 3 * seg + q);
            const v4d t0 = __builtin_shuffle(a0, a1, lo2), t1 = __builtin_shuffle(a0, a1, hi2);
            const v4d t2 = __builtin_shuffle(a2, a3, lo2), t3 = __builtin_shuffle(a2, a3, hi2);
            const v4d xr[4] = {__builtin_shuffle(t0, t2, lo4), __builtin_shuffle(t1, t3, lo4),
                               __builtin_shuffle(t0, t2, hi4), __builtin_shuffle(t1, t3, hi4)};
            for (int k = 0; k < 4; ++k) {  // the scalar loop's arithmetic, segment by segment
              const v4d t = sv + xr[k], bb = t - sv;
              cv += (sv - (t - bb)) + (xr[k] - bb);
              sv = t;
              const v4d at = reinterpret_cast<v4d>(reinterpret_cast<v4i>(t) & no_sign);
              tv = tv < at ? at : tv;
            }
          }
          *reinterpret_cast<v4u*>(sum + g) = sv;
          *reinterpret_cast<v4u*>(comp + g) = cv;
          *reinterpret_cast<v4u*>(top + g) = tv;
        }
      }
    }
#endif
    for (std::int64_t r = done; r < both; ++r) {
      double v[S];
      for (int s = 0; s < S; ++s) v[s] = x[(s * seg + r) * rs];
      for (int s = 0; s < S; ++s) {
        const double t = sum[s] + v[s];
        const double bb = t - sum[s];
        comp[s] += (sum[s] - (t - bb)) + (v[s] - bb);  // TwoSum error
        sum[s] = t;
        top[s] = std::max(top[s], std::fabs(t));
      }
    }
    for (int s = 0; s < S; ++s)
      for (std::int64_t r = both; r < r1 && s * seg + r < M; ++r) {
        double t, e;
        two_sum(sum[s], x[(s * seg + r) * rs], t, e);
        sum[s] = t;
        comp[s] += e;
        top[s] = std::max(top[s], std::fabs(t));
      }
  }
  for (int s = 0; s < S; ++s) {
    end_sum[s] = sum[s];
    end_comp[s] = comp[s];
    top_out[s] = top[s];
  }
}

ALLANITE_TARGET_CLONES ALLANITE_SLP_ONLY static void plan_segments(const double* x, std::int64_t rs, std::int64_t M,
                                                                   std::int64_t seg, double* sum_at, double* comp_at,
                                                                   std::int64_t stride, double* end_sum,
                                                                   double* end_comp, double* top_out) noexcept {
  plan_segments_impl<kPlanSegments>(x, rs, M, seg, sum_at, comp_at, stride, end_sum, end_comp, top_out);
}
ALLANITE_TARGET_CLONES ALLANITE_SLP_ONLY static void plan_segments_half(const double* x, std::int64_t rs,
                                                                        std::int64_t M, std::int64_t seg,
                                                                        double* sum_at, double* comp_at,
                                                                        std::int64_t stride, double* end_sum,
                                                                        double* end_comp, double* top_out) noexcept {
  plan_segments_impl<kPlanSegments / 2>(x, rs, M, seg, sum_at, comp_at, stride, end_sum, end_comp, top_out);
}

inline PrefixPlan prefix_plan(const PhaseRef& phase, int threads = 1) {
  const std::int64_t M = phase.rows();
  const Eigen::Index nc = phase.cols();
  const auto unc = static_cast<std::size_t>(nc);
  PrefixPlan p;
  p.nc = nc;
  const std::int64_t marks = M / kSumBlock + 1;
  // segments of whole blocks, summed side by side, then joined to the running total
  const std::int64_t seg_blocks = (marks + kPlanSegments - 1) / kPlanSegments;
  const std::int64_t seg = seg_blocks * kSumBlock;
  p.sum.assign(static_cast<std::size_t>(marks) * unc, 0.0);
  p.comp.assign(p.sum.size(), 0.0);
  p.big.assign(unc, 0.0);
  for (Eigen::Index c = 0; c < nc; ++c) {
    const auto uc = static_cast<std::size_t>(c);
    double end_sum[kPlanSegments], end_comp[kPlanSegments], top[kPlanSegments];
    const std::int64_t rs = phase.outerStride();
    if (threads > 1 && M >= (std::int64_t{1} << 16)) {  // segments 0-3 and 4-7 on two threads (same bits)
      parallel_for(2, 2, [&](std::size_t half) {
        const std::int64_t s0 = static_cast<std::int64_t>(half) * (kPlanSegments / 2);
        plan_segments_half(phase.data() + c + s0 * seg * rs, rs, M - s0 * seg, seg,
                           p.sum.data() + uc + s0 * seg_blocks * nc, p.comp.data() + uc + s0 * seg_blocks * nc,
                           nc, end_sum + s0, end_comp + s0, top + s0);
      });
    } else {
      plan_segments(phase.data() + c, rs, M, seg, p.sum.data() + uc, p.comp.data() + uc, nc, end_sum, end_comp,
                    top);
    }
    // the state at a mark of segment s: its local state after the total of segments < s
    double off_sum = 0.0, off_comp = 0.0, bound = 0.0;
    const auto join = [&](double& sum, double& comp) {
      double t, e;
      two_sum(off_sum, sum, t, e);
      comp = (off_comp + comp) + e;
      sum = t;
    };
    for (int s = 0; s < kPlanSegments; ++s) {
      bound = std::max(bound, std::fabs(off_sum) + top[s]);  // bounds |S| in segment s
      const std::int64_t k1 = std::min<std::int64_t>((s + 1) * seg_blocks, marks);
      for (std::int64_t k = s * seg_blocks; k < k1; ++k) {
        const auto i = static_cast<std::size_t>(k) * unc + uc;
        join(p.sum[i], p.comp[i]);
      }
      join(end_sum[s], end_comp[s]);
      off_sum = end_sum[s];
      off_comp = end_comp[s];
    }
    int e2 = 0;
    std::frexp(bound, &e2);               // every |S| < 2^e2 = 2^48 q (up to rounding)
    p.big[uc] = std::ldexp(1.5, e2 + 4);  // 1.5 * 2^52 q: exact rounding for |v| < 2^51 q
  }
  return p;
}

/// Regenerates S[row], S[row+1], ... of every channel from the plan (see fill_prefix).
struct PrefixCursor {
  PrefixCursor(const PhaseRef& phase, const PrefixPlan& plan, std::int64_t start)
      : x(phase.data()), rs(phase.outerStride()), end(phase.rows()), nc(phase.cols()), big(plan.big.data()),
        sum(plan.sum.begin() + (start / kSumBlock) * nc, plan.sum.begin() + (start / kSumBlock + 1) * nc),
        comp(plan.comp.begin() + (start / kSumBlock) * nc, plan.comp.begin() + (start / kSumBlock + 1) * nc),
        row(start / kSumBlock * kSumBlock) {}
  const double* x;
  std::int64_t rs, end;  // row stride and rows of the phase
  Eigen::Index nc;
  const double* big;
  std::vector<double> sum, comp;  // TwoSum state of S[row], per channel
  std::int64_t row;
};

/// Advance K cursors together by `rows` rows (interleaved: K independent chains), writing
/// the split S of the rows passed to hi[i], lo[i] (rows x nc, row-major) unless null. S[M]
/// (the row after the phase's last) can be written, no row beyond it.
template <int K>
inline void fill_prefix(PrefixCursor* const* cur, std::int64_t rows, double* const* hi, double* const* lo) {
  const Eigen::Index nc = cur[0]->nc;
  for (Eigen::Index c = 0; c < nc; ++c) {
    const auto uc = static_cast<std::size_t>(c);
    double sum[K], comp[K], big[K];
    const double* x[K];
    for (int i = 0; i < K; ++i) {
      sum[i] = cur[i]->sum[uc];
      comp[i] = cur[i]->comp[uc];
      big[i] = cur[i]->big[uc];
      x[i] = cur[i]->x + cur[i]->row * cur[i]->rs + c;
    }
    const std::int64_t rs = cur[0]->rs;
    bool at_end[K];  // the last row passed is S[M]: nothing to add after it
    for (int i = 0; i < K; ++i) at_end[i] = cur[i]->row + rows > cur[i]->end;
    for (std::int64_t r = 0; r < rows; ++r) {
      for (int i = 0; i < K; ++i) {
        if (hi[i] != nullptr) {
          const double h = (sum[i] + big[i]) - big[i];  // exact rounding (no fast-math)
          hi[i][r * nc + c] = h;
          lo[i][r * nc + c] = (sum[i] - h) + comp[i];  // sum - h is exact
        }
        if (r + 1 == rows && at_end[i]) continue;
        double t, e;
        two_sum(sum[i], x[i][r * rs], t, e);  // the only chain is sum += x
        sum[i] = t;
        comp[i] += e;
      }
    }
    for (int i = 0; i < K; ++i) {
      cur[i]->sum[uc] = sum[i];
      cur[i]->comp[uc] = comp[i];
    }
  }
  for (int i = 0; i < K; ++i) cur[i]->row += rows;
}

/// A cursor at row `start`: from the plan's state at the block below, moved on.
inline PrefixCursor prefix_cursor(const PhaseRef& phase, const PrefixPlan& plan, std::int64_t start) {
  PrefixCursor cur(phase, plan, start);
  PrefixCursor* one[1] = {&cur};
  double* none[1] = {nullptr};
  fill_prefix<1>(one, start - cur.row, none, none);
  return cur;
}

/// Lanes side by side in the single-factor pass (add_modified_single) and in the tiled one
/// (add_modified_lanes): four (one vector) or eight.
constexpr int kModSingleLanes = 4;
constexpr int kModTileLanes = 4;

/// Terms per lane of the modified estimator's running window in the tiled pass (see
/// add_modified_lanes), chosen per factor by mod_lane: a whole block, or a quarter block (four
/// lanes make a summation block). A lane of a whole block starts from the prefix sums a
/// quarter as often (the windows took about a tenth of the tiled pass with quarter blocks);
/// its 256 unguarded moves of the window round to at most O(256 eps) of it (measured at the
/// worst case of test_core_modified.py, factors 1 to 8193: within 2.3e-16 of the exact
/// variance).
constexpr std::int64_t kModLaneLong = kSumBlock;
constexpr std::int64_t kModLaneShort = kSumBlock / 4;

/// The lane of the tiled pass for factor m (a function of m alone, so that every layout of
/// the phase gives the same bits). Whole-block lanes are 8 KiB apart, so the four lanes of a
/// tap share one set of the 8-way L1 cache (4 KiB period); if two taps of a lane fall within
/// a cache line of each other modulo 4 KiB (512 rows), 8 or more streams share a set and the
/// pass slows down up to 3.5x (measured at m = 4096). Quarter-block lanes, 2 KiB apart, spread
/// them over two sets.
inline std::int64_t mod_lane(std::int64_t m) noexcept {
  for (std::int64_t d = 1; d <= 3; ++d) {
    const std::int64_t r = d * m % 512;
    if (r < 8 || r > 504) return kModLaneShort;
  }
  return kModLaneLong;
}

/// The step of the modified estimator's window, w(j+1) - w(j) = d3(j), the third difference at
/// lag m of the phase, written differences first: x3 - x0 and x2 - x1 round relative to the
/// differences (exactly, by Sterbenz, where the phase is far from zero), not to |x|.
ALLANITE_ALWAYS_INLINE double window_step(double x0, double x1, double x2, double x3) noexcept {
  return (x3 - x0) - 3.0 * (x2 - x1);
}

/// out[j] = window_step of term j (one channel of the phase from row b on, row stride rs) for
/// j < avail, 0 for avail <= j < n (the step after the last term would read past the phase).
ALLANITE_TARGET_CLONES static void window_steps(const double* b, std::int64_t m, std::int64_t rs, std::int64_t avail,
                                                std::int64_t n, double* out) noexcept {
  const double* b1 = b + m * rs;
  const double* b2 = b + 2 * m * rs;
  const double* b3 = b + 3 * m * rs;
  if (rs == 1) {
    for (std::int64_t j = 0; j < avail; ++j) out[j] = window_step(b[j], b1[j], b2[j], b3[j]);
  } else {
    for (std::int64_t j = 0; j < avail; ++j) out[j] = window_step(b[j * rs], b1[j * rs], b2[j * rs], b3[j * rs]);
  }
  for (std::int64_t j = std::max<std::int64_t>(avail, 0); j < n; ++j) out[j] = 0.0;
}

/// Groups of four steps whose moves of an exact (TwoSum) window are summed before they are
/// folded into it (see lane_run).
constexpr std::int64_t kModFoldGroups = 4;

/// The running window of one lane of the modified estimator: `n` terms from the window
/// hi + lo, moved on by the steps d[0 .. n) (readable up to n rounded up to 4), squares added
/// to acc. The arithmetic, in groups of four steps from the lane's start (shared bit for bit by
/// lane_groups): with w the window, p1 = d0, p2 = p1 + d1, p3 = p2 + d2, p4 = p3 + d3, the
/// windows of the group are w, w + p1, w + p2, w + p3 (missing terms count as 0),
/// acc += (w^2 + (w + p1)^2) + ((w + p2)^2 + (w + p3)^2), and the window moves on by p4.
/// Not kExact: w = hi, hi = w + p4. kExact (hi, lo a TwoSum pair, so that only the steps' own
/// rounding accumulates, not that of the window): the moves of kModFoldGroups groups are
/// summed, part = p4 + p4' + ..., the windows meanwhile w = (hi + lo) + part, and part is
/// folded into the pair (TwoSum into hi, its error into lo) after every kModFoldGroups groups
/// from the lane's start and after the last; part rounds to O(eps) of a few steps, like the
/// steps. One dependent add per four terms on each chain.
template <bool kExact>
ALLANITE_ALWAYS_INLINE void lane_run(const double* d, std::int64_t n, double& hi, double& lo, double& acc) noexcept {
  double base = hi + lo, part = 0.0;
  for (std::int64_t j = 0; j < n; j += 4) {
    const double w = kExact ? base + part : hi;
    const double p1 = d[j], p2 = p1 + d[j + 1], p3 = p2 + d[j + 2], p4 = p3 + d[j + 3];
    const double x1 = w + p1, x2 = w + p2, x3 = w + p3;
    const double q1 = j + 1 < n ? x1 * x1 : 0.0, q2 = j + 2 < n ? x2 * x2 : 0.0, q3 = j + 3 < n ? x3 * x3 : 0.0;
    acc += (w * w + q1) + (q2 + q3);
    if constexpr (kExact) {
      part += p4;
      if ((j / 4 + 1) % kModFoldGroups == 0 || j + 4 >= n) {
        double s, e;
        two_sum(hi, part, s, e);
        hi = s;
        lo += e;
        base = hi + lo;
        part = 0.0;
      }
    } else {
      hi = w + p4;
    }
  }
}

/// lane_run of eight lanes side by side, `steps` (a multiple of 4, of 4 kModFoldGroups if
/// kExact) steps each: lane k's steps
/// are src[k ls + j] (kFromPhase false) or computed from the phase, src = x of lane 0's first
/// term, unit row stride, every step readable (kFromPhase true). The same arithmetic as
/// lane_run with the lanes in two vectors: four steps of each lane are loaded as a row and
/// the rows transposed in registers. hi, lo, acc: eight lanes' state, updated.
template <bool kFromPhase, bool kExact, int V = 2, std::int64_t kLs = 0>
ALLANITE_ALWAYS_INLINE void lane_groups(const double* src, std::int64_t m, std::int64_t ls_arg, std::int64_t steps,
                                        double* hi, double* lo, double* acc) noexcept {
  const std::int64_t ls = kLs != 0 ? kLs : ls_arg;  // a constant lane stride frees the address registers
  static_assert(V == 1 || V == 2, "four or eight lanes");
// GCC vector extensions; elsewhere (or with ALLANITE_SCALAR_LANES defined, to check that the
// two give the same bits) lane by lane through lane_run
#if defined(__GNUC__) && !defined(__clang__) && !defined(ALLANITE_SCALAR_LANES)
  typedef double v4d __attribute__((vector_size(32)));
  typedef double v4u __attribute__((vector_size(32), aligned(8), may_alias));  // unaligned access
  typedef long long v4i __attribute__((vector_size(32)));
  const v4i lo2 = {0, 4, 2, 6}, hi2 = {1, 5, 3, 7}, lo4 = {0, 1, 4, 5}, hi4 = {2, 3, 6, 7};
  const v4d three = {3.0, 3.0, 3.0, 3.0};
  constexpr std::int64_t kGroups = kExact ? kModFoldGroups : 1;  // groups between folds
#define ALLANITE_LOAD(p) (*reinterpret_cast<const v4u*>(p))
  v4d h0 = ALLANITE_LOAD(hi), l0 = ALLANITE_LOAD(lo), a0 = ALLANITE_LOAD(acc);
  v4d h1 = h0, l1 = l0, a1 = a0;
  if constexpr (V == 2) {
    h1 = ALLANITE_LOAD(hi + 4);
    l1 = ALLANITE_LOAD(lo + 4);
    a1 = ALLANITE_LOAD(acc + 4);
  }
  const double* p = src;
  for (std::int64_t s0 = 0; s0 < steps; s0 += 4 * kGroups) {
    const v4d b0 = h0 + l0, b1 = h1 + l1;  // kExact: the windows' base until the next fold
    v4d part0 = {}, part1 = {};             // kExact: the moves since the last fold
    for (std::int64_t g = 0; g < kGroups; ++g, p += 4) {
      // rows: four steps of one lane; columns after the transpose: one step of four lanes
#define ALLANITE_TAP(k, t) ALLANITE_LOAD(p + (k) * ls + (t) * m)
#define ALLANITE_ROW(k)                                                                             \
  (kFromPhase ? (ALLANITE_TAP(k, 3) - ALLANITE_TAP(k, 0)) - three * (ALLANITE_TAP(k, 2) - ALLANITE_TAP(k, 1)) \
              : ALLANITE_TAP(k, 0))
      // lanes 4q .. 4q + 3 in one vector: window h (kExact: base b, moves part), squares a
#define ALLANITE_LANES(q, h, b, part, a)                                                            \
  do {                                                                                              \
    const v4d r0 = ALLANITE_ROW(4 * (q)), r1 = ALLANITE_ROW(4 * (q) + 1);                           \
    const v4d r2 = ALLANITE_ROW(4 * (q) + 2), r3 = ALLANITE_ROW(4 * (q) + 3);                       \
    const v4d t0 = __builtin_shuffle(r0, r1, lo2), t1 = __builtin_shuffle(r0, r1, hi2);             \
    const v4d t2 = __builtin_shuffle(r2, r3, lo2), t3 = __builtin_shuffle(r2, r3, hi2);             \
    const v4d p1 = __builtin_shuffle(t0, t2, lo4);                                                  \
    const v4d p2 = p1 + __builtin_shuffle(t1, t3, lo4);                                             \
    const v4d p3 = p2 + __builtin_shuffle(t0, t2, hi4);                                             \
    const v4d p4 = p3 + __builtin_shuffle(t1, t3, hi4);                                             \
    const v4d w = kExact ? b + part : h;                                                            \
    const v4d x1 = w + p1, x2 = w + p2, x3 = w + p3;                                                \
    a += (w * w + x1 * x1) + (x2 * x2 + x3 * x3);                                                   \
    if constexpr (kExact) {                                                                         \
      part += p4;                                                                                   \
    } else {                                                                                        \
      h = w + p4;                                                                                   \
    }                                                                                               \
  } while (false)
      ALLANITE_LANES(0, h0, b0, part0, a0);
      if constexpr (V == 2) ALLANITE_LANES(1, h1, b1, part1, a1);
#undef ALLANITE_LANES
#undef ALLANITE_ROW
#undef ALLANITE_TAP
    }
    if constexpr (kExact) {  // the fold: TwoSum of h and the moves, lane by lane (as two_sum)
      const v4d sum0 = h0 + part0, bb0 = sum0 - h0;
      l0 += (h0 - (sum0 - bb0)) + (part0 - bb0);
      h0 = sum0;
      if constexpr (V == 2) {
        const v4d sum1 = h1 + part1, bb1 = sum1 - h1;
        l1 += (h1 - (sum1 - bb1)) + (part1 - bb1);
        h1 = sum1;
      }
    }
  }
#undef ALLANITE_LOAD
  *reinterpret_cast<v4u*>(hi) = h0;
  *reinterpret_cast<v4u*>(lo) = l0;
  *reinterpret_cast<v4u*>(acc) = a0;
  if constexpr (V == 2) {
    *reinterpret_cast<v4u*>(hi + 4) = h1;
    *reinterpret_cast<v4u*>(lo + 4) = l1;
    *reinterpret_cast<v4u*>(acc + 4) = a1;
  }
#else
  std::vector<double> d(static_cast<std::size_t>(steps));
  for (int k = 0; k < 4 * V; ++k) {
    const double* row = src + k * ls;
    if constexpr (kFromPhase) {
      for (std::int64_t j = 0; j < steps; ++j)
        d[j] = window_step(row[j], row[j + m], row[j + 2 * m], row[j + 3 * m]);
      row = d.data();
    }
    lane_run<kExact>(row, steps, hi[k], lo[k], acc[k]);
  }
#endif
}

ALLANITE_TARGET_CLONES static void lane_groups_phase(const double* x, std::int64_t m, std::int64_t ls,
                                                     std::int64_t steps, double* hi, double* lo, double* acc) noexcept {
  lane_groups<true, false, kModTileLanes / 4, kModLaneLong>(x, m, ls, steps, hi, lo, acc);
}
ALLANITE_TARGET_CLONES static void lane_groups_phase_short(const double* x, std::int64_t m, std::int64_t ls,
                                                           std::int64_t steps, double* hi, double* lo,
                                                           double* acc) noexcept {
  lane_groups<true, false, kModTileLanes / 4, kModLaneShort>(x, m, ls, steps, hi, lo, acc);
}
ALLANITE_TARGET_CLONES static void lane_groups_phase_exact(const double* x, std::int64_t m, std::int64_t ls,
                                                           std::int64_t steps, double* hi, double* lo,
                                                           double* acc) noexcept {
  lane_groups<true, true, kModSingleLanes / 4>(x, m, ls, steps, hi, lo, acc);
}
ALLANITE_TARGET_CLONES static void lane_groups_steps_exact(const double* d, std::int64_t ls, std::int64_t steps,
                                                           double* hi, double* lo, double* acc) noexcept {
  lane_groups<false, true, kModSingleLanes / 4>(d, 0, ls, steps, hi, lo, acc);
}
ALLANITE_TARGET_CLONES static void lane_groups_steps(const double* d, std::int64_t ls, std::int64_t steps, double* hi,
                                                     double* lo, double* acc) noexcept {
  lane_groups<false, false, kModTileLanes / 4>(d, 0, ls, steps, hi, lo, acc);
}

/// Add the modified AVAR's squares of `count` terms (from a block boundary, one channel: the
/// phase x from the first term's row on, row stride rs) to total, block by block; a block is
/// kSumBlock / kLane lanes of kLane terms (see mod_lane), its sum the lanes' lane_run sums
/// (combined (a_0 + a_1) + (a_2 + a_3) for four).
/// Lane l starts from the exact window w0[l] (from the prefix sums) and moves on by steps
/// rounded to O(eps) of the window and of the phase's lag-m differences; restarting every
/// kLane terms keeps that drift from growing with the record. `avail`: steps readable
/// (the last term of the record has none). `buf`: kModTileLanes kLane + 4 doubles.
template <std::int64_t kLane>
void add_modified_lanes(const double* x, std::int64_t rs, std::int64_t m, const double* w0, std::int64_t count,
                        std::int64_t avail, NeumaierSum& total, double* buf) {
  static_assert(kLane == kModLaneLong || kLane == kModLaneShort, "a whole or a quarter block");
  constexpr std::int64_t kStride = kModTileLanes * kLane;  // terms per call: whole blocks
  for (std::int64_t b = 0; b < count; b += kStride) {
    const std::int64_t len = std::min(kStride, count - b);
    double hi[kModTileLanes], lo[kModTileLanes] = {}, acc[kModTileLanes] = {};
    std::copy(w0 + b / kLane, w0 + b / kLane + (len + kLane - 1) / kLane, hi);
    if (len == kStride && rs == 1 && avail - b >= len) {  // whole blocks, steps from the phase
      if constexpr (kLane == kModLaneLong) {
        lane_groups_phase(x + b, m, kLane, kLane, hi, lo, acc);
      } else {
        lane_groups_phase_short(x + b, m, kLane, kLane, hi, lo, acc);
      }
    } else {
      window_steps(x + b * rs, m, rs, std::min(len, avail - b), len + 4, buf);
      if (len == kStride) {
        lane_groups_steps(buf, kLane, kLane, hi, lo, acc);
      } else {
        for (std::int64_t k = 0; k * kLane < len; ++k)
          lane_run<false>(buf + k * kLane, std::min(kLane, len - k * kLane), hi[k], lo[k], acc[k]);
      }
    }
    for (std::int64_t k = 0; k * kLane < len; ++k) {
      if constexpr (kLane == kModLaneLong) {
        total.add(acc[k]);
      } else if (k % 4 == 0) {
        total.add((acc[k] + acc[k + 1]) + (acc[k + 2] + acc[k + 3]));
      }
    }
  }
}

/// Most terms of a lane of the single-factor pass between starts from the exact prefix sums.
constexpr std::int64_t kModSegment = 64 * kSumBlock;

/// Smallest factor whose single-factor lanes are spread m apart (see add_modified_single).
constexpr std::int64_t kModSpreadMin = 32 * kSumBlock;

/// Modified AVAR sums of one factor beyond kTileMaxM (no other factor shares its rows). The
/// terms go in passes of four lanes of up to kModSegment terms, evenly spaced, that advance
/// together a block at a time; each lane's window starts from four prefix cursors and moves on
/// by the steps (lane_run, the window a TwoSum pair: at these factors a step rounds to far
/// below eps of the window), steps straight from the phase or via a buffer. Up to
/// kModSpreadMin the lanes of a pass are neighbours (up to 4 kModSegment terms, so that their
/// taps stay close enough to share the cache, as the overlapping kernel's do); from it on they
/// are m apart, lane k covering terms [g + k m, g + (k + 1) m) of a group of 4 m terms in
/// passes of kModSegment, so that tap t + 1 of lane k reads the rows of tap t of lane k + 1
/// in the same block: the four lanes stream 7 row ranges from memory instead of 16. Block
/// sums go to totals pass by pass, lane by lane, in order. The passes depend only on m and
/// the record length. No prefix sums are stored.
static void add_modified_single(const PhaseRef& phase, const PrefixPlan& plan, std::int64_t m,
                                std::int64_t count, NeumaierSum* totals) {
  constexpr int kLanes = kModSingleLanes;
  constexpr std::int64_t kMaxBlocks = kModSegment / kSumBlock;
  const Eigen::Index nc = phase.cols();
  const auto unc = static_cast<std::size_t>(nc);
  const std::int64_t rs = phase.outerStride();
  std::vector<double> w0(kLanes * unc), buf(8 * unc), d(static_cast<std::size_t>(kLanes * kSumBlock + 4));
  std::vector<double> sums(static_cast<std::size_t>(kLanes * kMaxBlocks));
  // one pass: lane k covers terms [base + k ls, base + k ls + lane_len) (within the record)
  const auto pass = [&](std::int64_t base, std::int64_t ls, std::int64_t lane_len) {
    std::int64_t first[kLanes], len[kLanes];
    for (int k = 0; k < kLanes; ++k) {  // the window at each lane's first term, from the prefix sums
      first[k] = std::min(count, base + k * ls);
      len[k] = std::min(count, first[k] + lane_len) - first[k];
      if (len[k] == 0) continue;
      PrefixCursor c0 = prefix_cursor(phase, plan, first[k]), c1 = prefix_cursor(phase, plan, first[k] + m),
                   c2 = prefix_cursor(phase, plan, first[k] + 2 * m), c3 = prefix_cursor(phase, plan, first[k] + 3 * m);
      PrefixCursor* cur[4] = {&c0, &c1, &c2, &c3};
      double* h[4];
      double* l[4];
      for (int i = 0; i < 4; ++i) {
        h[i] = buf.data() + 2 * i * unc;
        l[i] = buf.data() + (2 * i + 1) * unc;
      }
      fill_prefix<4>(cur, 1, h, l);
      const SplitTaps t{{h[0], h[1], h[2], h[3]}, {l[0], l[1], l[2], l[3]}, nc};
      for (Eigen::Index c = 0; c < nc; ++c) w0[static_cast<std::size_t>(k) * unc + c] = tap_diff(t, c);
    }
    for (Eigen::Index c = 0; c < nc; ++c) {
      double hi[kLanes], lo[kLanes] = {}, acc[kLanes];
      for (int k = 0; k < kLanes; ++k) hi[k] = w0[static_cast<std::size_t>(k) * unc + c];
      const double* x = phase.data() + c;
      for (std::int64_t start = 0; start < lane_len; start += kSumBlock) {
        std::int64_t n[kLanes];
        bool full = true;
        for (int k = 0; k < kLanes; ++k) {
          n[k] = std::clamp<std::int64_t>(len[k] - start, 0, kSumBlock);
          full = full && n[k] == kSumBlock;
        }
        std::fill(acc, acc + kLanes, 0.0);
        if (full && rs == 1 && first[kLanes - 1] + start + kSumBlock < count) {  // steps from the phase
          lane_groups_phase_exact(x + first[0] + start, m, ls, kSumBlock, hi, lo, acc);
        } else {
          for (int k = 0; k < kLanes; ++k) {
            const std::int64_t avail = std::min(n[k], count - 1 - (first[k] + start));
            window_steps(x + (first[k] + start) * rs, m, rs, avail, kSumBlock, d.data() + k * kSumBlock);
          }
          if (full) {
            lane_groups_steps_exact(d.data(), kSumBlock, kSumBlock, hi, lo, acc);
          } else {
            for (int k = 0; k < kLanes; ++k) lane_run<true>(d.data() + k * kSumBlock, n[k], hi[k], lo[k], acc[k]);
          }
        }
        for (int k = 0; k < kLanes; ++k) sums[static_cast<std::size_t>(k * kMaxBlocks + start / kSumBlock)] = acc[k];
      }
      for (int k = 0; k < kLanes; ++k)
        for (std::int64_t b = 0; b < len[k]; b += kSumBlock)
          totals[c].add(sums[static_cast<std::size_t>(k * kMaxBlocks + b / kSumBlock)]);
    }
  };
  // groups of lanes spread m / q apart while whole ones fit (q = 1, 2, 3: tap t + q of lane k
  // reads about the rows of tap t of lane k + q), the rest (and every term below
  // kModSpreadMin) in passes of neighbouring lanes
  std::int64_t g0 = 0;
  for (std::int64_t q = 1; q <= 3 && m >= kModSpreadMin; ++q) {
    const std::int64_t spacing = (m + q - 1) / q;
    for (; g0 + kLanes * spacing <= count; g0 += kLanes * spacing)
      for (std::int64_t r = 0; r < spacing; r += kModSegment) pass(g0 + r, spacing, std::min(kModSegment, spacing - r));
  }
  while (g0 < count) {
    const std::int64_t blocks = (count - g0 + kSumBlock - 1) / kSumBlock;
    const std::int64_t lane_len = std::min(kMaxBlocks, (blocks + kLanes - 1) / kLanes) * kSumBlock;
    pass(g0, lane_len, lane_len);
    g0 += kLanes * lane_len;
  }
}

/// The end terms of the total variance, which read the reflected extension: term j of the
/// left end is i = j + 1 (x*[i-m] = 2 x[0] - x[m-i]), of the right end i = M - m + j
/// (x*[i+m] = 2 x[M-1] - x[M-2-j]); j < m - 1 on either side. One channel, row stride rs.
struct LeftEnd {
  const double* x;
  std::int64_t rs, m;
  double twice_first;
};
struct RightEnd {
  const double* x;
  std::int64_t rs, m, M;
  double twice_last;
};
ALLANITE_ALWAYS_INLINE double tap_diff(const LeftEnd& t, std::int64_t j) noexcept {
  return diff2(t.twice_first - t.x[(t.m - 1 - j) * t.rs], t.x[(j + 1) * t.rs], t.x[(j + 1 + t.m) * t.rs]);
}
ALLANITE_ALWAYS_INLINE double tap_diff(const RightEnd& t, std::int64_t j) noexcept {
  return diff2(t.x[(t.M - 2 * t.m + j) * t.rs], t.x[(t.M - t.m + j) * t.rs], t.twice_last - t.x[(t.M - 2 - j) * t.rs]);
}

/// Add the 2 (m - 1) end terms of the total variance to totals (the others are the
/// overlapping AVAR's terms): per channel, the left end's blocks, then the right end's.
inline void add_total_ends(const PhaseRef& phase, std::int64_t m, NeumaierSum* totals) {
  const std::int64_t M = phase.rows();
  const std::int64_t rs = phase.outerStride();
  for (Eigen::Index c = 0; c < phase.cols(); ++c) {
    const double* x = phase.data() + c;
    add_diff_squares_1ch_impl(LeftEnd{x, rs, m, 2.0 * x[0]}, m - 1, totals[c]);
    add_diff_squares_1ch_impl(RightEnd{x, rs, m, M, 2.0 * x[(M - 1) * rs]}, m - 1, totals[c]);
  }
}

/// Terms per tile of the tau-blocked pass (a multiple of kSumBlock, so the block grid of
/// every factor is unchanged and the sums are bit-for-bit those of a single pass).
constexpr std::int64_t kTileTerms = 8 * kSumBlock;
/// Largest factor tiled: the tile's rows (kTileTerms + 3m) x channels stay in L2.
constexpr std::int64_t kTileMaxM = 8192;

/// Difference terms a kind sums with its taps: all of them, except for the total variance,
/// whose taps cover the M - 2m terms equal to the overlapping AVAR's (add_total_ends adds
/// the others).
inline std::int64_t tap_terms(VarianceKind kind, std::int64_t M, std::int64_t m) {
  return kind == VarianceKind::Total ? M - 2 * m : n_terms(kind, M, m);
}

/// fill_prefix<4> of four whole blocks of one contiguous channel, x[i kSumBlock ...] from the
/// states sum[i], comp[i], into h[i], l[i] (the same arithmetic, the four chains in a vector:
/// four rows of each block are loaded and transposed in registers, and back for the stores).
ALLANITE_TARGET_CLONES static void fill_blocks4(const double* x, double big, const double* sum, const double* comp,
                                                double* const* h, double* const* l) noexcept {
#if defined(__GNUC__) && !defined(__clang__) && !defined(ALLANITE_SCALAR_LANES)
  typedef double v4d __attribute__((vector_size(32)));
  typedef double v4u __attribute__((vector_size(32), aligned(8), may_alias));  // unaligned access
  typedef long long v4i __attribute__((vector_size(32)));
  const v4i lo2 = {0, 4, 2, 6}, hi2 = {1, 5, 3, 7}, lo4 = {0, 1, 4, 5}, hi4 = {2, 3, 6, 7};
  const v4d b = {big, big, big, big};
  v4d sv = *reinterpret_cast<const v4u*>(sum), cv = *reinterpret_cast<const v4u*>(comp);
#define ALLANITE_TRANSPOSE(r0, r1, r2, r3, c)                                                    \
  do {                                                                                           \
    const v4d t0 = __builtin_shuffle(r0, r1, lo2), t1 = __builtin_shuffle(r0, r1, hi2);          \
    const v4d t2 = __builtin_shuffle(r2, r3, lo2), t3 = __builtin_shuffle(r2, r3, hi2);          \
    c[0] = __builtin_shuffle(t0, t2, lo4);                                                       \
    c[1] = __builtin_shuffle(t1, t3, lo4);                                                       \
    c[2] = __builtin_shuffle(t0, t2, hi4);                                                       \
    c[3] = __builtin_shuffle(t1, t3, hi4);                                                       \
  } while (false)
  for (std::int64_t r = 0; r < kSumBlock; r += 4) {
    v4d xr[4], hr[4], lr[4], hc[4], lc[4];
    const double* p = x + r;
    ALLANITE_TRANSPOSE(*reinterpret_cast<const v4u*>(p), *reinterpret_cast<const v4u*>(p + kSumBlock),
                       *reinterpret_cast<const v4u*>(p + 2 * kSumBlock),
                       *reinterpret_cast<const v4u*>(p + 3 * kSumBlock), xr);
    for (int k = 0; k < 4; ++k) {  // row r + k of the four blocks
      hr[k] = (sv + b) - b;
      lr[k] = (sv - hr[k]) + cv;
      const v4d t = sv + xr[k], bb = t - sv;
      cv += (sv - (t - bb)) + (xr[k] - bb);  // TwoSum error
      sv = t;
    }
    ALLANITE_TRANSPOSE(hr[0], hr[1], hr[2], hr[3], hc);
    ALLANITE_TRANSPOSE(lr[0], lr[1], lr[2], lr[3], lc);
    for (int i = 0; i < 4; ++i) {
      *reinterpret_cast<v4u*>(h[i] + r) = hc[i];
      *reinterpret_cast<v4u*>(l[i] + r) = lc[i];
    }
  }
#undef ALLANITE_TRANSPOSE
#else
  for (int i = 0; i < 4; ++i) {
    double sv = sum[i], cv = comp[i];
    for (std::int64_t r = 0; r < kSumBlock; ++r) {
      const double hv = (sv + big) - big;
      h[i][r] = hv;
      l[i][r] = (sv - hv) + cv;
      double t, e;
      two_sum(sv, x[i * kSumBlock + r], t, e);
      sv = t;
      cv += e;
    }
  }
#endif
}

/// The prefix sums S[k0 .. k0 + span) that a tile of factors up to top_m reads where its
/// lanes start, in a ring of whole blocks (span = kTileTerms + 3 top_m rounded up to blocks):
/// a tile fills only the blocks it adds, each regenerated from its mark of the plan, four
/// blocks side by side, so that S[r] depends on r alone (not on the tiles or threads).
struct PrefixRing {
  /// From row `first` on (a multiple of kSumBlock: the tile where the pass starts).
  PrefixRing(const PhaseRef& ph, const PrefixPlan& pl, std::int64_t top_m, std::int64_t first = 0)
      : phase(ph), plan(pl), rows(ph.rows() + 1), nc(ph.cols()),
        span(kTileTerms + (3 * top_m + kSumBlock - 1) / kSumBlock * kSumBlock),
        hi(static_cast<std::size_t>(span * nc)), lo(hi.size()), filled(first) {}

  /// Make rows [k0, k0 + span) present (those below rows).
  void cover(std::int64_t k0) {
    const std::int64_t target = std::min(k0 + span, rows);
    while (filled < target) {
      if (filled + 4 * kSumBlock <= target) {  // four whole blocks side by side
        PrefixCursor c0(phase, plan, filled), c1(phase, plan, filled + kSumBlock),
            c2(phase, plan, filled + 2 * kSumBlock), c3(phase, plan, filled + 3 * kSumBlock);
        PrefixCursor* cur[4] = {&c0, &c1, &c2, &c3};
        double* h[4];
        double* l[4];
        for (int i = 0; i < 4; ++i) {
          h[i] = slot(hi, filled + i * kSumBlock);
          l[i] = slot(lo, filled + i * kSumBlock);
        }
        if (nc == 1 && phase.outerStride() == 1 && filled + 4 * kSumBlock <= phase.rows()) {
          double sum[4], comp[4];
          for (int i = 0; i < 4; ++i) {
            sum[i] = cur[i]->sum[0];
            comp[i] = cur[i]->comp[0];
          }
          fill_blocks4(phase.data() + filled, plan.big[0], sum, comp, h, l);
        } else {
          fill_prefix<4>(cur, kSumBlock, h, l);
        }
        filled += 4 * kSumBlock;
      } else {
        PrefixCursor c0(phase, plan, filled);
        PrefixCursor* cur[1] = {&c0};
        double* h[1] = {slot(hi, filled)};
        double* l[1] = {slot(lo, filled)};
        const std::int64_t n = std::min(kSumBlock, target - filled);
        fill_prefix<1>(cur, n, h, l);
        filled += n;
      }
    }
  }

  /// The exact windows w(j) = S[j+3m] - 3 S[j+2m] + 3 S[j+m] - S[j] of channel c at
  /// j = k0, k0 + lane, ... (`lanes` of them) into out.
  void windows(std::int64_t k0, std::int64_t m, std::int64_t lane, Eigen::Index c, std::int64_t lanes,
               double* out) const {
    std::int64_t slot[4];
    for (int i = 0; i < 4; ++i) slot[i] = (k0 + i * m) % span;
    for (std::int64_t q = 0; q < lanes; ++q) {
      const SplitTaps t{{&hi[slot[0] * nc], &hi[slot[1] * nc], &hi[slot[2] * nc], &hi[slot[3] * nc]},
                        {&lo[slot[0] * nc], &lo[slot[1] * nc], &lo[slot[2] * nc], &lo[slot[3] * nc]},
                        nc};
      out[q] = tap_diff(t, c);
      for (int i = 0; i < 4; ++i) {
        slot[i] += lane;
        if (slot[i] >= span) slot[i] -= span;
      }
    }
  }

 private:
  double* slot(std::vector<double>& v, std::int64_t row) const { return v.data() + row % span * nc; }
  const PhaseRef& phase;
  const PrefixPlan& plan;
  std::int64_t rows;
  Eigen::Index nc;
  std::int64_t span;
  std::vector<double> hi, lo;
  std::int64_t filled;  // rows [first, filled) have been generated
};

/// Variances of the factors ms[idx[...]] in one pass over the rows: tile by tile of
/// kTileTerms terms, every factor adds the tile's terms to its own compensated sums (for a
/// single factor that is one plain pass). `plan`: the prefix sums (modified only), regenerated
/// tile by tile into a PrefixRing where the lanes start.
/// The normalisation of a kind's sum of squares for factor m on M rows.
inline double variance_norm(VarianceKind kind, std::int64_t M, std::int64_t m) {
  const double md = static_cast<double>(m);
  const double nd = static_cast<double>(n_terms(kind, M, m));
  if (kind == VarianceKind::Hadamard || kind == VarianceKind::StandardHadamard) return 6.0 * md * md * nd;
  if (kind == VarianceKind::Modified) return 2.0 * md * md * md * md * nd;
  return 2.0 * md * md * nd;
}

/// `terms` [k_begin, k_end) of a variance_group (tile-aligned) whose sums go to `sums`
/// (per factor, per channel) instead of the result: the modified factors up to kTileMaxM run
/// in two such row ranges (see variance).
struct TermRange {
  std::int64_t k_begin, k_end;
  std::vector<std::vector<NeumaierSum>>* sums;
};

inline void variance_group(const PhaseRef& phase, const PrefixPlan* plan, VarianceKind kind,
                           const std::vector<std::int64_t>& ms, const std::vector<std::size_t>& idx,
                           RowMatrix& out, const TermRange* range = nullptr) {
  const std::int64_t M = phase.rows();
  const Eigen::Index nc = phase.cols();
  const double* x = phase.data();
  const std::int64_t rs = phase.outerStride();
  std::vector<std::vector<NeumaierSum>> totals(idx.size(), std::vector<NeumaierSum>(static_cast<std::size_t>(nc)));
  std::vector<std::int64_t> n(idx.size());
  std::int64_t longest = 0;
  for (std::size_t a = 0; a < idx.size(); ++a) {
    n[a] = tap_terms(kind, M, ms[idx[a]]);
    longest = std::max(longest, n[a]);
  }
  const bool strided = kind == VarianceKind::Standard || kind == VarianceKind::StandardHadamard;
  std::int64_t top_m = 0;
  for (const std::size_t i : idx) top_m = std::max(top_m, ms[i]);
  // modified beyond kTileMaxM (a factor alone): eight lanes from cursors, add_modified_single
  const bool windowed = kind == VarianceKind::Modified && top_m <= kTileMaxM;
  if (kind == VarianceKind::Modified && !windowed) longest = 0;
  // modified: the prefix sums of the tile's rows, where its lanes start (add_modified_lanes)
  std::optional<PrefixRing> ring;
  const std::int64_t k_begin = range != nullptr ? range->k_begin : 0;
  if (range != nullptr) longest = std::min(longest, range->k_end);
  if (windowed) ring.emplace(phase, *plan, top_m, k_begin);
  std::vector<double> anchors(windowed ? kTileTerms / kModLaneShort : 0),
      steps(windowed ? kModTileLanes * kModLaneLong + 4 : 0);
  // Hadamard, one channel in unit stride: the factors of a tile go in fours side by side (their
  // first taps read the same rows), over the whole blocks all four have; the rest one by one
  constexpr std::size_t kSide = 4;
  const bool side_by_side = kind == VarianceKind::Hadamard && nc == 1 && rs == 1 && idx.size() > 1;
  for (std::int64_t k0 = k_begin; k0 < longest; k0 += kTileTerms) {
    if (windowed) ring->cover(k0);
    if (side_by_side) {
      for (std::size_t a0 = 0; a0 < idx.size(); a0 += kSide) {
        const std::size_t a1 = std::min(idx.size(), a0 + kSide);
        std::int64_t common = kTileTerms;  // whole blocks of the tile that every factor has
        for (std::size_t a = a0; a < a1; ++a) common = std::min(common, n[a] - k0);
        common = a1 - a0 > 1 && common > 0 ? common / kSumBlock * kSumBlock : 0;
        const double* b = x + k0;
        if (common > 0) {
          const double* p[kSide][3];
          NeumaierSum* tot[kSide];
          for (std::size_t a = a0; a < a1; ++a) {
            const std::int64_t m = ms[idx[a]];
            for (std::int64_t i = 0; i < 3; ++i) p[a - a0][i] = b + (i + 1) * m;
            tot[a - a0] = totals[a].data();
          }
          add_hadamard_side_by_side(static_cast<int>(a1 - a0), b, p, common, tot);
        }
        for (std::size_t a = a0; a < a1; ++a) {
          const std::int64_t rest = std::min(kTileTerms, n[a] - k0) - common;
          if (rest <= 0) continue;
          const std::int64_t m = ms[idx[a]];
          const double* c = b + common;
          add_diff_squares(Taps<3>{{c, c + m, c + 2 * m, c + 3 * m}, 1}, rest, 1, totals[a].data());
        }
      }
      continue;
    }
    for (std::size_t a = 0; a < idx.size(); ++a) {
      if (k0 >= n[a]) continue;
      const std::int64_t m = ms[idx[a]];
      const std::int64_t count = std::min(kTileTerms, n[a] - k0);
      const std::int64_t step = (strided ? m : 1) * rs;
      NeumaierSum* tot = totals[a].data();
      switch (kind) {
        case VarianceKind::Modified: {
          // every lane's first window from the prefix sums, the others by steps of the phase
          const std::int64_t lane = mod_lane(m);
          const std::int64_t lanes = (count + lane - 1) / lane;
          for (Eigen::Index c = 0; c < nc; ++c) {
            ring->windows(k0, m, lane, c, lanes, anchors.data());
            const double* b = x + k0 * rs + c;
            const std::int64_t avail = n[a] - 1 - k0;
            if (lane == kModLaneLong) {
              add_modified_lanes<kModLaneLong>(b, rs, m, anchors.data(), count, avail, tot[c], steps.data());
            } else {
              add_modified_lanes<kModLaneShort>(b, rs, m, anchors.data(), count, avail, tot[c], steps.data());
            }
          }
          break;
        }
        case VarianceKind::Hadamard:
        case VarianceKind::StandardHadamard: {
          const double* b = x + k0 * step;
          add_diff_squares(Taps<3>{{b, b + m * rs, b + 2 * m * rs, b + 3 * m * rs}, step}, count, nc, tot);
          break;
        }
        default: {
          const double* b = x + k0 * step;
          add_diff_squares(Taps<2>{{b, b + m * rs, b + 2 * m * rs}, step}, count, nc, tot);
          break;
        }
      }
    }
  }
  if (range != nullptr) {
    *range->sums = std::move(totals);
    return;
  }
  for (std::size_t a = 0; a < idx.size(); ++a) {
    const std::int64_t m = ms[idx[a]];
    if (kind == VarianceKind::Modified && top_m > kTileMaxM)
      add_modified_single(phase, *plan, m, n[a], totals[a].data());
    if (kind == VarianceKind::Total) add_total_ends(phase, m, totals[a].data());
    const double norm = variance_norm(kind, M, m);
    for (Eigen::Index c = 0; c < nc; ++c)
      out(static_cast<Eigen::Index>(idx[a]), c) = totals[a][static_cast<std::size_t>(c)].value() / norm;
  }
}

}  // namespace detail

/// Variances for a list of averaging factors (rows of the result), threaded over factors.
/// Bit-for-bit independent of `threads`: each factor is computed by one thread, and its sums
/// run in the same order whichever group it falls in.
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
  if (ms.empty()) return out;
  const int nthreads = resolve_threads(threads);
  detail::PrefixPlan plan;
  if (kind == VarianceKind::Modified) plan = detail::prefix_plan(phase, nthreads);
  // Cache blocking over taus: the overlapping-type estimators at small m read the same rows,
  // so they share passes (detail::variance_group); one group per thread. Beyond kTileMaxM the
  // overlapping, Hadamard and total factors go in groups of kWideGroup neighbours (their first
  // tap reads the same rows, the others stay in the last-level cache between the factors:
  // one pass from memory for four factors instead of four); the modified and standard ones
  // are one task each. Longest tasks first keeps both cores busy to the end.
  std::vector<std::vector<std::size_t>> groups;
  std::vector<std::size_t> single;
  const bool tiled = kind != VarianceKind::Standard && kind != VarianceKind::StandardHadamard;
  std::vector<std::size_t> small;
  for (std::size_t i = 0; i < ms.size(); ++i) {
    if (tiled && ms[i] <= detail::kTileMaxM)
      small.push_back(i);
    else
      single.push_back(i);
  }
  // The modified factors up to kTileMaxM: one group whose terms run in two row ranges, split
  // at a tile near the middle of the record (a function of M alone), as two tasks; each
  // generates only its own rows' prefix sums and reads only its half of the phase. The sums
  // of the second range are added to those of the first, so the bits depend neither on the
  // threads nor on the other factors.
  const bool ranged = kind == VarianceKind::Modified && !small.empty();
  std::vector<std::vector<NeumaierSum>> range_sums[2];
  const std::int64_t split = M / 2 / detail::kTileTerms * detail::kTileTerms;
  const detail::TermRange ranges[2] = {{0, split, &range_sums[0]},
                                       {split, std::numeric_limits<std::int64_t>::max(), &range_sums[1]}};
  const std::size_t n_ranged = ranged ? 2 : 0;  // the first tasks
  if (!ranged && small.size() > 1) {
    const std::size_t ng = std::min<std::size_t>(static_cast<std::size_t>(nthreads), small.size());
    groups.resize(ng);
    for (std::size_t a = 0; a < small.size(); ++a) groups[a % ng].push_back(small[a]);
  } else if (!ranged) {
    single.insert(single.begin(), small.begin(), small.end());
  }
  if (tiled && kind != VarianceKind::Modified) {
    constexpr std::size_t kWideGroup = 4;
    std::vector<std::size_t> wide;
    wide.swap(single);
    for (std::size_t a = 0; a < wide.size(); a += kWideGroup)
      groups.emplace_back(wide.begin() + static_cast<std::ptrdiff_t>(a),
                          wide.begin() + static_cast<std::ptrdiff_t>(std::min(wide.size(), a + kWideGroup)));
  }
  parallel_for(n_ranged + groups.size() + single.size(), nthreads, [&](std::size_t task) {
    if (task < n_ranged) {
      detail::variance_group(phase, &plan, kind, ms, small, out, &ranges[task]);
    } else if (task < n_ranged + groups.size()) {
      detail::variance_group(phase, &plan, kind, ms, groups[task - n_ranged], out);
    } else {
      detail::variance_group(phase, &plan, kind, ms, {single[task - n_ranged - groups.size()]}, out);
    }
  });
  if (ranged) {
    for (std::size_t a = 0; a < small.size(); ++a) {
      const double norm = detail::variance_norm(kind, M, ms[small[a]]);
      for (Eigen::Index c = 0; c < phase.cols(); ++c) {
        const auto uc = static_cast<std::size_t>(c);
        NeumaierSum total = range_sums[0][a][uc];
        total.add(range_sums[1][a][uc].hi());
        total.add(range_sums[1][a][uc].lo());
        out(static_cast<Eigen::Index>(small[a]), c) = total.value() / norm;
      }
    }
  }
  return out;
}

}  // namespace allanite
