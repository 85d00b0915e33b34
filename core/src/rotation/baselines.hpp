// The four baseline rotation solvers, scalar, on Eigen's dense solvers. Each takes a finite, normalised H
// (max |H_ij| in [1, 2) or H = 0) and returns the proper rotation maximising trace(R^T H).
#pragma once

#include "core/src/rotation/invariants.hpp"
#include "core/src/rotation/rotation_axis.hpp"
#include "core/src/rotation/sin_cos.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

namespace mlsdeform::detail {

/// Horn 1987: the unit quaternion is the eigenvector of the largest eigenvalue of the symmetric 4x4
/// matrix (Davenport's K; Horn's N matrix in his eq. for the column convention used here).
template <class T>
Matrix3<T> fit_rotation_horn_quaternion(const Matrix3<T>& H) {
  const Invariants<T> inv = invariants(H);
  const Eigen::Matrix<T, 4, 4> K = davenport(H, inv);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<T, 4, 4>> eig(K);
  return sin_cos<T>(eig.eigenvectors().col(3));  // eigenvalues ascend
}

/// Horn, Hilden, Negahdaripour 1988: R = H (H^T H)^{-1/2} = sum_k (H v_k / s_k) v_k^T over the eigenvectors
/// v_k of H^T H. The third term is taken as (u1 x u2)(v1 x v2)^T, which equals H v3 v3^T / s3 when
/// det H > 0 and is the paper's end-of-Sec.-4.6 correction when det H < 0 or H has rank 2. Rank 1 (u2
/// undefined) completes u1 with the direction of v2 made orthogonal to u1; rank 0 gives the identity.
template <class T>
Matrix3<T> fit_rotation_horn_matrix(const Matrix3<T>& H) {
  Eigen::SelfAdjointEigenSolver<Matrix3<T>> eig(H.transpose() * H);
  const Vector3<T> v1 = eig.eigenvectors().col(2);
  // v2 from the plane orthogonal to v1 (spanned by the other two eigenvectors e2, e3, orthonormal to working
  // precision), by the top eigenvector of the 2x2 Gram matrix of H e2, H e3: H^T H itself carries rounding
  // of eps s1^2, which buries s2^2 - s3^2 whenever s2 < sqrt(eps) s1 (wide weights: kappa 1e7 in double
  // drew angles of 1e-5 against a bound of 6e-7); the deflated Gram matrix carries eps (s1 s2 + s2^2).
  const Vector3<T> e2 = eig.eigenvectors().col(1), e3 = eig.eigenvectors().col(0);
  const Vector3<T> he2 = H * e2, he3 = H * e3;
  const T g22 = he2.squaredNorm(), g33 = he3.squaredNorm(), g23 = he2.dot(he3);
  const T phi = T(0.5) * std::atan2(T(2) * g23, g22 - g33);  // angle of the top eigenvector of the 2x2
  const Vector3<T> v2 = std::cos(phi) * e2 + std::sin(phi) * e3;
  const Vector3<T> h1 = H * v1;
  if (h1.squaredNorm() == T(0)) return Matrix3<T>::Identity();
  Vector3<T> u1 = h1.normalized();
  // x minus its component along the unit vector e, twice (Kahan, Parlett: "twice is enough"): when x is
  // small against what it lost, one pass leaves a residue whose rounding is not orthogonal to e.
  auto orthogonalise = [](Vector3<T>& x, const Vector3<T>& e) {
    x -= e * e.dot(x);
    x -= e * e.dot(x);
  };
  // u2 = H v2 / s2, made exactly orthogonal to u1 (in exact arithmetic it already is).
  Vector3<T> u2 = H * v2;
  orthogonalise(u2, u1);
  // Rank 1 only where H v2 is nothing but rounding of rounding (eps^2 |H v1|): a u2 taken from noise of order
  // eps |H v1| is harmless (s2, s3 are then at rounding level and every turn about v1 is optimal to within
  // it), while a larger threshold (16 eps |H v1|, as here before) misread float H with s2 ~ 1e-6 s1 (wide
  // weights) as rank 1 and turned them arbitrarily about v1.
  const T tiny = std::numeric_limits<T>::epsilon() * std::numeric_limits<T>::epsilon() * h1.norm();
  if (!(u2.norm() > tiny)) {  // rank 1: any rotation taking v1 to u1 is optimal
    u2 = v2;
    orthogonalise(u2, u1);
    if (!(u2.norm() > T(0.5))) u2 = u1.unitOrthogonal();
  }
  u2.normalize();
  // Forming H^T H squares the conditioning of its eigenvectors: v2 and v3 mix by eps s1^2 / (s2^2 - s3^2),
  // an error of up to eps kappa^2 in R. u = H v / |H v| carries that mixing only scaled by s3 / s2, so
  // alternating v_k = H^T u_k / |H^T u_k| and u_k = H v_k / |H v_k| (subspace iteration on the same
  // factorisation, three rounds) brings R = sum_k u_k v_k^T back to eps kappa.
  Vector3<T> w1 = v1, w2 = v2;  // stay v1, v2 when the first round cannot start (rank 1)
  for (int round = 0; round < 3; ++round) {
    Vector3<T> a1 = H.transpose() * u1, a2 = H.transpose() * u2;
    const T n1 = a1.norm();
    if (!(n1 > T(0))) break;
    a1 /= n1;
    orthogonalise(a2, a1);
    if (!(a2.norm() > tiny)) break;
    a2.normalize();
    w1 = a1, w2 = a2;
    Vector3<T> b1 = H * w1, b2 = H * w2;
    b1.normalize();
    orthogonalise(b2, b1);
    if (!(b2.norm() > tiny)) break;
    u1 = b1, u2 = b2.normalized();
  }
  const Vector3<T> u3 = u1.cross(u2), w3 = w1.cross(w2);
  return u1 * w1.transpose() + u2 * w2.transpose() + u3 * w3.transpose();
}

/// Kanatani 1994: with the correlation matrix K = sum_i w_i phat_i qhat_i^T = H^T and its SVD
/// K = U S V^T, the optimal proper rotation is R = V diag(1, 1, det(V U^T)) U^T. Mathematically the same
/// optimum as Umeyama's fix of Arun's SVD method (and as Horn's quaternion), reached from H^T.
template <class T>
Matrix3<T> fit_rotation_kanatani(const Matrix3<T>& H) {
  Eigen::JacobiSVD<Matrix3<T>> svd(H.transpose(), Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Matrix3<T> U = svd.matrixU(), V = svd.matrixV();
  const T d = (V * U.transpose()).determinant() < T(0) ? T(-1) : T(1);
  return V * Vector3<T>(T(1), T(1), d).asDiagonal() * U.transpose();
}

/// Arun, Huang, Blostein 1987 with Umeyama's 1991 reflection fix: H = U S V^T, R = U diag(1,1,d) V^T,
/// d = sign det(U V^T).
template <class T>
Matrix3<T> fit_rotation_svd(const Matrix3<T>& H) {
  Eigen::JacobiSVD<Matrix3<T>> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Matrix3<T> U = svd.matrixU(), V = svd.matrixV();
  const T d = (U * V.transpose()).determinant() < T(0) ? T(-1) : T(1);
  return U * Vector3<T>(T(1), T(1), d).asDiagonal() * V.transpose();
}

// Instantiated once per type in baselines_float.cpp and baselines_double.cpp (Eigen's dense solvers are the
// slowest code of the library to compile).
#define MLSDEFORM_BASELINES(EXTERN, T)                                           \
  EXTERN template Matrix3<T> fit_rotation_horn_quaternion<T>(const Matrix3<T>&); \
  EXTERN template Matrix3<T> fit_rotation_horn_matrix<T>(const Matrix3<T>&);     \
  EXTERN template Matrix3<T> fit_rotation_kanatani<T>(const Matrix3<T>&);        \
  EXTERN template Matrix3<T> fit_rotation_svd<T>(const Matrix3<T>&);
MLSDEFORM_BASELINES(extern, float)
MLSDEFORM_BASELINES(extern, double)

}  // namespace mlsdeform::detail
