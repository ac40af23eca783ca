// Function multi-versioning for the hot loops of every header (phase build, kernels, noise
// identification).
#pragma once

// The hot loops are compiled twice, for AVX2 and for the baseline ISA, and picked at load time
// (GCC function multi-versioning). Each lane performs the same IEEE operations in the same
// order either way (no FMA contraction: -ffp-contract=off), so the clones agree bit for bit.
// The loop bodies are forced inline into the clones: otherwise both call one baseline copy.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define ALLANITE_TARGET_CLONES __attribute__((target_clones("avx2", "default")))
#define ALLANITE_ALWAYS_INLINE inline __attribute__((always_inline))
// for 4-lane bodies that vectorise as they are (SLP), where loop vectorisation adds shuffles
#define ALLANITE_SLP_ONLY __attribute__((optimize("no-tree-loop-vectorize")))
#else
#define ALLANITE_SLP_ONLY
#define ALLANITE_TARGET_CLONES
#define ALLANITE_ALWAYS_INLINE inline
#endif

namespace allanite {

/// Four doubles operated on lane by lane (one AVX2 vector, two SSE2 ones): a GCC/Clang vector
/// type, else a struct with the same lane-wise operators. Each lane does the IEEE operations
/// written, in that order, so either form gives the same bits. Built in place (braces, memcpy):
/// passing it by value through a function is an ABI question on x86 without AVX.
#if defined(__GNUC__)
typedef double Pack4 __attribute__((vector_size(32)));
#else
struct Pack4 {
  double v[4];
  double operator[](int i) const noexcept { return v[i]; }
  double& operator[](int i) noexcept { return v[i]; }
  friend Pack4 operator+(Pack4 a, const Pack4& b) noexcept {
    for (int i = 0; i < 4; ++i) a.v[i] += b.v[i];
    return a;
  }
  friend Pack4 operator-(Pack4 a, const Pack4& b) noexcept {
    for (int i = 0; i < 4; ++i) a.v[i] -= b.v[i];
    return a;
  }
  friend Pack4 operator*(Pack4 a, const Pack4& b) noexcept {
    for (int i = 0; i < 4; ++i) a.v[i] *= b.v[i];
    return a;
  }
  Pack4& operator+=(const Pack4& b) noexcept { return *this = *this + b; }
};
#endif

}  // namespace allanite
