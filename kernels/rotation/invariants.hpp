// Stage "invariants" of Algorithm 1 (eq. 6) in SIMD lanes, twin of detail::invariants in
// core/src/rotation/invariants.hpp: E = trace H, z = -V, ||H||^2, det H and c2 = sum_{i<j} |H_i x H_j|^2
// (columns H_i), the coefficients of the quartic (13). Sums of products are fused (mul_add: one rounding on
// FMA ISAs, a product and a sum on SSE4.2).
#pragma once

#include "kernels/simd.hpp"

namespace mlsdeform::kernels {

template <class V>
struct Invariants {
  V E;      // trace H
  V z[3];   // (H21 - H12, H02 - H20, H10 - H01) = -V of eq. (6), 0-based indices
  V norm2;  // ||H||_F^2
  V det;    // det H
  V c2;     // sum_{i<j} |H_i x H_j|^2 over columns
};

/// h[3 r + c] = H(r, c), normalised.
///   Lanes:       float, double (an xsimd batch, or a Pair of them)
///   Error:       a k-step sum of products, within gamma_k = k eps / (1 - k eps) of the exact value times the
///                same sum over absolute values: E gamma_2, z gamma_1, ||H||^2 gamma_9, det H gamma_5 (2x2
///                minors, then a 3-term dot product), c2 gamma_12 against sum m_i^2, m_i = |ab| + |cd| for
///                the minor ab - cd (tests/test_stages.cpp)
///   Valid range: finite H whose products of four entries stay normal: a normalised H (max |h_ij| in [1, 2),
///                as fit_rotation leaves it), or H = 0
template <class V>
MLSDEFORM_KERNEL_INLINE Invariants<V> invariants(const V (&h)[9]) {
  Invariants<V> inv;
  inv.E = h[0] + h[4] + h[8];
  inv.z[0] = h[7] - h[5];
  inv.z[1] = h[2] - h[6];
  inv.z[2] = h[3] - h[1];
  V n = h[0] * h[0];
  for (int i = 1; i < 9; ++i) n = mul_add(h[i], h[i], n);
  inv.norm2 = n;
  // Columns c0 = (h0, h3, h6), c1 = (h1, h4, h7), c2 = (h2, h5, h8); x01 = c0 x c1 and so on.
  const V x01a = mul_sub(h[3], h[7], h[6] * h[4]), x01b = mul_sub(h[6], h[1], h[0] * h[7]),
          x01c = mul_sub(h[0], h[4], h[3] * h[1]);
  const V x02a = mul_sub(h[3], h[8], h[6] * h[5]), x02b = mul_sub(h[6], h[2], h[0] * h[8]),
          x02c = mul_sub(h[0], h[5], h[3] * h[2]);
  const V x12a = mul_sub(h[4], h[8], h[7] * h[5]), x12b = mul_sub(h[7], h[2], h[1] * h[8]),
          x12c = mul_sub(h[1], h[5], h[4] * h[2]);
  inv.det = mul_add(x01a, h[2], mul_add(x01b, h[5], x01c * h[8]));
  const V x[9] = {x01a, x01b, x01c, x02a, x02b, x02c, x12a, x12b, x12c};
  V c2 = x[0] * x[0];
  for (int i = 1; i < 9; ++i) c2 = mul_add(x[i], x[i], c2);
  inv.c2 = c2;
  return inv;
}

}  // namespace mlsdeform::kernels
