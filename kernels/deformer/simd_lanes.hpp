// The lane policy of the SIMD deformation kernels (DeformKernel<SimdLanes<T, A>>, deform_kernel.hpp): one
// vertex per lane of an xsimd batch of arch A. Its fit is the lanes' branch-free axis/angle fit
// (kernels/rotation/axis_angle.hpp) or the Horn-Jacobi baseline, and its on-the-fly weight exp2(u/2 log2 r2),
// where the scalar reference (core/src/deformer/reference.hpp) has fit_rotation and std::pow: the only
// places where the two instantiations of the one driver differ.
#pragma once

#include "kernels/rotation/axis_angle.hpp"
#include "kernels/rotation/horn_jacobi.hpp"
#include "kernels/simd.hpp"

namespace mlsdeform::kernels {

template <class Elem, class A>
struct SimdLanes {
  using T = Elem;
  using V = xsimd::batch<T, A>;
  static constexpr std::size_t W = V::size;
  /// Batches whose fits run side by side (fit_tile).
  static constexpr std::size_t kFitTile = kFitTileBatches<V>;

  MLSDEFORM_KERNEL_INLINE static V load(const T* p) { return V::load_aligned(p); }
  MLSDEFORM_KERNEL_INLINE static void store(const V& v, T* p) { v.store_unaligned(p); }

  /// w = (dref2 / d2)^(u/2); u = 2 (the default) needs no power.
  MLSDEFORM_KERNEL_INLINE static V relative_weight(V r2, T half_u) {
    if (half_u == T(1)) return r2;
    return exp2(V(half_u) * log2(r2));
  }

  /// R from the unnormalised H of nb <= B batches (h is normalised in place): the SIMD tables run axis_angle,
  /// its batches side by side (fit_rotation_tile: each lane bitwise as fit_rotation<AxisAngleFit> alone), and
  /// horn_quaternion (the session falls back to the scalar table for the other methods).
  template <std::size_t B>
  MLSDEFORM_KERNEL_INLINE static void fit_tile(RotationMethod method, V (&h)[B][9], V (&r)[B][9], std::size_t nb) {
    std::size_t careful = 0;  // not reported per frame
    if (method == RotationMethod::horn_quaternion)
      for (std::size_t b = 0; b < nb; ++b) fit_rotation<HornJacobiFit>(h[b], r[b], careful);
    else
      fit_rotation_tile<B>(h, r, nb, careful);
  }
};

}  // namespace mlsdeform::kernels
