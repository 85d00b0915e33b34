// Stage "sin_cos" of Algorithm 1 (eqs. 15 and 5) in SIMD lanes, twin of detail::sin_cos in
// core/src/rotation/sin_cos.hpp: with q = (w, x) unnormalised and n = |q|^2, cos a = (w^2 - |x|^2)/n and
// sin a e = 2 w x / n, so R = ((w^2 - |x|^2) I + 2 x x^T + 2 w [x]_x) / n, sums of products fused (mul_add).
#pragma once

#include "kernels/rotation/rotation_axis.hpp"
#include "kernels/simd.hpp"

namespace mlsdeform::kernels {

/// r[3 i + j] = R(i, j) of the unnormalised quaternion q = (w, x). The scalar twin returns R; here it is
/// written into the caller's array (a C array cannot be returned; the fits' r is their output).
///   Lanes:       float, double (an xsimd batch, or a Pair of them)
///   Error:       |dR_ij| <= 3 gamma_10 (each entry a numerator of absolute value <= 2 |q|^2 in 8 steps over
///                |q|^2 in 4: tests/test_stages.cpp); |(R^T R - I)_ij| within c_o eps = 64 eps
///   Valid range: q finite with |q|^2 normal (the fits' q is); q = 0 gives NaN
template <class V>
MLSDEFORM_KERNEL_INLINE void sin_cos(const Vec4<V>& q, V (&r)[9]) {
  using T = scalar_of<V>;
  const V w = q.v[0], x0 = q.v[1], x1 = q.v[2], x2 = q.v[3];
  const V v2 = mul_add(x0, x0, mul_add(x1, x1, x2 * x2));
  const V inv_n = V(T(1)) / mul_add(w, w, v2);
  const V c = mul_sub(w, w, v2);
  const V two(T(2));
  const V tx0 = two * x0, tx1 = two * x1, tx2 = two * x2;
  r[0] = mul_add(tx0, x0, c) * inv_n;
  r[4] = mul_add(tx1, x1, c) * inv_n;
  r[8] = mul_add(tx2, x2, c) * inv_n;
  const V wx = tx0 * w, wy = tx1 * w, wz = tx2 * w;
  r[1] = mul_sub(tx0, x1, wz) * inv_n;
  r[3] = mul_add(tx0, x1, wz) * inv_n;
  r[2] = mul_add(tx0, x2, wy) * inv_n;
  r[6] = mul_sub(tx0, x2, wy) * inv_n;
  r[5] = mul_sub(tx1, x2, wx) * inv_n;
  r[7] = mul_add(tx1, x2, wx) * inv_n;
}

}  // namespace mlsdeform::kernels
