// The long-double SVD reference that every rotation-fit benchmark checks its results against before timing,
// and the tolerances it applies (derived below, not tuned).
//
// Same definitions as the accuracy suite (tests/support/rotation_cases.hpp), kept here so that the benchmarks
// build without the test support library: H (exactly as the method sees it, already rounded to float or
// double) is converted exactly to long double and decomposed, H = U diag(s1, s2, s3) V^T with
// s1 >= s2 >= s3 >= 0 and d = sign det(U V^T). The optimal proper rotation is R* = U diag(1, 1, d) V^T, the
// optimum of trace(R^T H) is y* = s1 + s2 + d s3, and its condition number is kappa = s1 / (s2 + d s3).
//
// Tolerances for a method computing in precision eps (float or double), with gap = s2 + d s3:
//   * Backward error. A backward-stable method returns the exact answer for some H + dH with
//     ||dH||_F <= c eps ||H||_F. We take c = 32: each method forms R from H through O(10) dependent roundings
//     per entry (invariants, a quartic root or two Jacobi sweeps of three rotations, a 4x4 adjugate, 3x3
//     products), ~16 on the longest chain, and a factor 2 of margin.
//   * Angle, backward-stable methods (axis_angle, horn_quaternion, kanatani, svd). The proper polar factor
//     turns, in the plane of singular pair (i, j), by at most ||dH|| / (s_i + s_j) (Higham, Functions of
//     Matrices, Thm. 8.9; the proper rotation has d s3 in place of s3). The smallest sum is gap and
//     ||H||_F <= sqrt(3) s1, so angle <= c eps sqrt(3) kappa; add 2 c eps for the rounding of R itself and
//     of the stored reference:  theta_tol = c eps (2 + sqrt(3) kappa).
//   * Angle, Horn 1988 (through the normal matrix H^T H). Its eigenvectors are backward stable for H^T H,
//     ||d(H^T H)|| <= c eps s1^2, so the pair (2, 3) mixes by phi <= c eps s1^2 / (s2^2 - s3^2) (Davis-Kahan).
//     R = sum u_k v_k^T then turns by phi when d = -1 (the third column comes from cross products, and
//     nothing cancels the mixing) and by phi (s2 - s3)/(s2 + s3) when d = +1 (the pair's u2 v2^T + u3 v3^T is
//     invariant under mixing to first order as s2 -> s3); both equal c eps kappa s1 / (s2 + s3). The pairs
//     with s1 add at most c eps s1^2 / (s1 + s_j)^2 <= c eps.
//     theta_tol = c eps (2 + sqrt(3) kappa + kappa s1 / (s2 + s3)).
//   * Angle, QCP (a root of the characteristic polynomial from its coefficients, no refinement). Rounding
//     the terms of P(lambda) = lambda^4 + c2 lambda^2 + c1 lambda + c0 moves the root by
//     dlambda <= c eps S / |P'(lambda1)|, S = sum_k |c_k| lambda1^k; the eigenvalues of K are
//     lambda = (s1 + s2 + d s3, s1 - s2 - d s3, -s1 + s2 - d s3, -s1 - s2 + d s3), so
//     P'(lambda1) = 8 gap (s1 + d s3)(s1 + s2). The adjugate of K - (lambda1 + dlambda) I mixes the second
//     eigenvector in by dlambda / (lambda1 - lambda2) = dlambda / (2 gap), and the rotation angle is twice
//     the quaternion's:  theta_tol = c eps (2 + sqrt(3) kappa) + dlambda / gap (~ eps kappa^2).
//   * Orthonormality. Each entry of R is a sum of at most 3 products of factors that are orthonormal to
//     within the backward error: |R^T R - I|_max <= 2 c eps.
//   * Trace. A non-orthonormal R shifts trace(R^T H) by |trace(E^T H)| <= ||E||_F ||H||_F <= 3 * 2 c eps
//     ||H||_F either way; a rotation misplaced by theta in the gap plane loses gap (1 - cos theta), at most
//     gap min(2, theta^2) with theta <= theta_tol:  |trace(R^T H) - y*| <= 6 c eps ||H||_F + gap min(2,
//     theta_tol^2). (For a backward-stable method the second term is <= sqrt(6) c eps s1, where the two
//     bounds of the min cross.)
#pragma once

#include <mlsdeform/rotation.hpp>

#include <Eigen/Core>
#include <Eigen/SVD>

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

namespace bench {

using Matrix3L = Eigen::Matrix<long double, 3, 3>;

/// The reference for one H, rounded to double for storage (the rounding, <= eps_double / 2 per entry, is
/// covered by the 2 c eps term of the angle tolerance).
struct Reference {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< R* = U diag(1, 1, d) V^T
  double optimum = 0;                                       ///< y* = s1 + s2 + d s3
  double s1 = 0, s2 = 0, s3 = 0;                            ///< singular values, descending
  double d = 1;                                             ///< sign det(U V^T)
  double kappa = 0;                                         ///< s1 / (s2 + d s3); +inf when not unique
  double norm = 0;                                          ///< ||H||_F
  double gap() const { return s2 + d * s3; }
};

template <class T>
Reference reference(const mlsdeform::Matrix3<T>& H) {
  const Matrix3L Hl = H.template cast<long double>();
  Eigen::JacobiSVD<Matrix3L> svd(Hl, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Matrix3L U = svd.matrixU(), V = svd.matrixV();
  const auto s = svd.singularValues();
  const long double d = (U.determinant() * V.determinant()) < 0 ? -1.0L : 1.0L;
  Matrix3L D = Matrix3L::Identity();
  D(2, 2) = d;
  Reference r;
  r.rotation = (U * D * V.transpose()).template cast<double>();
  r.optimum = static_cast<double>(s(0) + s(1) + d * s(2));
  r.s1 = static_cast<double>(s(0));
  r.s2 = static_cast<double>(s(1));
  r.s3 = static_cast<double>(s(2));
  r.d = static_cast<double>(d);
  const long double gap = s(1) + d * s(2);
  r.kappa = gap > 0 ? static_cast<double>(s(0) / gap) : std::numeric_limits<double>::infinity();
  r.norm = static_cast<double>(Hl.norm());
  return r;
}

/// Which error model judges a method (see the tolerances above).
enum class ErrorModel { backward_stable, normal_matrix, polynomial_root };

inline ErrorModel error_model(mlsdeform::RotationMethod m) {
  return m == mlsdeform::RotationMethod::horn_matrix ? ErrorModel::normal_matrix : ErrorModel::backward_stable;
}

/// The angle (rad) between two nearly orthonormal matrices, 2 asin(||A - B||_F / sqrt(8)): exact for
/// rotations and well conditioned near 0 (unlike acos((trace(A^T B) - 1) / 2)).
inline long double rotation_angle(const Matrix3L& A, const Matrix3L& B) {
  const long double x = (A - B).norm() / std::sqrt(8.0L);
  return 2 * std::asin(x < 1 ? x : 1.0L);
}

/// The errors of one result and the verdict against the tolerances above.
struct Verdict {
  long double angle = 0, angle_tol = 0;  ///< angle to R* (0 and inf when the optimum is not unique)
  long double trace = 0, trace_tol = 0;  ///< |trace(R^T H) - y*|
  long double orth = 0, orth_tol = 0;    ///< max |R^T R - I|
  bool ok = true;
  /// The worst of the three error/tolerance ratios (<= 1 when ok).
  long double worst_ratio() const {
    long double r = trace / trace_tol;
    if (orth / orth_tol > r) r = orth / orth_tol;
    if (angle_tol > 0 && std::isfinite(static_cast<double>(angle_tol)) && angle / angle_tol > r) r = angle / angle_tol;
    return r;
  }
  std::string describe() const {
    char buf[256];
    std::snprintf(buf, sizeof buf, "angle %.3Lg (tol %.3Lg), trace %.3Lg (tol %.3Lg), orth %.3Lg (tol %.3Lg)", angle,
                  angle_tol, trace, trace_tol, orth, orth_tol);
    return buf;
  }
};

/// c in the derivation above.
inline constexpr long double kBackwardErrorFactor = 32;

/// theta_tol of the derivation above (+inf where the optimum is not unique).
inline long double angle_tolerance(const Reference& ref, ErrorModel model, long double eps) {
  constexpr long double c = kBackwardErrorFactor;
  const long double inf = std::numeric_limits<long double>::infinity();
  if (!std::isfinite(ref.kappa)) return inf;
  const long double kappa = ref.kappa, s1 = ref.s1, s2 = ref.s2, s3 = ref.s3, d = ref.d;
  long double tol = c * eps * (2 + std::sqrt(3.0L) * kappa);
  if (model == ErrorModel::normal_matrix) tol += c * eps * kappa * s1 / (s2 + s3);
  if (model == ErrorModel::polynomial_root) {
    const long double gap = s2 + d * s3;
    const long double l1 = s1 + s2 + d * s3, l2 = s1 - s2 - d * s3, l3 = -s1 + s2 - d * s3, l4 = -s1 - s2 + d * s3;
    const long double c2 = -2 * (s1 * s1 + s2 * s2 + s3 * s3), c1 = -8 * s1 * s2 * d * s3, c0 = l1 * l2 * l3 * l4;
    const long double S = l1 * l1 * l1 * l1 + std::abs(c2) * l1 * l1 + std::abs(c1) * l1 + std::abs(c0);
    const long double dP = 8 * gap * (s1 + d * s3) * (s1 + s2);
    if (!(dP > 0)) return inf;
    tol += c * eps * S / dP / gap;
  }
  return tol;
}

template <class T>
Verdict judge(const mlsdeform::Matrix3<T>& R, const mlsdeform::Matrix3<T>& H, const Reference& ref,
              ErrorModel model = ErrorModel::backward_stable) {
  constexpr long double eps = std::numeric_limits<T>::epsilon();
  constexpr long double c = kBackwardErrorFactor;
  const Matrix3L Rl = R.template cast<long double>(), Hl = H.template cast<long double>();
  Verdict v;
  v.orth = (Rl.transpose() * Rl - Matrix3L::Identity()).cwiseAbs().maxCoeff();
  v.orth_tol = 2 * c * eps;
  v.angle_tol = angle_tolerance(ref, model, eps);
  if (std::isfinite(static_cast<double>(v.angle_tol))) v.angle = rotation_angle(Rl, ref.rotation.cast<long double>());
  const long double gap = static_cast<long double>(ref.s2 + ref.d * ref.s3);
  const long double theta2 = std::isfinite(static_cast<double>(v.angle_tol)) ? v.angle_tol * v.angle_tol : 2.0L;
  v.trace = std::abs((Rl.transpose() * Hl).trace() - static_cast<long double>(ref.optimum));
  v.trace_tol = 6 * c * eps * static_cast<long double>(ref.norm) + gap * std::min(2.0L, theta2);
  // Written so that a NaN anywhere fails.
  v.ok = R.allFinite() && v.orth <= v.orth_tol && v.trace <= v.trace_tol && v.angle <= v.angle_tol;
  return v;
}

}  // namespace bench
