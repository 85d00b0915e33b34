// The paper's closed-form rotation fit (Sec. 4.3-4.6, Algorithm 1 steps 3-7), scalar reference.
//
// Written to be read beside the paper; kernels/rotation/axis_angle.hpp computes the same stages in the same
// order in SIMD lanes, one file per stage on each side (docs/design.md has the map), each twin taking the same
// arguments in the same shapes (H, its Invariants, K, y, q, R). Column-vector convention (see rotation.hpp):
// H = sum w q p^T is the paper's M.
//
// Unlike the deformer's stages (one body for both, kernels/deformer/stages.hpp), these have two bodies: the
// lanes fuse their sums of products (mul_add: one rounding on the FMA instruction sets, which baseline x86-64,
// and so this reference, lacks), cannot branch per lane (Newton's loop runs under a mask, the careful path is
// a select over all lanes, the strongest column is chosen by selects) and take no Eigen types. The stage test
// holds each pair against long-double values instead of against each other.
//
// Stages, with the paper's routine names (Table 1):
//   normalise          H <- 2^-e H so that max |H_ij| is in [1, 2) (fit_rotation.cpp): exact, so the result
//                      is bitwise invariant under power-of-two scaling and no product (det^2, ||H||^4) can
//                      overflow.
//   invariants (6)     invariants.hpp
//   maximum_root (13)  maximum_root.hpp: Newton's method from an upper bound of the largest root.
//   rotation_axis (14) rotation_axis.hpp: the strongest column of adj(K - y I) and one power step (fast
//                      path); jacobi.hpp: K's top eigenvector (careful path).
//   sin_cos (15), (5)  sin_cos.hpp: R from the unnormalised quaternion.
//
// Two paths. The fast path settles almost every H (all but ~1e-3 of random point-set matrices, none of 10^6
// Gaussian H): maximum_root, rotation_axis, sin_cos. The careful path takes the rest (a multiple or nearly
// multiple root of (13), e.g. rank-1 H from collinear handles; a gap s2 + d s3 below cbrt(eps) s1; three
// clustered eigenvalues of K): top_eigenvector (Jacobi), sin_cos.
#pragma once

#include "core/src/rotation/jacobi.hpp"
#include "core/src/rotation/maximum_root.hpp"
#include "core/src/rotation/rotation_axis.hpp"
#include "core/src/rotation/sin_cos.hpp"

#include "kernels/contract.hpp"

namespace mlsdeform::detail {

/// The whole fit (Algorithm 1, steps 3-7) on a finite, normalised H (max |H_ij| in [1, 2), or H = 0): the
/// fast path, or for H it cannot settle (a (nearly) multiple root of the quartic, a gap below cbrt(eps) ||H||,
/// a cluster of three eigenvalues of K) the careful one, top_eigenvector.
template <class T>
Matrix3<T> fit_rotation_axis_angle(const Matrix3<T>& H) {
  const Invariants<T> inv = invariants(H);
  bool converged;
  const T y = maximum_root(inv, converged);
  const Matrix4<T> K = davenport(H, inv);
  T dk;
  const Vector4<T> q = rotation_axis(K, y, dk);
  const T n3 = inv.norm2 * inv.norm2 * inv.norm2;
  if (converged && dk * dk > kernels::kCarefulTau<T> * kernels::kCarefulTau<T> * n3) return sin_cos(q);
  return sin_cos(top_eigenvector(K, K.norm()));
}

}  // namespace mlsdeform::detail
