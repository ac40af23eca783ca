// Recursive noise generators: banks of first-order (AR(1)) recursions and random walks.
//
// Every recursive part of the simulator is one call of `ar1_bank`: J independent first-order
// recursions per channel, driven by standard normal numbers supplied by the caller (so the
// random numbers, and hence the samples, are fixed by the caller's seeded generator), summed
// into one output per channel. For component j and channel c at sample k:
//
//     e        = q_j * z[k, j, c]                   (innovation)
//     out[k,c] += a_j * x[j, c] + b_j * e           (what the sample sees of component j)
//     x[j, c]  = phi_j * x[j, c] + e                (state update)
//
// Choices of (phi, q, a, b) give the exact discretisations used by allanite.simulation:
//   * point-sampled AR(1) (x_k itself):       a = phi, b = 1   (out = x_{k+1})
//   * random walk sampled at its start:       phi = 1, a = 1, b = 0
//   * sample average of a continuous Gauss-Markov process or Wiener process over the sample
//     period: a = E[avg | x_k] / x_k, b = Cov(avg, e) / Var(e); the remaining independent
//     part of the average is added by the caller.
// The state carries over between calls, so a long record is generated block by block with
// results identical to one long call. Channels are independent and may run on several
// threads; each channel is computed by one thread with the same arithmetic, so the result is
// bit-for-bit independent of the thread count.
#pragma once

#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>

#include "allanite/compensated.hpp"
#include "allanite/parallel.hpp"

namespace allanite {

/// Dimensions of one ar1_bank call: B samples, J components, C channels.
struct BankShape {
  std::size_t samples;
  std::size_t components;
  std::size_t channels;
};

/// Run J first-order recursions per channel over B samples (see the header comment).
///
/// state: J x C row-major, updated in place. phi, q, a, b: length J.
/// z: B x J x C row-major standard normals. out: B x C row-major, overwritten.
inline void ar1_bank(double* state, const double* phi, const double* q, const double* a,
                     const double* b, const double* z, double* out, BankShape shape,
                     int threads) {
  const std::size_t B = shape.samples, J = shape.components, C = shape.channels;
  for (std::size_t j = 0; j < J; ++j) {
    if (!(phi[j] >= -1.0 && phi[j] <= 1.0))
      throw std::invalid_argument("ar1_bank: phi[" + std::to_string(j) +
                                  "] must lie in [-1, 1] (a stable or unit-root recursion)");
  }
  parallel_for(C, threads, [&](std::size_t c) {
    for (std::size_t k = 0; k < B; ++k) {
      double acc = 0.0;
      const double* zk = z + (k * J) * C + c;
      for (std::size_t j = 0; j < J; ++j) {
        double& x = state[j * C + c];
        const double e = q[j] * zk[j * C];
        acc += a[j] * x + b[j] * e;
        x = phi[j] * x + e;
      }
      out[k * C + c] = acc;
    }
  });
}

/// Compensated running sum over B samples of C channels, carried across calls.
///
/// hi, lo: length-C state (the Neumaier sum and its compensation), updated in place.
/// x: B x C row-major increments. out: B x C row-major, out[k, c] = sum of x[0..k, c] plus
/// the carried total, rounded once. Chunked calls give the same result as one call.
inline void running_sum(double* hi, double* lo, const double* x, double* out, std::size_t B,
                        std::size_t C) {
  for (std::size_t c = 0; c < C; ++c) {
    double sum = hi[c], comp = lo[c];
    for (std::size_t k = 0; k < B; ++k) {
      const double v = x[k * C + c];
      const double t = sum + v;
      if (std::fabs(sum) >= std::fabs(v)) {
        comp += (sum - t) + v;
      } else {
        comp += (v - t) + sum;
      }
      sum = t;
      out[k * C + c] = sum + comp;
    }
    hi[c] = sum;
    lo[c] = comp;
  }
}

}  // namespace allanite
