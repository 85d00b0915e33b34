// Common definitions for the structure-of-arrays kernels: one matrix (or vertex) per SIMD lane. Every
// function here is a template instantiated on types that name the xsimd arch (a batch<T, A>, a Pair of
// them, Simd<T, A>, or a kernel's lambda over them), so an ISA object's instantiations are its own symbols,
// never ones another ISA object or the baseline code defines too (tests/scripts/check_weak_symbols.cmake
// checks the built library). The lane vocabulary shared with the width-1 scalar instantiation (scalar_of,
// mask_of, select) is lanes.hpp.
#pragma once

#include "kernels/lanes.hpp"

#include <xsimd/xsimd.hpp>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>

#if defined(__aarch64__)
// xsimd (8.1 and 13.2 alike) divides and takes square roots of float batches on aarch64 with the 32-bit ARM
// recipe: a reciprocal (square root) estimate refined by two Newton steps, a few ulps off the correctly rounded
// result, where SSE, AVX and the scalar reference round once (IEEE 754). AArch64 has the correctly rounded
// instructions (FDIV, FSQRT on vectors): these explicit specialisations of xsimd's neon kernels for neon64 make
// `/` and sqrt use them, so that the NEON twins agree with the scalar reference bit for bit where x86's do
// (tests/test_stages.cpp). Double already uses vdivq_f64 / vsqrtq_f64. Kernel objects only (this header).
namespace xsimd::kernel {
template <>
inline batch<float, neon64> div<neon64>(batch<float, neon64> const& lhs, batch<float, neon64> const& rhs,
                                        requires_arch<neon>) noexcept {
  return vdivq_f32(lhs, rhs);
}
template <>
inline batch<float, neon64> sqrt<neon64>(batch<float, neon64> const& x, requires_arch<neon>) noexcept {
  return vsqrtq_f32(x);
}
}  // namespace xsimd::kernel
#endif

namespace mlsdeform::kernels {

/// Tag for Simd<T, Twin<A>>: two batches of arch A side by side, processed together by every operation,
/// so that the core has a second, independent dependency chain to issue while the first waits on a
/// division or square root. Worth it where few vectors are live at once: the batched Horn-Jacobi baseline
/// (1.3-1.5x faster); not for the axis/angle fit, which twinned ran slower (see isa_instance.inc).
template <class A>
struct Twin {};

/// Two batches of arch A as one vector of twice the width (lo = lanes [0, n), hi = [n, 2n)).
template <class B>
struct Pair {
  B lo, hi;
  using value_type = typename B::value_type;
  static constexpr std::size_t size = 2 * B::size;
  Pair() = default;
  Pair(value_type x) : lo(x), hi(x) {}  // broadcast, as batch(x)
  Pair(B l, B h) : lo(l), hi(h) {}
  static Pair load_aligned(const value_type* p) { return {B::load_aligned(p), B::load_aligned(p + B::size)}; }
  static Pair load_unaligned(const value_type* p) { return {B::load_unaligned(p), B::load_unaligned(p + B::size)}; }
  void store_aligned(value_type* p) const { lo.store_aligned(p), hi.store_aligned(p + B::size); }
  void store_unaligned(value_type* p) const { lo.store_unaligned(p), hi.store_unaligned(p + B::size); }
};

template <class B>
struct PairMask {
  B lo, hi;
  PairMask() = default;
  explicit PairMask(bool x) : lo(x), hi(x) {}
  PairMask(B l, B h) : lo(l), hi(h) {}
};

#define MLSDEFORM_PAIR_BINARY(R, OP, X)                                    \
  template <class B>                                                       \
  MLSDEFORM_KERNEL_INLINE auto operator OP(const X<B>& a, const X<B>& b) { \
    return R{a.lo OP b.lo, a.hi OP b.hi};                                  \
  }
#define MLSDEFORM_PAIR_COMPARE(OP)                                               \
  template <class B>                                                             \
  MLSDEFORM_KERNEL_INLINE auto operator OP(const Pair<B>& a, const Pair<B>& b) { \
    using BM = decltype(a.lo OP b.lo);                                           \
    return PairMask<BM>{a.lo OP b.lo, a.hi OP b.hi};                             \
  }
MLSDEFORM_PAIR_BINARY(Pair<B>, +, Pair)
MLSDEFORM_PAIR_BINARY(Pair<B>, -, Pair)
MLSDEFORM_PAIR_BINARY(Pair<B>, *, Pair)
MLSDEFORM_PAIR_BINARY(Pair<B>, /, Pair)
MLSDEFORM_PAIR_COMPARE(<)
MLSDEFORM_PAIR_COMPARE(<=)
MLSDEFORM_PAIR_COMPARE(>)
MLSDEFORM_PAIR_COMPARE(>=)
MLSDEFORM_PAIR_COMPARE(==)
MLSDEFORM_PAIR_BINARY(PairMask<B>, &, PairMask)
MLSDEFORM_PAIR_BINARY(PairMask<B>, |, PairMask)
MLSDEFORM_PAIR_BINARY(PairMask<B>, ^, PairMask)
#undef MLSDEFORM_PAIR_BINARY
#undef MLSDEFORM_PAIR_COMPARE
template <class B>
MLSDEFORM_KERNEL_INLINE Pair<B> operator-(const Pair<B>& a) {
  return {-a.lo, -a.hi};
}
template <class B>
MLSDEFORM_KERNEL_INLINE PairMask<B> operator~(const PairMask<B>& a) {
  return {~a.lo, ~a.hi};
}
template <class B>
MLSDEFORM_KERNEL_INLINE PairMask<B> operator!(const PairMask<B>& a) {
  return {!a.lo, !a.hi};
}

// The element-wise functions the kernels call (unqualified, so that a batch finds xsimd's by argument-
// dependent lookup and a Pair these).
template <class B>
MLSDEFORM_KERNEL_INLINE Pair<B> abs(const Pair<B>& a) {
  return {xsimd::abs(a.lo), xsimd::abs(a.hi)};
}
template <class B>
MLSDEFORM_KERNEL_INLINE Pair<B> sqrt(const Pair<B>& a) {
  return {xsimd::sqrt(a.lo), xsimd::sqrt(a.hi)};
}
template <class B>
MLSDEFORM_KERNEL_INLINE Pair<B> acos(const Pair<B>& a) {
  return {xsimd::acos(a.lo), xsimd::acos(a.hi)};
}
template <class B>
MLSDEFORM_KERNEL_INLINE Pair<B> exp2(const Pair<B>& a) {
  return {xsimd::exp2(a.lo), xsimd::exp2(a.hi)};
}
template <class B>
MLSDEFORM_KERNEL_INLINE Pair<B> log2(const Pair<B>& a) {
  return {xsimd::log2(a.lo), xsimd::log2(a.hi)};
}
template <class B>
MLSDEFORM_KERNEL_INLINE Pair<B> max(const Pair<B>& a, const Pair<B>& b) {
  return {xsimd::max(a.lo, b.lo), xsimd::max(a.hi, b.hi)};
}
template <class B>
MLSDEFORM_KERNEL_INLINE Pair<B> min(const Pair<B>& a, const Pair<B>& b) {
  return {xsimd::min(a.lo, b.lo), xsimd::min(a.hi, b.hi)};
}
/// x * y + z and x * y - z, fused (one rounding) on the ISAs with FMA; on SSE4.2, a product and a sum.
/// xsimd 10 fuses for fma3<...> archs only; its avx512f fma is the unfused generic one, hence the
/// intrinsics below. Named mul_add, not fma, so that unqualified calls never meet xsimd::fma by ADL.
template <class T, class A>
MLSDEFORM_KERNEL_INLINE xsimd::batch<T, A> mul_add(const xsimd::batch<T, A>& x, const xsimd::batch<T, A>& y,
                                                   const xsimd::batch<T, A>& z) {
  return xsimd::fma(x, y, z);
}
template <class T, class A>
MLSDEFORM_KERNEL_INLINE xsimd::batch<T, A> mul_sub(const xsimd::batch<T, A>& x, const xsimd::batch<T, A>& y,
                                                   const xsimd::batch<T, A>& z) {
  return xsimd::fms(x, y, z);
}
#ifdef __AVX512F__
template <class T>
MLSDEFORM_KERNEL_INLINE xsimd::batch<T, xsimd::avx512f> mul_add(const xsimd::batch<T, xsimd::avx512f>& x,
                                                                const xsimd::batch<T, xsimd::avx512f>& y,
                                                                const xsimd::batch<T, xsimd::avx512f>& z) {
  if constexpr (sizeof(T) == 4)
    return _mm512_fmadd_ps(x, y, z);
  else
    return _mm512_fmadd_pd(x, y, z);
}
template <class T>
MLSDEFORM_KERNEL_INLINE xsimd::batch<T, xsimd::avx512f> mul_sub(const xsimd::batch<T, xsimd::avx512f>& x,
                                                                const xsimd::batch<T, xsimd::avx512f>& y,
                                                                const xsimd::batch<T, xsimd::avx512f>& z) {
  if constexpr (sizeof(T) == 4)
    return _mm512_fmsub_ps(x, y, z);
  else
    return _mm512_fmsub_pd(x, y, z);
}
#endif
template <class B>
MLSDEFORM_KERNEL_INLINE Pair<B> mul_add(const Pair<B>& x, const Pair<B>& y, const Pair<B>& z) {
  return {mul_add(x.lo, y.lo, z.lo), mul_add(x.hi, y.hi, z.hi)};
}
template <class B>
MLSDEFORM_KERNEL_INLINE Pair<B> mul_sub(const Pair<B>& x, const Pair<B>& y, const Pair<B>& z) {
  return {mul_sub(x.lo, y.lo, z.lo), mul_sub(x.hi, y.hi, z.hi)};
}
/// The stage bodies' x * y + z (kernels/lanes.hpp) on a vector: mul_add.
template <class T, class A>
struct LaneArith<xsimd::batch<T, A>> {
  using V = xsimd::batch<T, A>;
  static MLSDEFORM_KERNEL_INLINE V mul_add(const V& x, const V& y, const V& z) { return kernels::mul_add(x, y, z); }
};
template <class B>
struct LaneArith<Pair<B>> {
  static MLSDEFORM_KERNEL_INLINE Pair<B> mul_add(const Pair<B>& x, const Pair<B>& y, const Pair<B>& z) {
    return kernels::mul_add(x, y, z);
  }
};
template <class BM, class B>
MLSDEFORM_KERNEL_INLINE Pair<B> select(const PairMask<BM>& m, const Pair<B>& a, const Pair<B>& b) {
  return {xsimd::select(m.lo, a.lo, b.lo), xsimd::select(m.hi, a.hi, b.hi)};
}
template <class BM>
MLSDEFORM_KERNEL_INLINE bool any(const PairMask<BM>& m) {
  return xsimd::any(m.lo | m.hi);
}
template <class BM>
MLSDEFORM_KERNEL_INLINE bool none(const PairMask<BM>& m) {
  return xsimd::none(m.lo | m.hi);
}

/// What every vector type shares: constants and the batch walk over a 3 x 3 x n layout.
template <class T, std::size_t Width>
struct SimdCommon {
  static constexpr std::size_t W = Width;
  static constexpr T eps = std::numeric_limits<T>::epsilon();
  /// sqrt(eps) as a literal (2^-11.5, 2^-26): no std::sqrt may be emitted in an ISA object.
  static constexpr T sqrt_eps = sizeof(T) == 4 ? T(3.45266983e-4f) : T(1.4901161193847656e-8);

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

template <class T, class A>
struct Simd : SimdCommon<T, xsimd::batch<T, A>::size> {
  using V = xsimd::batch<T, A>;
  using M = xsimd::batch_bool<T, A>;

  MLSDEFORM_KERNEL_INLINE static M all_true() { return V(T(0)) == V(T(0)); }

  /// 2^-e with e = the exponent of m (m > 0 finite), so that m * 2^-e is in [1, 2): the exact power-of-two
  /// normalisation of the scalar code (std::ilogb / std::ldexp), done on the exponent bits. The exponent is
  /// clamped so that 2^-e stays a normal number (|m| >= 2^(emax-1) then lands in [2, 4): still safe).
  MLSDEFORM_KERNEL_INLINE static V pow2_inverse_exponent(V m) {
    using I = xsimd::as_integer_t<T>;
    using VI = xsimd::batch<I, A>;
    constexpr int mant = std::numeric_limits<T>::digits - 1;                // 23 or 52
    constexpr I bias2 = I((std::numeric_limits<T>::max_exponent - 1) * 2);  // 254 or 2046
    const VI exp_mask = VI(I(((I(1) << (sizeof(T) * 8 - 1 - mant)) - 1)) << mant);
    VI e = bits_as<I>(m) & exp_mask;
    e = xsimd::min(e, VI(I(bias2 - 1) << mant));  // keep the result normal
    e = xsimd::max(e, VI(I(1) << mant));          // subnormal m: scale by 2^(emax-1)
    return bits_as<T>(VI(bias2 << mant) - e);
  }

  /// The bits of x read as a batch of To (a reinterpret_cast per lane). xsimd 11 changed bitwise_cast's
  /// template argument from the batch type (xsimd 8, Debian 12) to the element type (xsimd 13, Debian 13).
  template <class To, class From>
  MLSDEFORM_KERNEL_INLINE static xsimd::batch<To, A> bits_as(xsimd::batch<From, A> x) {
#if XSIMD_VERSION_MAJOR >= 11
    return xsimd::bitwise_cast<To>(x);
#else
    return xsimd::bitwise_cast<xsimd::batch<To, A>>(x);
#endif
  }
};

/// Two interleaved batches of arch A (see Twin): the same interface, twice the width.
template <class T, class A>
struct Simd<T, Twin<A>> : SimdCommon<T, 2 * xsimd::batch<T, A>::size> {
  using V = Pair<xsimd::batch<T, A>>;
  using M = PairMask<xsimd::batch_bool<T, A>>;

  MLSDEFORM_KERNEL_INLINE static M all_true() { return M(true); }
  MLSDEFORM_KERNEL_INLINE static V pow2_inverse_exponent(V m) {
    return {Simd<T, A>::pow2_inverse_exponent(m.lo), Simd<T, A>::pow2_inverse_exponent(m.hi)};
  }
};

/// 2^-e per lane (see Simd::pow2_inverse_exponent), for either vector type.
template <class T, class A>
MLSDEFORM_KERNEL_INLINE xsimd::batch<T, A> pow2_inverse_exponent(const xsimd::batch<T, A>& m) {
  return Simd<T, A>::pow2_inverse_exponent(m);
}
template <class B>
MLSDEFORM_KERNEL_INLINE Pair<B> pow2_inverse_exponent(const Pair<B>& m) {
  return {pow2_inverse_exponent(m.lo), pow2_inverse_exponent(m.hi)};
}

/// base[index[l]] in lane l: the ISA's gather instruction. xsimd 8.1's batch::gather names its kernel with an
/// explicit element type, which rules out the AVX2 and AVX-512 overloads, and falls back to one load and insert
/// per lane in a call that GCC 12 does not inline (7% of an ARAP iteration on the 6,890-vertex body, `perf`). The
/// values are the same loads: bitwise xsimd's.
/// NEON has no gather instruction: xsimd's lane loads there.
template <class A>
MLSDEFORM_KERNEL_INLINE xsimd::batch<double, A> gather(const double* base, const xsimd::batch<std::int64_t, A>& index) {
#if defined(__SSE2__)  // x86 (and WebAssembly through emscripten's SSE headers)
  if constexpr (std::is_same_v<A, xsimd::avx512f>)
    return _mm512_i64gather_pd(index, base, 8);
  else if constexpr (std::is_base_of_v<xsimd::avx2, A>)  // avx2, fma3<avx2>
    return _mm256_i64gather_pd(base, index, 8);
  else
#endif
    return xsimd::batch<double, A>::gather(base, index);
}

/// Whether store_streaming writes past the caches on arch A: AVX2 and AVX-512 (vmovntps / vmovntpd). Elsewhere
/// (SSE4.2, WebAssembly through it, and NEON) it is a plain aligned store.
/// NEON's non-temporal pair stores (STNP) are a hint that the core may ignore, and xsimd does not offer them:
/// plain stores there too.
template <class A>
inline constexpr bool kStreamingStores =
#if defined(__SSE2__)
    std::is_same_v<A, xsimd::avx512f> || std::is_base_of_v<xsimd::avx2, A>;
#else
    false;
#endif

/// v to p (aligned to the vector's width) by a non-temporal store where kStreamingStores<A>: the line goes to
/// memory through a write-combining buffer, without first being read into the cache (a plain store's read for
/// ownership: a third of a streamed fit's memory traffic). Weakly ordered: the writer issues store_fence() before
/// the values are read by another thread. The same bits as store_aligned.
template <class T, class A>
MLSDEFORM_KERNEL_INLINE void store_streaming(T* p, const xsimd::batch<T, A>& v) {
#if defined(__SSE2__)
  if constexpr (std::is_same_v<A, xsimd::avx512f> && std::is_same_v<T, float>)
    _mm512_stream_ps(p, v);
  else if constexpr (std::is_same_v<A, xsimd::avx512f>)
    _mm512_stream_pd(p, v);
  else if constexpr (std::is_base_of_v<xsimd::avx2, A> && std::is_same_v<T, float>)
    _mm256_stream_ps(p, v);
  else if constexpr (std::is_base_of_v<xsimd::avx2, A>)
    _mm256_stream_pd(p, v);
  else
#endif
    v.store_aligned(p);
}

/// Orders the non-temporal stores before it ahead of every store after it (sfence), where arch A has them.
template <class A>
MLSDEFORM_KERNEL_INLINE void store_fence() {
#if defined(__SSE2__)
  if constexpr (kStreamingStores<A>) _mm_sfence();
#endif
}

}  // namespace mlsdeform::kernels
