// Compensated (Neumaier) summation and error-free transformations.
//
// The prefix sums of a long gyro record are the heart of every Allan-family kernel: with a
// large bias or drift, naive accumulation destroys the second differences. These helpers keep
// the rounding error of a running sum at O(eps) independent of its length.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "allanite/simd.hpp"

namespace allanite {

/// Neumaier's improved Kahan summation: value() is the sum correct to about one rounding.
class NeumaierSum {
 public:
  NeumaierSum() = default;
  /// Resume a sum from its state (hi(), lo()), e.g. across the chunks of a file.
  NeumaierSum(double hi, double lo) noexcept : sum_(hi), comp_(lo) {}
  void add(double x) noexcept {
    const double t = sum_ + x;
    if (std::fabs(sum_) >= std::fabs(x)) {
      comp_ += (sum_ - t) + x;
    } else {
      comp_ += (x - t) + sum_;
    }
    sum_ = t;
  }
  [[nodiscard]] double value() const noexcept { return sum_ + comp_; }
  [[nodiscard]] double hi() const noexcept { return sum_; }
  [[nodiscard]] double lo() const noexcept { return comp_; }

 private:
  double sum_ = 0.0;
  double comp_ = 0.0;
};

/// Knuth's TwoSum: s + e == a + b exactly.
inline void two_sum(double a, double b, double& s, double& e) noexcept {
  s = a + b;
  const double bb = s - a;
  e = (a - (s - bb)) + (b - bb);
}

/// TwoProduct with a fused multiply-add: p + e == a * b exactly.
inline void two_prod(double a, double b, double& p, double& e) noexcept {
  p = a * b;
  e = std::fma(a, b, -p);
}

/// A compensated sum kept in kLanes lanes: term k (a global index, e.g. the sample number) goes
/// to lane k mod kLanes, each lane a TwoSum pair (hi, lo), so a long sum is kLanes independent
/// chains that vectorise instead of one latency-bound chain. TwoSum's error term is the one
/// Neumaier's branch computes, so each lane is exactly a NeumaierSum of its terms. Lanes by
/// global index make the sum independent of how the terms are cut into chunks (streaming.hpp:
/// the state is carried between chunks as kStateSize doubles, his then los).
struct LaneSum {
  static constexpr int kLanes = 4;
  static constexpr int kStateSize = 2 * kLanes;
  double hi[kLanes] = {};
  double lo[kLanes] = {};

  /// The total: Neumaier over the lanes' hi in lane order, then their lo.
  [[nodiscard]] double value() const noexcept {
    NeumaierSum total;
    for (const double h : hi) total.add(h);
    for (const double l : lo) total.add(l);
    return total.value();
  }
};

/// One term v into lane r of s (TwoSum, the arithmetic of every lane).
ALLANITE_ALWAYS_INLINE void lane_add(LaneSum& s, int r, double v) noexcept {
  const double t = s.hi[r] + v;
  const double bb = t - s.hi[r];
  s.lo[r] += (s.hi[r] - (t - bb)) + (v - bb);
  s.hi[r] = t;
}

/// s += sum_{k<n} (x[k * stride] - a) - b, term k in lane (k0 + k) mod kLanes.
template <class T>
ALLANITE_ALWAYS_INLINE void add_shifted_lanes_impl(const T* x, std::ptrdiff_t stride, std::int64_t n,
                                                   std::int64_t k0, double a, double b, LaneSum& s) noexcept {
  constexpr int L = LaneSum::kLanes;
  static_assert(L == 4, "the lanes are one Pack4");
  std::int64_t k = 0;
  for (; k < n && (k0 + k) % L != 0; ++k)
    lane_add(s, static_cast<int>((k0 + k) % L), (static_cast<double>(x[k * stride]) - a) - b);
  if (k + L <= n) {
    Pack4 hi, lo, v;
    std::memcpy(&hi, s.hi, sizeof hi);
    std::memcpy(&lo, s.lo, sizeof lo);
    const Pack4 pa = {a, a, a, a}, pb = {b, b, b, b};
    for (; k + L <= n; k += L) {
      if constexpr (std::is_same_v<T, double>) {
        if (stride == 1) {
          std::memcpy(&v, x + k, sizeof v);
        } else {
          for (int r = 0; r < L; ++r) v[r] = x[(k + r) * stride];
        }
      } else {
        for (int r = 0; r < L; ++r) v[r] = static_cast<double>(x[(k + r) * stride]);
      }
      v = (v - pa) - pb;
      const Pack4 t = hi + v;  // lane_add, four lanes at once
      const Pack4 bb = t - hi;
      lo += (hi - (t - bb)) + (v - bb);
      hi = t;
    }
    std::memcpy(s.hi, &hi, sizeof hi);
    std::memcpy(s.lo, &lo, sizeof lo);
  }
  for (; k < n; ++k) lane_add(s, static_cast<int>((k0 + k) % L), (static_cast<double>(x[k * stride]) - a) - b);
}

[[maybe_unused]] ALLANITE_TARGET_CLONES static void add_shifted_lanes_contiguous(const double* x, std::int64_t n, std::int64_t k0,
                                                                double a, double b, LaneSum& s) noexcept {
  add_shifted_lanes_impl(x, 1, n, k0, a, b, s);
}

/// s += sum_{k<n} (x[k * stride] - a) - b with term k in lane (k0 + k) mod kLanes (LaneSum);
/// the contiguous float64 case runs the vectorised clone.
template <class T>
inline void add_shifted_lanes(const T* x, std::ptrdiff_t stride, std::int64_t n, std::int64_t k0, double a,
                              double b, LaneSum& s) noexcept {
  if constexpr (std::is_same_v<T, double>) {
    if (stride == 1) {
      add_shifted_lanes_contiguous(x, n, k0, a, b, s);
      return;
    }
  }
  add_shifted_lanes_impl(x, stride, n, k0, a, b, s);
}

/// Sum of many positive or mixed terms: blocks of plain accumulation folded into a
/// compensated total. Error O(block * eps) instead of O(n * eps); vectorises well.
class BlockedSum {
 public:
  static constexpr int kBlock = 512;
  void add(double x) noexcept {
    block_ += x;
    if (++count_ == kBlock) flush();
  }
  [[nodiscard]] double value() noexcept {
    flush();
    return total_.value();
  }

 private:
  void flush() noexcept {
    total_.add(block_);
    block_ = 0.0;
    count_ = 0;
  }
  NeumaierSum total_;
  double block_ = 0.0;
  int count_ = 0;
};

}  // namespace allanite
