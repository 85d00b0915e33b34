// Baseline in the same lanes: Horn 1987 (the unit quaternion is the eigenvector of the largest eigenvalue
// of the symmetric 4x4 matrix K), with the eigenproblem solved by cyclic Jacobi rotations (jacobi.hpp,
// swept to convergence). Jacobi is the dense method of choice for small symmetric eigenproblems in lanes (no
// data-dependent branching; McAdams et al. 2011 use it for their 3x3 SIMD SVD).
#pragma once

#include "kernels/rotation/axis_angle.hpp"
#include "kernels/rotation/jacobi.hpp"

namespace mlsdeform::kernels {

/// On a normalised H (as fit_rotation_axis_angle; fit_rotation<HornJacobiFit> normalises and gives H = 0 the
/// identity): R of K's eigenvector with the largest eigenvalue.
///   Lanes:       float, double (an xsimd batch, or a Pair of them)
///   Error:       the accuracy suite's bounds with c_b = 16, as axis_angle (tests/test_batch_accuracy.cpp)
///   Valid range: every finite normalised H
template <class V>
MLSDEFORM_KERNEL_INLINE void fit_rotation_horn_jacobi(const V (&h)[9], V (&r)[9]) {
  using T = scalar_of<V>;
  using M = mask_of<V>;
  const Invariants<V> inv = invariants(h);
  const Mat4<V> K = davenport(h, inv);
  V a[4][4], v[4][4];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) a[i][j] = K.k[4 * i + j];
  // ||K||_F^2 = 4 ||H||_F^2 (K's blocks: |E|^2 + 2|z|^2 + ||H + H^T - E I||^2).
  jacobi_eigen(a, v, sqrt(V(T(4)) * inv.norm2));
  // The eigenvector of the largest diagonal entry (first index on ties).
  V best = a[0][0];
  V w = v[0][0], x0 = v[1][0], x1 = v[2][0], x2 = v[3][0];
  for (int j = 1; j < 4; ++j) {
    const M better = a[j][j] > best;
    best = select(better, a[j][j], best);
    w = select(better, v[0][j], w);
    x0 = select(better, v[1][j], x0);
    x1 = select(better, v[2][j], x1);
    x2 = select(better, v[3][j], x2);
  }
  sin_cos(Vec4<V>{{w, x0, x1, x2}}, r);
}

struct HornJacobiFit {
  template <class V>
  MLSDEFORM_KERNEL_INLINE static void fit(const V (&h)[9], V (&r)[9], std::size_t&) {
    fit_rotation_horn_jacobi(h, r);
  }
};

}  // namespace mlsdeform::kernels
