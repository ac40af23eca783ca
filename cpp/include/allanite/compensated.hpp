// Compensated (Neumaier) summation and error-free transformations.
//
// The prefix sums of a long gyro record are the heart of every Allan-family kernel: with a
// large bias or drift, naive accumulation destroys the second differences. These helpers keep
// the rounding error of a running sum at O(eps) independent of its length.
#pragma once

#include <cmath>

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
