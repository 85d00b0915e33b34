// The paper's rotation axis step taken literally, for the error-versus-half-turn plot only (it is not a
// library method and is not timed): the largest root y of (13) (the library's maximum_root),
// then (14), (N - lambda I) u = V with lambda = y + E, solved by Cramer's rule, and (15)/(5) from the Gibbs
// vector u = e tan(alpha / 2). As alpha -> pi, N - lambda I becomes singular and |u| -> inf, which is why the
// library solves (14) in a frame turned by pi about the best axis (Shuster's sequential rotations) instead.
#pragma once

#include "core/src/rotation/axis_angle.hpp"  // invariants, maximum_root (the library's scalar reference)

#include <mlsdeform/rotation.hpp>

namespace bench {

template <class T>
mlsdeform::Matrix3<T> fit_rotation_paper_literal(const mlsdeform::Matrix3<T>& H_in) {
  namespace d = mlsdeform::detail;
  const T m = H_in.cwiseAbs().maxCoeff();
  if (m == T(0)) return mlsdeform::Matrix3<T>::Identity();
  const mlsdeform::Matrix3<T> H = H_in * std::ldexp(T(1), -std::ilogb(m));
  const d::Invariants<T> inv = d::invariants(H);
  bool converged;  // (the plot's point sets are far from multiple roots)
  const T y = d::maximum_root(inv, converged);
  const T lambda = y + inv.E;
  mlsdeform::Matrix3<T> A = H + H.transpose();  // N
  A.diagonal().array() -= lambda;
  const mlsdeform::Vector3<T> V = -inv.z;  // the paper's V (eq. 6)
  // (14) by Cramer's rule: u = adj(A) V / det A.
  const mlsdeform::Vector3<T> u = A.inverse() * V;
  // (15) and (5): cos = (1 - |u|^2) / (1 + |u|^2), sin from 2 |u| / (1 + |u|^2), axis u / |u|; in
  // quaternion form, q = (1, u) / sqrt(1 + |u|^2).
  const T n = T(1) + u.squaredNorm();
  const T w = T(1);
  mlsdeform::Matrix3<T> R = (w * w - u.squaredNorm()) * mlsdeform::Matrix3<T>::Identity() + T(2) * u * u.transpose();
  mlsdeform::Matrix3<T> cross;
  cross << T(0), -u(2), u(1), u(2), T(0), -u(0), -u(1), u(0), T(0);
  R += T(2) * w * cross;
  return R / n;
}

}  // namespace bench
