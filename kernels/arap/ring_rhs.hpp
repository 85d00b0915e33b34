// The ARAP global step's rotated one-ring sums, the twin of ring_rhs in core/src/arap/ring_correlation.hpp
// (Sorkine & Alexa 2007, eq. (9)'s right-hand side, as that file writes it):
//   b_i = (R_i c_i + sum_j R_j w_ij (p_i - p_j)) / 2.
// Not one vertex per lane: a lane per row of b_i. One vertex per lane (tried first) gathers R_j's nine values
// for every neighbour of every lane, and the gathers made the sums 1.4x slower than the scalar reference on
// the 6,890-vertex body (AMD EPYC Zen 5, `perf`). Here the term R_j a is three columns of R_j, each one
// 128-bit load (fr.R holds each R_j^T row-major: R_j's columns side by side), widened and scaled by a
// broadcast a_k: (R_.0 a_0 + R_.1 a_1) + R_.2 a_2, lane r holding row r, halved and added to b, in the scalar
// reference's order (R_i c_i first, then the neighbours in the CSR order). Products and sums are plain
// (-ffp-contract=off): b_i is bitwise the scalar reference's (the stage test checks it). The fourth lane reads
// the next column's first value (one value past the last R_j: fr.R's padding) and is never stored.
#pragma once

#include "kernels/contract.hpp"
#include "kernels/simd.hpp"

#include <cstddef>
#include <cstdint>
#include <type_traits>

namespace mlsdeform::kernels {

#if defined(__AVX2__)
/// The 256-bit body, in the AVX2 and the AVX-512 object (A: the object's arch, which keeps each object's copy its
/// own symbol; the vectors are raw __m256d, no xsimd template shared between the two), vertices [i0, i1).
template <class T, class A>
void ring_rhs_quad(const RingFrame<T>& fr, std::size_t i0, std::size_t i1) {
  const auto column = [](const T* p) {
    if constexpr (std::is_same_v<T, float>)
      return _mm256_cvtps_pd(_mm_loadu_ps(p));
    else
      return _mm256_loadu_pd(p);
  };
  const __m256d half = _mm256_set1_pd(0.5);
  for (std::size_t i = i0; i < i1; ++i) {
    __m256d b = _mm256_setzero_pd();
    const auto rotate_add = [&](const T* Rt, const double* a) {
      const __m256d t0 = _mm256_mul_pd(column(Rt), _mm256_broadcast_sd(a));
      const __m256d t1 = _mm256_mul_pd(column(Rt + 3), _mm256_broadcast_sd(a + 1));
      const __m256d t2 = _mm256_mul_pd(column(Rt + 6), _mm256_broadcast_sd(a + 2));
      b = _mm256_add_pd(b, _mm256_mul_pd(half, _mm256_add_pd(_mm256_add_pd(t0, t1), t2)));
    };
    rotate_add(fr.R + 9 * i, fr.c + 3 * i);
    for (std::ptrdiff_t e = fr.start[i]; e < fr.start[i + 1]; ++e)
      rotate_add(fr.R + 9 * std::size_t(fr.nbr[e]), fr.we + 3 * e);
    _mm_storeu_pd(fr.b + 3 * i, _mm256_castpd256_pd128(b));
    _mm_store_sd(fr.b + 3 * i + 2, _mm256_extractf128_pd(b, 1));
  }
}
#endif

/// The 128-bit body (SSE4.2, and WebAssembly through it): rows 0 and 1 in one vector, row 2 in scalars.
template <class T, class A>
void ring_rhs_pair(const RingFrame<T>& fr, std::size_t i0, std::size_t i1) {
  using V = xsimd::batch<double, A>;
  static_assert(V::size == 2, "rows 0 and 1");
  const V half(0.5);
  for (std::size_t i = i0; i < i1; ++i) {
    V b01(0.0);
    double b2 = 0;
    const auto rotate_add = [&](const T* Rt, const double* a) {
      const auto column = [&](std::size_t k) {
        alignas(16) const double v[2] = {double(Rt[3 * k]), double(Rt[3 * k + 1])};
        return V::load_aligned(v);
      };
      b01 = b01 + half * ((column(0) * V(a[0]) + column(1) * V(a[1])) + column(2) * V(a[2]));
      b2 = b2 + 0.5 * ((double(Rt[2]) * a[0] + double(Rt[5]) * a[1]) + double(Rt[8]) * a[2]);
    };
    rotate_add(fr.R + 9 * i, fr.c + 3 * i);
    for (std::ptrdiff_t e = fr.start[i]; e < fr.start[i + 1]; ++e)
      rotate_add(fr.R + 9 * std::size_t(fr.nbr[e]), fr.we + 3 * e);
    b01.store_unaligned(fr.b + 3 * i);
    fr.b[3 * i + 2] = b2;
  }
}

/// The stage: the kernel table's ring_rhs entry (kernels/kernel_table.hpp). Blocks [block_begin, block_end) of
/// kLanes vertices of fr: fr.b for those below fr.n.
template <class T, class A>
void ring_rhs(const RingFrame<T>& fr, std::size_t block_begin, std::size_t block_end) {
  const std::size_t i0 = block_begin * kLanes, i1 = block_end * kLanes < fr.n ? block_end * kLanes : fr.n;
#if defined(__AVX2__)  // the AVX2 and AVX-512 objects
  ring_rhs_quad<T, A>(fr, i0, i1);
#else
  ring_rhs_pair<T, A>(fr, i0, i1);
#endif
}

}  // namespace mlsdeform::kernels
