// The careful path of stage "rotation_axis" (eq. 14), scalar reference: K's top eigenvector by cyclic Jacobi
// (Jacobi 1846; Golub & Van Loan Alg. 8.5.2). SIMD twin: kernels/rotation/jacobi.hpp (see there for the
// skip threshold and the stopping rule).
#pragma once

#include "core/src/rotation/rotation_axis.hpp"

#include "kernels/contract.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <limits>

namespace mlsdeform::detail {

/// The careful path's eigensolver: cyclic Jacobi on the symmetric 4x4 a, in the order, with the skip threshold
/// (|a_pq| <= eps ||a||_F) and the stopping rule of kernels/rotation/jacobi.hpp (see there); v receives the
/// eigenvectors (columns), a's diagonal the eigenvalues. frobenius: ||a||_F (invariant under the rotations).
template <class T>
void jacobi_eigen(Matrix4<T>& a, Matrix4<T>& v, T frobenius) {
  using std::abs;
  using std::sqrt;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  v.setIdentity();
  const T small = eps * frobenius;
  for (int sweep = 0; sweep < kernels::kMaxSweeps; ++sweep) {
    for (int p = 0; p < 3; ++p)
      for (int q = p + 1; q < 4; ++q) {
        const T apq = a(p, q);
        if (abs(apq) <= small) {
          a(p, q) = a(q, p) = T(0);
          continue;
        }
        const T theta = (a(q, q) - a(p, p)) / (T(2) * apq);
        const T t0 = T(1) / (abs(theta) + sqrt(theta * theta + T(1)));  // 0 where theta^2 overflows
        const T t = theta < T(0) ? -t0 : t0;
        const T c = T(1) / sqrt(t * t + T(1)), s = t * c;
        a(p, p) -= t * apq;
        a(q, q) += t * apq;
        a(p, q) = a(q, p) = T(0);
        for (int k = 0; k < 4; ++k) {
          if (k == p || k == q) continue;
          const T akp = a(k, p), akq = a(k, q);
          a(k, p) = a(p, k) = c * akp - s * akq;
          a(k, q) = a(q, k) = s * akp + c * akq;
        }
        for (int k = 0; k < 4; ++k) {
          const T vkp = v(k, p), vkq = v(k, q);
          v(k, p) = c * vkp - s * vkq;
          v(k, q) = s * vkp + c * vkq;
        }
      }
    if (sweep < 2) continue;
    T off = T(0);
    for (int p = 0; p < 3; ++p)
      for (int q = p + 1; q < 4; ++q) off = std::max(off, abs(a(p, q)));
    if (!(off > small)) break;
  }
}

/// Eq. (14) on the careful path: the (unnormalised) top eigenvector of K, or where the top eigenvalue is
/// multiple to rounding (within 8 eps max|K_ij|: rank-1 H, a point reflection H = -s R, H = s diag(1, -1, -1)
/// ...) the vector of its eigenspace closest to e0 = (1, 0, 0, 0), the identity rotation: q = sum_{j in top}
/// v_j v_j(m) with m = 0, or where e0 is nearly orthogonal to the eigenspace (its projection below a quarter
/// of the largest) the axis e_m with the largest projection; so that neighbouring vertices of a deformation
/// make the same choice. With a single top eigenvalue the same formula gives v_1 v_1(m), a non-zero multiple
/// of v_1. Jacobi is backward stable whatever the spectrum (multiple, clustered or nearly double
/// eigenvalues), which is what the careful path's lanes have. frobenius: ||K||_F (K.norm() here; the twin
/// takes it as 2 ||H||_F, see there).
template <class T>
Vector4<T> top_eigenvector(const Matrix4<T>& K, T frobenius) {
  using Vec4 = Vector4<T>;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  Matrix4<T> a = K, v;
  jacobi_eigen(a, v, frobenius);
  const Vec4 d = a.diagonal();
  const T floor = d.maxCoeff() - T(8) * eps * K.cwiseAbs().maxCoeff();
  Vec4 proj = Vec4::Zero();
  for (int j = 0; j < 4; ++j)
    if (d(j) >= floor) proj += v.col(j).cwiseAbs2();
  int m;
  const T pm = proj.maxCoeff(&m);
  if (proj(0) >= T(0.25) * pm) m = 0;
  Vec4 q = Vec4::Zero();
  for (int j = 0; j < 4; ++j)
    if (d(j) >= floor) q += v.col(j) * v(m, j);
  return q;
}

}  // namespace mlsdeform::detail
