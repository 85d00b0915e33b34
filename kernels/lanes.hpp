// The lane vocabulary the stage bodies are written in: a stage is a template on its lane type V, which is
// either a SIMD vector (an xsimd batch or a Pair, kernels/simd.hpp: one vertex or matrix per lane) or the
// element type itself, one lane (the scalar reference), as Embree's intersectors take a width and xsimd
// has scalar overloads. This header holds what the width-1 instantiation needs and nothing of xsimd, so
// that core/ (baseline flags) can instantiate the same bodies without meeting an ISA's code.
#pragma once

#include <type_traits>
#include <utility>

/// Stage functions are inlined into the per-batch loop: called out of line, their batch arguments and results
/// travel through memory (measured: ~1.5x slower on AVX2).
#define MLSDEFORM_KERNEL_INLINE inline __attribute__((always_inline))

namespace mlsdeform::kernels {

template <class V, class = void>
struct LaneTraits {
  using scalar = typename V::value_type;
};
template <class T>
struct LaneTraits<T, std::enable_if_t<std::is_floating_point_v<T>>> {
  using scalar = T;
};

/// The element type and the mask type of a lane type V: T and bool for a scalar T, the batch's value type
/// and batch_bool for a vector.
template <class V>
using scalar_of = typename LaneTraits<V>::scalar;
template <class V>
using mask_of = decltype(std::declval<V>() < std::declval<V>());

// One lane: the operations a vector has that a scalar lacks. `static`, so that no baseline object and ISA
// object ever share a weak symbol (kernels/contract.hpp).

/// a where m, else b (xsimd::select on a batch).
template <class T, std::enable_if_t<std::is_floating_point_v<T>, int> = 0>
static MLSDEFORM_KERNEL_INLINE T select(bool m, T a, T b) {
  return m ? a : b;
}
/// Whether some lane, or every lane, of m is set.
static MLSDEFORM_KERNEL_INLINE bool any(bool m) { return m; }
static MLSDEFORM_KERNEL_INLINE bool all(bool m) { return m; }

/// x * y + z in the lanes of V: LaneArith<V>::mul_add. One lane: a product and a sum, rounded twice (core/'s
/// baseline flags have no FMA). A vector: kernels/simd.hpp specialises it as its mul_add, fused (rounded once) on
/// the ISAs with FMA, a product and a sum on SSE4.2. A class, not an overload, so that a stage body finds the
/// vector's version whatever the order in which a translation unit includes the two headers.
template <class V, class = void>
struct LaneArith {
  static MLSDEFORM_KERNEL_INLINE V mul_add(V x, V y, V z) { return x * y + z; }
};

}  // namespace mlsdeform::kernels
