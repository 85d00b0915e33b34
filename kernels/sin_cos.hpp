// Stage "sin_cos" of Algorithm 1 (eqs. 15 and 5) in SIMD lanes, mirroring rotation_from_quaternion in
// core/src/axis_angle.hpp: with q = (w, x) unnormalised and n = |q|^2, cos a = (w^2 - |x|^2)/n and
// sin a e = 2 w x / n, so R = ((w^2 - |x|^2) I + 2 x x^T + 2 w [x]_x) / n. And stage "apply": d = R vhat.
#pragma once

#include "simd.hpp"

namespace mlsdeform::kernels {

template <class T, class A>
struct SinCos : Simd<T, A> {
  using typename Simd<T, A>::V;

  /// r[3 i + j] = R(i, j).
  MLSDEFORM_KERNEL_INLINE static void rotation_from_quaternion(V w, V x0, V x1, V x2, V (&r)[9]) {
    const V inv_n = V(T(1)) / (w * w + x0 * x0 + x1 * x1 + x2 * x2);
    const V c = w * w - (x0 * x0 + x1 * x1 + x2 * x2);
    const V two(T(2));
    r[0] = (c + two * x0 * x0) * inv_n;
    r[4] = (c + two * x1 * x1) * inv_n;
    r[8] = (c + two * x2 * x2) * inv_n;
    const V xy = two * x0 * x1, xz = two * x0 * x2, yz = two * x1 * x2;
    const V wx = two * w * x0, wy = two * w * x1, wz = two * w * x2;
    r[1] = (xy - wz) * inv_n;
    r[3] = (xy + wz) * inv_n;
    r[2] = (xz + wy) * inv_n;
    r[6] = (xz - wy) * inv_n;
    r[5] = (yz - wx) * inv_n;
    r[7] = (yz + wx) * inv_n;
  }
};

}  // namespace mlsdeform::kernels
