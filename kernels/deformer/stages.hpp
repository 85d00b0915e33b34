// The deformer's per-vertex stages, read beside the paper: one body each, a template on the lane type V
// (kernels/lanes.hpp), which the scalar reference instantiates with V = T (one vertex) and the SIMD kernels
// with a batch (one vertex per lane). Plain products and sums, no fusion (the kernels are compiled with
// -ffp-contract=off, core/ with baseline flags that have no FMA), so each stage's result is bitwise the same
// at every width; the stage test (tests/test_stages.cpp) checks it on every ISA.
//   weighted_centroid   q* = sum_j omega_j q_j                         (eq. 2), one term per call
//   correlation_matrix  H  = sum_j (q_j - c) A_j^T                     (eq. 6, Sec. 6.2), one term per call
//   similarity_scale    mu = trace(R^T H) / D                          (Sec. 6.1)
//   apply               v' = q* + mu R vhat                            (Algorithm 1 steps 8-10)
#pragma once

#include "kernels/lanes.hpp"

namespace mlsdeform::kernels {

/// Eq. (2), the term of one pseudo-handle: qs += omega q_j (q_j the same in every lane).
///   Lanes:       float, double (one vertex, or an xsimd batch)
///   Error:       over J calls from 0, a 2J-step sum of products: within gamma_2J = 2J eps / (1 - 2J eps) of
///                the exact q* times sum_j |omega_j q_j| (tests/test_stages.cpp); bitwise the same at every width
///   Valid range: finite omega, q whose sums do not overflow
template <class V>
MLSDEFORM_KERNEL_INLINE void weighted_centroid(V (&qs)[3], V omega, const V (&q)[3]) {
  for (int r = 0; r < 3; ++r) qs[r] = qs[r] + omega * q[r];
}

/// Eq. (6), the term of one pseudo-handle: h += d a^T with d = q_j - c, a = A_j; h[3 r + c] = H(r, c).
///   Lanes:       float, double (one vertex, or an xsimd batch)
///   Error:       over J calls from 0, each entry within gamma_2J of the exact sum times sum_j |d_j| |a_j|
///                (tests/test_stages.cpp); bitwise the same at every width
///   Valid range: finite d, a whose sums do not overflow
template <class V>
MLSDEFORM_KERNEL_INLINE void correlation_matrix(V (&h)[9], const V (&d)[3], const V (&a)[3]) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) h[3 * r + c] = h[3 * r + c] + d[r] * a[c];
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

}  // namespace mlsdeform::kernels
