// The symmetric 4x4 eigensolver of the lanes: cyclic Jacobi rotations (Jacobi 1846; Golub & Van Loan
// Alg. 8.5.2) in branch-free form, twin of detail::jacobi_eigen and
// detail::top_eigenvector in core/src/rotation/jacobi.hpp. Used by the
// careful path of the axis/angle fit (eq. 14 for the lanes its fast path cannot settle) and by the Horn 1987
// baseline (horn_jacobi.hpp).
//
// Each rotation t = sign(theta) / (|theta| + sqrt(theta^2 + 1)), theta = (a_qq - a_pp) / (2 a_pq), is skipped
// by select where |a_pq| <= eps ||K||_F (setting it to zero is then a backward error of eps ||K||, as in
// Rutishauser's threshold); sweeps over the six pivot pairs go on until every lane's off-diagonal entries are
// below that threshold (checked from the third sweep on; at most kMaxSweeps). Without the threshold, an
// off-diagonal entry of 1e-229 between equal diagonal entries (a wide_exponents matrix) drew a 45-degree
// rotation that mixed two decoupled blocks, and convergence fell to a factor 2 per sweep. Jacobi is backward
// stable and converges quadratically; it handles every input alike, multiple eigenvalues included.
#pragma once

#include "kernels/contract.hpp"
#include "kernels/rotation/rotation_axis.hpp"
#include "kernels/simd.hpp"

namespace mlsdeform::kernels {

/// One rotation annihilating a[p][q] (skipped where |a[p][q]| <= small: it is set to zero).
template <class V>
MLSDEFORM_KERNEL_INLINE void jacobi_rotate(V (&a)[4][4], V (&v)[4][4], int p, int q, V small) {
  using T = scalar_of<V>;
  using M = mask_of<V>;
  const V apq = a[p][q];
  const M skip = abs(apq) <= small;
  const V theta = (a[q][q] - a[p][p]) / (V(T(2)) * select(skip, V(T(1)), apq));
  const V t0 = V(T(1)) / (abs(theta) + sqrt(theta * theta + V(T(1))));
  // theta^2 may overflow to inf for a tiny a_pq: then t0 = 0, the rotation is the identity (as it should be).
  const V t = select(skip, V(T(0)), select(theta < V(T(0)), -t0, t0));
  const V c = V(T(1)) / sqrt(t * t + V(T(1))), s = t * c;
  a[p][p] = a[p][p] - t * apq;
  a[q][q] = a[q][q] + t * apq;
  a[p][q] = a[q][p] = V(T(0));
  for (int k = 0; k < 4; ++k) {
    if (k == p || k == q) continue;
    const V akp = a[k][p], akq = a[k][q];
    a[k][p] = a[p][k] = c * akp - s * akq;
    a[k][q] = a[q][k] = s * akp + c * akq;
  }
  for (int k = 0; k < 4; ++k) {
    const V vkp = v[k][p], vkq = v[k][q];
    v[k][p] = c * vkp - s * vkq;
    v[k][q] = s * vkp + c * vkq;
  }
}

/// Diagonalises the symmetric a (full storage) in place; v (columns) receives the eigenvectors.
/// frobenius: ||a||_F (invariant under the rotations).
///   Lanes:       float, double (an xsimd batch, or a Pair of them)
///   Error:       backward stable: the eigenpairs of a + E, ||E||_F a small multiple of eps ||a||_F (each
///                skipped rotation drops an entry <= eps ||a||_F; each applied one rounds at eps level), whatever
///                the spectrum; every lane's off-diagonal below eps ||a||_F, or kMaxSweeps sweeps
///   Valid range: finite symmetric a with ||a||_F normal (a = 0 returns v = I)
template <class V>
MLSDEFORM_KERNEL_INLINE void jacobi_eigen(V (&a)[4][4], V (&v)[4][4], V frobenius) {
  using T = scalar_of<V>;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) v[i][j] = V(i == j ? T(1) : T(0));
  const V small = V(eps) * frobenius;
  for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
    for (int p = 0; p < 3; ++p)
      for (int q = p + 1; q < 4; ++q) jacobi_rotate(a, v, p, q, small);
    if (sweep < 2) continue;
    V off = abs(a[0][1]);
    for (int p = 0; p < 3; ++p)
      for (int q = p + 1; q < 4; ++q) off = max(off, abs(a[p][q]));
    if (none(off > small)) break;
  }
}

/// The (unnormalised) top eigenvector of the symmetric K (full storage k[4 i + j]), or where the top
/// eigenvalue is multiple to rounding (within 8 eps max|K_ij|) the vector of its eigenspace closest to
/// e0 = (1, 0, 0, 0), the identity rotation: q = sum_{j in top} v_j v_j(m) with m = 0, or, where e0 is
/// nearly orthogonal to the eigenspace (its projection below a quarter of the largest), the axis e_m with
/// the largest projection; so that neighbouring vertices of a deformation make the same choice. With a
/// single top eigenvalue the same formula gives v_1 v_1(m), a non-zero multiple of v_1. Mirrors the scalar
/// detail::top_eigenvector, with the same arguments: frobenius = ||K||_F, which the callers here take as
/// 2 ||H||_F (an identity of Davenport's K: 2 operations from the invariants instead of 16 products) and
/// the scalar ones as K.norm(); each side keeps its own rounding of it, and so its results to the bit.
///   Lanes:       float, double (an xsimd batch, or a Pair of them)
///   Error:       where the optimum is unique, the rotation of q within the accuracy suite's angle bound,
///                2 sqrt(3) c_b eps kappa + (3/2) c_o eps (tests/test_stages.cpp holds it on every lane); where
///                it is not, a vector of the top eigenspace, which attains the optimum trace to the backward
///                error c_b eps ||H||_F (test_rotation_rank1). q is unnormalised
///   Valid range: K of a finite normalised H
template <class V>
MLSDEFORM_KERNEL_INLINE Vec4<V> top_eigenvector(const Mat4<V>& K, V frobenius) {
  using T = scalar_of<V>;
  using M = mask_of<V>;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  V a[4][4], v[4][4];
  V amax = abs(K.k[0]);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      a[i][j] = K.k[4 * i + j];
      amax = max(amax, abs(a[i][j]));
    }
  jacobi_eigen(a, v, frobenius);
  const V top = max(max(a[0][0], a[1][1]), max(a[2][2], a[3][3]));
  const V floor = top - V(T(8) * eps) * amax;
  M in[4];
  V proj[4] = {V(T(0)), V(T(0)), V(T(0)), V(T(0))};
  for (int j = 0; j < 4; ++j) {
    in[j] = a[j][j] >= floor;
    for (int i = 0; i < 4; ++i) proj[i] = proj[i] + select(in[j], v[i][j] * v[i][j], V(T(0)));
  }
  // m: 0 unless proj(0) < proj(m) / 4 for the largest proj(m) (first index on ties).
  const V pm = max(max(proj[0], proj[1]), max(proj[2], proj[3]));
  const M m0 = proj[0] >= V(T(0.25)) * pm, m1 = ~m0 & (proj[1] == pm), m2 = ~(m0 | m1) & (proj[2] == pm);
  Vec4<V> q;
  for (int i = 0; i < 4; ++i) q.v[i] = V(T(0));
  for (int j = 0; j < 4; ++j) {
    const V vm = select(m0, v[0][j], select(m1, v[1][j], select(m2, v[2][j], v[3][j])));
    const V w = select(in[j], vm, V(T(0)));
    for (int i = 0; i < 4; ++i) q.v[i] = mul_add(v[i][j], w, q.v[i]);
  }
  return q;
}

}  // namespace mlsdeform::kernels
