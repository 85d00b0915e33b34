// The deformer's per-vertex stages, read beside the paper: one body each, a template on the lane type V
// (kernels/lanes.hpp), which the scalar reference instantiates with V = T (one vertex) and the SIMD kernels
// with a batch (one vertex per lane). Plain products and sums (the kernels are compiled with -ffp-contract=off,
// core/ with baseline flags that have no FMA), so each stage's result is bitwise the same at every width, except
// the two sums over the pseudo-handles, whose terms are fused where the ISA has FMA (LaneArith's mul_add: AVX2,
// AVX-512; one rounding per term instead of two, within the same bound): there they are the deformer's inner
// loop, and a fused term is one vector operation where a product and a sum are two (Table 2's Cylinder,
// 322 handles, precomputed_weights: 63.5 -> 48 us per frame on one core, AVX-512). The stage test
// (tests/test_stages.cpp) checks each stage on every ISA: bitwise, or against long double where fused.
//   weighted_centroid   q* = sum_j omega_j q_j                         (eq. 2), one term per call
//   correlation_matrix  H  = sum_j (q_j - c) A_j^T                     (eq. 6, Sec. 6.2), one term per call
//   similarity_scale    mu = trace(R^T H) / D                          (Sec. 6.1)
//   apply               v' = q* + mu R vhat                            (Algorithm 1 steps 8-10)
//   rotation_quaternion R -> unit q (w x y z), w >= 0                   (Shepperd 1978, Markley 2008)
#pragma once

#include "kernels/lanes.hpp"

#include <cmath>

namespace mlsdeform::kernels {

/// Eq. (2), the term of one pseudo-handle: qs += omega q_j (q_j the same in every lane).
///   Lanes:       float, double (one vertex, or an xsimd batch)
///   Error:       over J calls from 0, a 2J-step sum of products: within gamma_2J = 2J eps / (1 - 2J eps) of
///                the exact q* times sum_j |omega_j q_j| (tests/test_stages.cpp); fused on the FMA ISAs (J
///                roundings), else bitwise the scalar reference's
///   Valid range: finite omega, q whose sums do not overflow
template <class V>
MLSDEFORM_KERNEL_INLINE void weighted_centroid(V (&qs)[3], V omega, const V (&q)[3]) {
  for (int r = 0; r < 3; ++r) qs[r] = LaneArith<V>::mul_add(omega, q[r], qs[r]);
}

/// Eq. (6), the term of one pseudo-handle: h += d a^T with d = q_j - c, a = A_j; h[3 r + c] = H(r, c).
///   Lanes:       float, double (one vertex, or an xsimd batch)
///   Error:       over J calls from 0, each entry within gamma_2J of the exact sum times sum_j |d_j| |a_j|
///                (tests/test_stages.cpp); fused on the FMA ISAs, else bitwise the scalar reference's
///   Valid range: finite d, a whose sums do not overflow
template <class V>
MLSDEFORM_KERNEL_INLINE void correlation_matrix(V (&h)[9], const V (&d)[3], const V (&a)[3]) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) h[3 * r + c] = LaneArith<V>::mul_add(d[r], a[c], h[3 * r + c]);
}

/// Sec. 6.1: mu_s = trace(R^T H) / D where D > 0 (D = sum_i w_i |phat_i|^2 in the session's units; 0 only
/// where vhat = 0), `otherwise` elsewhere.
///   Lanes:       float, double (one vertex, or an xsimd batch)
///   Error:       a 9-term dot product and a division: within gamma_10 of the exact trace(R^T H) / D times
///                sum |r_i h_i| / D; bitwise the same at every width
///   Valid range: finite r, h; D > 0, else (D <= 0 or NaN) `otherwise`
template <class V>
MLSDEFORM_KERNEL_INLINE V similarity_scale(const V (&r)[9], const V (&h)[9], V D, V otherwise) {
  using T = scalar_of<V>;
  V tr = r[0] * h[0];
  for (int i = 1; i < 9; ++i) tr = tr + r[i] * h[i];
  return select(D > V(T(0)), tr / D, otherwise);
}

/// Algorithm 1 steps 8-10: out = q* + mu R vhat.
///   Lanes:       float, double (one vertex, or an xsimd batch)
///   Error:       each coordinate within gamma_5 of the exact value times |q*_i| + |mu| sum_k |R_ik vhat_k|;
///                bitwise the same at every width
///   Valid range: finite inputs
template <class V>
MLSDEFORM_KERNEL_INLINE void apply(const V (&qs)[3], V mu, const V (&r)[9], const V (&vh)[3], V (&out)[3]) {
  for (int i = 0; i < 3; ++i) {
    const V rv = r[3 * i] * vh[0] + r[3 * i + 1] * vh[1] + r[3 * i + 2] * vh[2];
    out[i] = qs[i] + mu * rv;
  }
}

/// The frames' output (FramesOut, mlsdeform/frames.hpp): the unit quaternion q = (w, x, y, z), w >= 0, of a
/// rotation matrix r (row-major), branch-free. Shepperd's method as Markley writes it: the four columns of
/// 4 q q^T that 3 x 3 entries give,
///   (1 + tr, r21 - r12, r02 - r20, r10 - r01)    (r21 - r12, 1 + r00 - r11 - r22, r10 + r01, r02 + r20)
///   (r02 - r20, r10 + r01, 1 - r00 + r11 - r22, r21 + r12)    (r10 - r01, r02 + r20, r21 + r12, 1 - r00 - r11 + r22),
/// each 4 q_k q; the one with the largest diagonal (4 q_k^2 >= 1 for a rotation: the largest of four squares
/// summing to 1 is at least 1/4) is normalised, so no component is found from a small difference, and for an
/// R that is orthonormal to a few eps the result is within a few eps of the exact quaternion of the nearest
/// rotation. Selects pick the column in every lane; a tie takes the first.
///   Lanes:       float, double (one vertex, or an xsimd batch)
///   Error:       |q - q_exact| <= ~10 eps + |R^T R - I| (the column's 3-term sums, one square root and a
///                division: tests/test_stages.cpp derives the check); bitwise the same at every width
///                (correctly rounded sqrt and division, no fusion)
///   Valid range: finite r, orthonormal to well within 1/4 (a fit's result)
template <class V>
MLSDEFORM_KERNEL_INLINE void rotation_quaternion(const V (&r)[9], V (&q)[4]) {
  using std::sqrt;
  using T = scalar_of<V>;
  const V one(T(1));
  const V d0 = one + r[0] + r[4] + r[8], d1 = one + r[0] - r[4] - r[8], d2 = one - r[0] + r[4] - r[8],
          d3 = one - r[0] - r[4] + r[8];
  const V s21 = r[7] - r[5], s02 = r[2] - r[6], s10 = r[3] - r[1];  // 4 w (x, y, z)
  const V a10 = r[3] + r[1], a02 = r[2] + r[6], a21 = r[7] + r[5];  // 4 x y, 4 x z, 4 y z
  // The column of the largest diagonal: k = 0 unless another is larger.
  const auto p1 = d1 > d0, p2 = d2 > select(p1, d1, d0), p3 = d3 > select(p2, d2, select(p1, d1, d0));
  V c[4] = {d0, s21, s02, s10};
  const V c1[4] = {s21, d1, a10, a02}, c2[4] = {s02, a10, d2, a21}, c3[4] = {s10, a02, a21, d3};
  for (int i = 0; i < 4; ++i) c[i] = select(p3, c3[i], select(p2, c2[i], select(p1, c1[i], c[i])));
  const V norm = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2] + c[3] * c[3]);
  // q and -q are one rotation: the one with w >= 0.
  const V inv = select(c[0] < V(T(0)), -one, one) / norm;
  for (int i = 0; i < 4; ++i) q[i] = c[i] * inv;
}

}  // namespace mlsdeform::kernels
