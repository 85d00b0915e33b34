// Common definitions for the structure-of-arrays kernels: one matrix (or vertex) per SIMD lane.
// Everything is a static member of a class template on the xsimd arch A, so each ISA translation unit gets
// its own symbols (no weak symbol is shared between ISA objects; tests/test_dispatch.cpp checks).
#pragma once

#include <xsimd/xsimd.hpp>

#include <cstddef>
#include <cstdint>
#include <limits>

/// Stage functions are inlined into the per-batch loop: called out of line, their batch arguments and results
/// travel through memory (measured: ~1.5x slower on AVX2).
#define MLSDEFORM_KERNEL_INLINE inline __attribute__((always_inline))

namespace mlsdeform::kernels {

template <class T, class A>
struct Simd {
  using V = xsimd::batch<T, A>;
  using M = xsimd::batch_bool<T, A>;
  static constexpr std::size_t W = V::size;
  static constexpr T eps = std::numeric_limits<T>::epsilon();
  /// sqrt(eps) as a literal (2^-11.5, 2^-26): no std::sqrt may be emitted in an ISA object.
  static constexpr T sqrt_eps = sizeof(T) == 4 ? T(3.45266983e-4f) : T(1.4901161193847656e-8);

  MLSDEFORM_KERNEL_INLINE static V splat(T x) { return V(x); }
  MLSDEFORM_KERNEL_INLINE static M all_true() { return V(T(0)) == V(T(0)); }

  /// 2^-e with e = the exponent of m (m > 0 finite), so that m * 2^-e is in [1, 2): the exact power-of-two
  /// normalisation of the scalar code (std::ilogb / std::ldexp), done on the exponent bits. The exponent is
  /// clamped so that 2^-e stays a normal number (|m| >= 2^(emax-1) then lands in [2, 4): still safe).
  MLSDEFORM_KERNEL_INLINE static V pow2_inverse_exponent(V m) {
    using I = xsimd::as_integer_t<T>;
    using VI = xsimd::batch<I, A>;
    constexpr int mant = std::numeric_limits<T>::digits - 1;  // 23 or 52
    constexpr I bias2 = I((std::numeric_limits<T>::max_exponent - 1) * 2);  // 254 or 2046
    const VI exp_mask = VI(I(((I(1) << (sizeof(T) * 8 - 1 - mant)) - 1)) << mant);
    VI e = xsimd::bitwise_cast<VI>(m) & exp_mask;
    e = xsimd::min(e, VI(I(bias2 - 1) << mant));  // keep the result normal
    e = xsimd::max(e, VI(I(1) << mant));          // subnormal m: scale by 2^(emax-1)
    return xsimd::bitwise_cast<V>(VI(bias2 << mant) - e);
  }

  /// Calls f(src, dst, stride, offset) for each batch of W matrices of [begin, end) in a 3 x 3 x n layout;
  /// a partial last batch goes through a zero-padded copy (padding lanes hold H = 0).
  template <class F>
  static void for_each_batch(const T* H, T* R, std::size_t stride, std::size_t begin, std::size_t end, F&& f) {
    std::size_t i = begin;
    for (; i + W <= end; i += W) f(H, R, stride, i);
    if (i == end) return;
    alignas(64) T hb[9 * W] = {}, rb[9 * W];
    const std::size_t rem = end - i;
    for (std::size_t e = 0; e < 9; ++e)
      for (std::size_t j = 0; j < rem; ++j) hb[e * W + j] = H[e * stride + i + j];
    f(static_cast<const T*>(hb), static_cast<T*>(rb), W, std::size_t(0));
    for (std::size_t e = 0; e < 9; ++e)
      for (std::size_t j = 0; j < rem; ++j) R[e * stride + i + j] = rb[e * W + j];
  }
};

}  // namespace mlsdeform::kernels
