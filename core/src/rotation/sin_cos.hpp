// Stage "sin_cos" of Algorithm 1 (eqs. 15 and 5), scalar reference: cos a = (q0^2 - |q_vec|^2) / |q|^2 and
// sin a = 2 q0 |q_vec| / |q|^2, the homogeneous forms of (1 - |u|^2)/(1 + |u|^2) and 2|u|/(1 + |u|^2); with
// e = q_vec / |q_vec|, (5) becomes R = ((q0^2 - |q_vec|^2) I + 2 q_vec q_vec^T + 2 q0 [q_vec]_x) / |q|^2.
// SIMD twin: kernels/rotation/sin_cos.hpp.
#pragma once

#include <mlsdeform/rotation.hpp>

namespace mlsdeform::detail {

/// Eqs. (15) and (5) in homogeneous form: the rotation matrix of the unnormalised quaternion q = (w, x),
/// R = ((w^2 - |x|^2) I + 2 x x^T + 2 w [x]_x) / |q|^2, written entry by entry as kernels/rotation/sin_cos.hpp does.
template <class T>
Matrix3<T> sin_cos(const Eigen::Matrix<T, 4, 1>& q) {
  const T w = q(0), x0 = q(1), x1 = q(2), x2 = q(3);
  const T inv_n = T(1) / (w * w + x0 * x0 + x1 * x1 + x2 * x2);
  const T c = w * w - (x0 * x0 + x1 * x1 + x2 * x2);
  const T xy = T(2) * x0 * x1, xz = T(2) * x0 * x2, yz = T(2) * x1 * x2;
  const T wx = T(2) * w * x0, wy = T(2) * w * x1, wz = T(2) * w * x2;
  Matrix3<T> R;
  R << (c + T(2) * x0 * x0) * inv_n, (xy - wz) * inv_n, (xz + wy) * inv_n,  //
      (xy + wz) * inv_n, (c + T(2) * x1 * x1) * inv_n, (yz - wx) * inv_n,   //
      (xz - wy) * inv_n, (yz + wx) * inv_n, (c + T(2) * x2 * x2) * inv_n;
  return R;
}

}  // namespace mlsdeform::detail
