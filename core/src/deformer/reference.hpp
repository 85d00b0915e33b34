// The MLS deformer's per-frame evaluation, scalar reference: the scalar table's entry (DeformBlocksFn) is the
// one driver of kernels/deformer/deform_kernel.hpp at width 1, one vertex at a time, over the same DeformFrame
// (kernels/contract.hpp) and session data (data.hpp) as the SIMD kernels, with the stages of
// kernels/deformer/stages.hpp:
//   weighted_centroid   q* = sum_j omega_j q_j                                     (eq. 2)
//   correlation_matrix  H  = sum_j (q_j - c) A_j^T                                 (eq. 6; Sec. 6.2)
//   fit_rotation        R  = argmax trace(R^T H)                                   (eqs. 13-15, or a baseline)
//   similarity_scale    mu = trace(R^T H) / D (similarity, Sec. 6.1), else 1
//   apply               v' = q* + mu R vhat                                        (steps 8-10)
// Affine: v' = sum_j alpha_j q_j. This file holds what the scalar lane policy has of its own: the fit is the
// public fit_rotation (every RotationMethod), the on-the-fly weight std::pow.
//
// Accumulation runs over j in increasing order in T, so a vertex's result depends only on its own data and
// the targets: bitwise the same for any thread count or block schedule.
#pragma once

#include "kernels/deformer/deform_kernel.hpp"

#include <mlsdeform/rotation.hpp>

#include <cmath>
#include <cstddef>

namespace mlsdeform::detail {

/// One vertex: the width-1 lane policy of kernels::DeformKernel.
template <class Elem>
struct ScalarLanes {
  using T = Elem;
  using V = T;
  static constexpr std::size_t W = 1;
  /// One vertex's fit at a time: nothing to interleave.
  static constexpr std::size_t kFitTile = 1;

  static T load(const T* p) { return *p; }
  static void store(T v, T* p) { *p = v; }

  /// w = (dref2 / d2)^(u/2); u = 2 (the default) needs no power.
  static T relative_weight(T r2, T half_u) { return half_u == T(1) ? r2 : T(std::pow(r2, half_u)); }

  /// R = fit_rotation(H, method), H row-major in h.
  static void fit(RotationMethod method, const T (&h)[9], T (&r)[9]) {
    Matrix3<T> H;
    for (int i = 0; i < 9; ++i) H(i / 3, i % 3) = h[i];
    const Matrix3<T> Rm = fit_rotation<T>(H, method);
    for (int i = 0; i < 9; ++i) r[i] = Rm(i / 3, i % 3);
  }
  template <std::size_t B>
  static void fit_tile(RotationMethod method, T (&h)[B][9], T (&r)[B][9], std::size_t nb) {
    for (std::size_t b = 0; b < nb; ++b) fit(method, h[b], r[b]);
  }
};

/// The scalar kernel-table entry (DeformBlocksFn): blocks [block_begin, block_end).
template <class T>
void deform_blocks_reference(const kernels::DeformFrame<T>& fr, std::size_t block_begin, std::size_t block_end) {
  kernels::DeformKernel<ScalarLanes<T>>::run(fr, block_begin, block_end);
}

}  // namespace mlsdeform::detail
