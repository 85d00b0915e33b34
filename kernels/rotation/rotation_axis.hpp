// Stage "rotation_axis" of Algorithm 1 (eq. 14, generalised) in SIMD lanes, twin of detail::davenport and
// detail::rotation_axis in core/src/rotation/rotation_axis.hpp: Davenport's K and the fast path, the
// strongest column of the adjugate of K - y I (eq. 14 by Cramer's rule in the best of Shuster's frames) and
// one power step. The careful path is jacobi.hpp.
#pragma once

#include "kernels/rotation/invariants.hpp"
#include "kernels/simd.hpp"

namespace mlsdeform::kernels {

/// The symmetric 4x4 Davenport matrix K, full storage k[4 i + j].
template <class V>
struct Mat4 {
  V k[16];
};
template <class V>
struct Vec4 {
  V v[4];
};

/// Davenport's symmetric K = [[E, z^T], [z, H + H^T - E I]] of the normalised H (h[3 r + c] = H(r, c)) and
/// its invariants, so that trace(R(q)^T H) = q^T K q / |q|^2.
///   Lanes:       float, double (an xsimd batch, or a Pair of them)
///   Error:       one rounding in each entry of H + H^T - E I (2 h_ii is exact): |dK_ij| <= eps |K_ij|, with
///                E and z as invariants leaves them
///   Valid range: every finite H
template <class V>
MLSDEFORM_KERNEL_INLINE Mat4<V> davenport(const V (&h)[9], const Invariants<V>& inv) {
  using T = scalar_of<V>;
  const V E = inv.E, z0 = inv.z[0], z1 = inv.z[1], z2 = inv.z[2];
  Mat4<V> K;
  const V n01 = h[1] + h[3], n02 = h[2] + h[6], n12 = h[5] + h[7];
  const V d[4] = {E, V(T(2)) * h[0] - E, V(T(2)) * h[4] - E, V(T(2)) * h[8] - E};
  const V off[4][4] = {{d[0], z0, z1, z2}, {z0, d[1], n01, n02}, {z1, n01, d[2], n12}, {z2, n02, n12, d[3]}};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) K.k[4 * i + j] = off[i][j];
  return K;
}

/// The fast path of eq. (14): the column of adj(K - y I) with the largest diagonal entry, then one step of
/// the power method on that adjugate (see the scalar twin for the error analysis). adj is symmetric: its 10
/// distinct entries come from 11 of the 12 complementary 2x2 minors of the row pairs (0, 1) and (2, 3) (the
/// upper triangle needs no c0), sums of products fused. `dk` returns the largest |diagonal entry| (the
/// careful path's trigger).
///   Lanes:       float, double (an xsimd batch, or a Pair of them)
///   Error:       where the fit takes this path (y converged, dk^2 > kCarefulTau^2 ||H||^6), the rotation of q
///                within the accuracy suite's angle bound of the optimum, 2 sqrt(3) c_b eps kappa + (3/2) c_o eps
///                (c_b = 16, c_o = 64: tests/support/accuracy_bounds.hpp; kappa <= eps^(-1/3) there); q is
///                unnormalised. Elsewhere q means nothing: the careful path replaces it
///   Valid range: K of a finite normalised H, y from maximum_root
template <class V>
MLSDEFORM_KERNEL_INLINE Vec4<V> rotation_axis(const Mat4<V>& K, V y, V& dk) {
  using M = mask_of<V>;
  const V S00 = K.k[0] - y, S11 = K.k[5] - y, S22 = K.k[10] - y, S33 = K.k[15] - y;
  const V S01 = K.k[1], S02 = K.k[2], S03 = K.k[3], S12 = K.k[6], S13 = K.k[7], S23 = K.k[11];
  const V s0 = mul_sub(S00, S11, S01 * S01), s1 = mul_sub(S00, S12, S01 * S02), s2 = mul_sub(S00, S13, S01 * S03);
  const V s3 = mul_sub(S01, S12, S11 * S02), s4 = mul_sub(S01, S13, S11 * S03), s5 = mul_sub(S02, S13, S12 * S03);
  const V c5 = mul_sub(S22, S33, S23 * S23), c4 = mul_sub(S12, S33, S13 * S23), c3 = mul_sub(S12, S23, S13 * S22);
  const V c2 = mul_sub(S02, S33, S03 * S23), c1 = mul_sub(S02, S23, S03 * S22);
  const V a00 = mul_add(S11, c5, mul_sub(S13, c3, S12 * c4));
  const V a01 = mul_add(S02, c4, -mul_add(S01, c5, S03 * c3));
  const V a02 = mul_add(S13, s5, mul_sub(S33, s3, S23 * s4));
  const V a03 = mul_add(S22, s4, -mul_add(S12, s5, S23 * s3));
  const V a11 = mul_add(S00, c5, mul_sub(S03, c1, S02 * c2));
  const V a12 = mul_add(S23, s2, -mul_add(S03, s5, S33 * s1));
  const V a13 = mul_add(S02, s5, mul_sub(S23, s1, S22 * s2));
  const V a22 = mul_add(S03, s4, mul_sub(S33, s0, S13 * s2));
  const V a23 = mul_add(S12, s2, -mul_add(S02, s4, S23 * s0));
  const V a33 = mul_add(S02, s3, mul_sub(S22, s0, S12 * s1));
  const V adj[4][4] = {{a00, a01, a02, a03}, {a01, a11, a12, a13}, {a02, a12, a22, a23}, {a03, a13, a23, a33}};
  // Column k = argmax |a_kk| (first index on ties), by selects.
  const V d0 = abs(a00), d1 = abs(a11), d2 = abs(a22), d3 = abs(a33);
  dk = max(max(d0, d1), max(d2, d3));
  const M k0 = d0 == dk, k1 = ~k0 & (d1 == dk), k2 = ~(k0 | k1) & (d2 == dk);
  Vec4<V> col;
  for (int i = 0; i < 4; ++i) col.v[i] = select(k0, adj[i][0], select(k1, adj[i][1], select(k2, adj[i][2], adj[i][3])));
  Vec4<V> q;
  for (int i = 0; i < 4; ++i)
    q.v[i] =
        mul_add(adj[i][0], col.v[0], mul_add(adj[i][1], col.v[1], mul_add(adj[i][2], col.v[2], adj[i][3] * col.v[3])));
  return q;
}

}  // namespace mlsdeform::kernels
