// The ARAP local step's one-ring sums in SIMD lanes, one vertex per lane: the twin of
// core/src/arap/ring_correlation.hpp (Sorkine & Alexa 2007, eq. (5)'s covariance, as that file writes it):
//   S_i = sum_j w_ij (x_i - x_j)(p_i - p_j)^T, and with the energy sum_j w_ij |x_i - x_j|^2,
// then S_i scaled by the power of two that puts max |S_i| in [1, 2), and rounded to T.
//
// The one-rings come padded (kernels/contract.hpp, RingFrame): block b of kLanes vertices has as many slots
// as its largest valence; slot s gives each lane its s-th neighbour's row and w_ij (p_i - p_j), or, past the
// lane's valence, its own row and weight 0. A lane's sums run over its slots in order: its neighbours in the
// CSR order, as the scalar reference visits them, then padding terms that are exactly +0 (d = x_i - x_i = 0
// and a = 0), which leave every sum unchanged (a sum that starts at +0 is never -0: x + (+0) = x). Products
// and sums are plain (the kernels are built with -ffp-contract=off), in the scalar reference's order, so
// every lane's S_i, energy term and H are bitwise the scalar reference's (the stage test checks it).
//
// Valid range: finite x (the session's units: of order one) and max |S_i| < 2^1023, where the power of
// two 2^-ilogb(max |S_i|) is a normal number (pow2_inverse_exponent, simd.hpp).
#pragma once

#include "kernels/contract.hpp"
#include "kernels/simd.hpp"

#include <cstddef>
#include <cstdint>

namespace mlsdeform::kernels {

/// Blocks [block_begin, block_end) of fr (kernels/contract.hpp, RingFrame): H, and with fr.ring the unscaled
/// S_i and the energy sum, for the vertices of those blocks below fr.n.
template <class T, class A, bool Energy>
void ring_correlation_blocks(const RingFrame<T>& fr, std::size_t block_begin, std::size_t block_end) {
  using V = xsimd::batch<double, A>;
  using VI = xsimd::batch<std::int64_t, A>;
  constexpr std::size_t W = V::size;
  static_assert(kLanes % W == 0, "a block is a whole number of batches");
  const V zero(0.0), big(0x1p1000), tiny_below(0x1p-1000);
  for (std::size_t b = block_begin; b < block_end; ++b) {
    // The block's results, lane-major per entry, stored below for the lanes that are vertices.
    alignas(64) double h[9][kLanes], raw[10][kLanes];
    const std::size_t slot0 = fr.slot_begin[b], slot1 = fr.slot_begin[b + 1];
    for (std::size_t l0 = 0; l0 < kLanes; l0 += W) {
      const VI self = VI::load_unaligned(fr.self + b * kLanes + l0);
      const V xi0 = gather(fr.x, self), xi1 = gather(fr.x + 1, self), xi2 = gather(fr.x + 2, self);
      V s0 = zero, s1 = zero, s2 = zero, s3 = zero, s4 = zero, s5 = zero, s6 = zero, s7 = zero, s8 = zero;
      V dd = zero;
      for (std::size_t s = slot0; s < slot1; ++s) {
        const VI j = VI::load_unaligned(fr.slot_x + s * kLanes + l0);
        const double* a = fr.slot_a + 3 * s * kLanes + l0;
        const V a0 = V::load_unaligned(a), a1 = V::load_unaligned(a + kLanes), a2 = V::load_unaligned(a + 2 * kLanes);
        const V d0 = xi0 - gather(fr.x, j), d1 = xi1 - gather(fr.x + 1, j), d2 = xi2 - gather(fr.x + 2, j);
        s0 = s0 + d0 * a0, s1 = s1 + d0 * a1, s2 = s2 + d0 * a2;
        s3 = s3 + d1 * a0, s4 = s4 + d1 * a1, s5 = s5 + d1 * a2;
        s6 = s6 + d2 * a0, s7 = s7 + d2 * a1, s8 = s8 + d2 * a2;
        if constexpr (Energy) dd = dd + V::load_unaligned(fr.slot_w + s * kLanes + l0) * (d0 * d0 + d1 * d1 + d2 * d2);
      }
      V S[9] = {s0, s1, s2, s3, s4, s5, s6, s7, s8};
      if constexpr (Energy) {
        for (std::size_t k = 0; k < 9; ++k) S[k].store_aligned(raw[k] + l0);
        dd.store_aligned(raw[9] + l0);
      }
      V m = abs(S[0]);
      for (std::size_t k = 1; k < 9; ++k) m = max(m, abs(S[k]));
      // if (m > 0) { if (ilogb(m) < -1000) { S *= 2^1000; m *= 2^1000; } S *= 2^-ilogb(m); }: where m = 0 every
      // entry is +0, which both products keep.
      const auto tiny = m < tiny_below;
      for (V& x : S) x = select(tiny, x * big, x);
      m = select(tiny, m * big, m);
      const V to_unit = pow2_inverse_exponent(m);
      const auto nonzero = m > zero;
      for (std::size_t k = 0; k < 9; ++k) select(nonzero, S[k] * to_unit, S[k]).store_aligned(h[k] + l0);
    }
    // Rounded to T one value at a time, as the scalar reference rounds (the same conversion, to nearest).
    const std::size_t i0 = b * kLanes, lanes = fr.n - i0 < kLanes ? fr.n - i0 : kLanes;
    for (std::size_t k = 0; k < 9; ++k)
      for (std::size_t l = 0; l < lanes; ++l) fr.H[k * fr.n + i0 + l] = T(h[k][l]);
    if constexpr (Energy)
      for (std::size_t l = 0; l < lanes; ++l)
        for (std::size_t k = 0; k < 10; ++k) fr.ring[10 * (i0 + l) + k] = raw[k][l];
  }
}

/// The stage: the kernel table's ring_correlation entry (kernels/kernel_table.hpp).
template <class T, class A>
void ring_correlation(const RingFrame<T>& fr, std::size_t block_begin, std::size_t block_end) {
  if (fr.ring)
    ring_correlation_blocks<T, A, true>(fr, block_begin, block_end);
  else
    ring_correlation_blocks<T, A, false>(fr, block_begin, block_end);
}

}  // namespace mlsdeform::kernels
