// Stage "invariants" of Algorithm 1 (eq. 6), scalar reference: E = trace H, V, ||H||^2, det H and
// c2 = sum_{i<j} |H_i x H_j|^2 (columns H_i), the coefficients of the quartic (13). SIMD twin:
// kernels/rotation/invariants.hpp.
#pragma once

#include <mlsdeform/rotation.hpp>

#include <Eigen/Geometry>  // cross

namespace mlsdeform::detail {

template <class T>
struct Invariants {
  T E;           // trace H (paper's E)
  Vector3<T> z;  // (H21 - H12, H02 - H20, H10 - H01) = -V (paper's V, eq. 6), 0-based indices
  T norm2;       // ||H||_F^2
  T det;         // det H
  T c2;          // sum_{i<j} |H_i x H_j|^2: second invariant of H^T H (Lagrange identity)
};

/// Eq. (6) and the coefficients of (13), on a normalised H.
template <class T>
Invariants<T> invariants(const Matrix3<T>& H) {
  Invariants<T> inv;
  inv.E = H.trace();
  inv.z = Vector3<T>(H(2, 1) - H(1, 2), H(0, 2) - H(2, 0), H(1, 0) - H(0, 1));
  inv.norm2 = H.squaredNorm();
  const Vector3<T> c01 = H.col(0).cross(H.col(1));
  const Vector3<T> c02 = H.col(0).cross(H.col(2));
  const Vector3<T> c12 = H.col(1).cross(H.col(2));
  inv.det = c01.dot(H.col(2));
  inv.c2 = c01.squaredNorm() + c02.squaredNorm() + c12.squaredNorm();
  return inv;
}

}  // namespace mlsdeform::detail
