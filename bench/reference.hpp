// How the rotation-fit benchmarks judge a result before timing: the project's long-double SVD reference and
// accuracy bounds (tests/support/rotation_cases.hpp and accuracy_bounds.hpp, the ones the accuracy suite
// and docs/accuracy.md use), so that a benchmark and the accuracy suite never disagree on a method, plus one
// extra bound for QCP, which is not a library method.
//
// The project's bounds (derived in tests/support/accuracy_bounds.hpp from a backward-error constant c_b per
// method, c_o = 64 for orthonormality and kappa = s1 / (s2 + d s3)):
//   |R^T R - I| <= c_o eps, |det R - 1| <= 1.5 c_o eps,
//   trace loss <= (2 sqrt(3) c_b + 1.5 c_o) eps ||H||_F, overshoot <= 1.5 c_o eps ||H||_F,
//   angle <= 2 sqrt(3) c_b eps kappa + 1.5 c_o eps where the optimum is unique (and the bound below pi),
// with c_b = 16 for horn_quaternion, kanatani and svd and 64 for axis_angle and horn_matrix.
//
// QCP (bench/qcp.hpp) takes the largest root of the characteristic polynomial from its coefficients and
// uses it without refinement, so it is not backward stable near a double root; its bound adds that
// effect to the uniform c_b = 16:
//   * Rounding the terms of P(lambda) = lambda^4 + c2 lambda^2 + c1 lambda + c0 moves the root by
//     dlambda <= c eps S / |P'(lambda1)|, S = sum_k |c_k| lambda1^k, c = 32 (the ~16 roundings of the
//     coefficients and of Horner's evaluation, doubled). The eigenvalues of K are (s1 + s2 + d s3,
//     s1 - s2 - d s3, -s1 + s2 - d s3, -s1 - s2 + d s3), so P'(lambda1) = 8 gap (s1 + d s3)(s1 + s2) with
//     gap = s2 + d s3.
//   * The adjugate of K - (lambda1 + dlambda) I mixes in the second eigenvector by dlambda / (lambda1 -
//     lambda2) = dlambda / (2 gap), and the rotation angle is twice the quaternion's: + dlambda / gap
//     (~ eps kappa^2).
//   * The mixing costs trace: a rotation misplaced by theta in the gap plane loses gap (1 - cos theta),
//     at most gap min(2, theta^2): that is added to the trace-loss bound.
// Stored references are rounded to double (R* loses <= eps_double / 2 per entry, far inside 1.5 c_o eps).
#pragma once

#include "tests/support/accuracy_bounds.hpp"
#include "tests/support/rotation_cases.hpp"

#include <mlsdeform/rotation.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>

namespace bench {

using Matrix3L = Eigen::Matrix<long double, 3, 3>;
namespace testing = mlsdeform::testing;

/// The long-double reference of one H (tests/support's), stored compactly in double.
struct Reference {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< R* = U diag(1, 1, d) V^T
  double optimum = 0;                                      ///< y* = s1 + s2 + d s3
  double s1 = 0, s2 = 0, s3 = 0;                           ///< singular values, descending
  double d = 1;                                            ///< sign det(U V^T)
  double kappa = 0;                                        ///< s1 / (s2 + d s3); +inf when not unique
  double norm = 0;                                         ///< ||H||_F
  double gap() const { return s2 + d * s3; }

  testing::Reference expand() const {
    testing::Reference r;
    r.rotation = rotation.cast<long double>();
    r.singular = testing::Vector3L(s1, s2, s3);
    r.d = d < 0 ? -1 : 1;
    r.optimum = optimum;
    r.kappa = kappa;
    r.norm = norm;
    return r;
  }
};

template <class T>
Reference reference(const mlsdeform::Matrix3<T>& H) {
  const testing::Reference t = testing::reference(H);
  Reference r;
  r.rotation = t.rotation.template cast<double>();
  r.optimum = static_cast<double>(t.optimum);
  r.s1 = static_cast<double>(t.singular(0));
  r.s2 = static_cast<double>(t.singular(1));
  r.s3 = static_cast<double>(t.singular(2));
  r.d = t.d;
  r.kappa = static_cast<double>(t.kappa);
  r.norm = static_cast<double>(t.norm);
  return r;
}

using testing::rotation_angle;

/// Which bound judges a result: a library method's (its c_b), or QCP's.
struct Judge {
  long double cb = testing::c_b_uniform;
  bool polynomial_root = false;  ///< add the QCP terms

  static Judge method(mlsdeform::RotationMethod m) { return {testing::c_b(m), false}; }
  static Judge qcp() { return {testing::c_b_uniform, true}; }
};

/// The extra angle of the polynomial-root bound (see the file comment); +inf where it says nothing.
inline long double polynomial_root_angle(const Reference& ref, long double eps) {
  constexpr long double c = 32;
  const long double s1 = ref.s1, s2 = ref.s2, s3 = ref.s3, d = ref.d, gap = s2 + d * s3;
  const long double l1 = s1 + s2 + d * s3, l2 = s1 - s2 - d * s3, l3 = -s1 + s2 - d * s3, l4 = -s1 - s2 + d * s3;
  const long double c2 = -2 * (s1 * s1 + s2 * s2 + s3 * s3), c1 = -8 * s1 * s2 * d * s3, c0 = l1 * l2 * l3 * l4;
  const long double S = l1 * l1 * l1 * l1 + std::abs(c2) * l1 * l1 + std::abs(c1) * l1 + std::abs(c0);
  const long double dP = 8 * gap * (s1 + d * s3) * (s1 + s2);
  if (!(dP > 0)) return std::numeric_limits<long double>::infinity();
  return c * eps * S / dP / gap;
}

/// The errors of one result and the verdict.
struct Verdict {
  long double angle = 0, angle_tol = 0;  ///< angle to R* (tol +inf: not checked)
  long double loss = 0, loss_tol = 0;    ///< trace loss / ||H||_F (negative: overshoot)
  long double overshoot_tol = 0;
  long double orth = 0, orth_tol = 0;
  long double det = 0, det_tol = 0;
  bool finite = true, ok = true;
  /// The worst error/tolerance ratio (<= 1 when ok).
  long double worst_ratio() const {
    if (!finite) return std::numeric_limits<long double>::infinity();
    long double r = std::max({orth / orth_tol, det / det_tol, loss / loss_tol, -loss / overshoot_tol});
    if (std::isfinite(static_cast<double>(angle_tol))) r = std::max(r, angle / angle_tol);
    return r;
  }
  std::string describe() const {
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "angle %.3Lg (tol %.3Lg), trace loss %.3Lg ||H|| (tol %.3Lg, overshoot tol %.3Lg), orth %.3Lg "
                  "(tol %.3Lg), |det - 1| %.3Lg (tol %.3Lg)%s",
                  angle, angle_tol, loss, loss_tol, overshoot_tol, orth, orth_tol, det, det_tol,
                  finite ? "" : ", NOT FINITE");
    return buf;
  }
};

template <class T>
Verdict judge(const mlsdeform::Matrix3<T>& R, const mlsdeform::Matrix3<T>& H, const Reference& ref, const Judge& how) {
  constexpr long double eps = std::numeric_limits<T>::epsilon();
  const testing::Reference tref = ref.expand();
  const testing::Errors e = testing::measure<T>(R, H, tref);
  Verdict v;
  v.finite = e.finite;
  v.orth = e.orthonormality, v.orth_tol = testing::tol_orthonormality<T>();
  v.det = e.det_error, v.det_tol = testing::tol_det<T>();
  v.loss = e.trace_loss, v.loss_tol = testing::tol_trace_loss<T>(how.cb);
  v.overshoot_tol = testing::tol_trace_overshoot<T>();
  v.angle = e.angle;
  v.angle_tol = std::numeric_limits<long double>::infinity();
  if (tref.unique()) {
    long double tol = testing::tol_angle<T>(tref.kappa, how.cb);
    if (how.polynomial_root) {
      tol += polynomial_root_angle(ref, eps);
      const long double gap = ref.gap(), theta2 = std::isfinite(static_cast<double>(tol)) ? tol * tol : 2.0L;
      if (ref.norm > 0) v.loss_tol += gap * std::min(2.0L, theta2) / static_cast<long double>(ref.norm);
    }
    if (tol < std::numbers::pi_v<long double>) v.angle_tol = tol;
  }
  // Written so that a NaN anywhere fails.
  v.ok = e.finite && v.orth <= v.orth_tol && v.det <= v.det_tol && v.loss <= v.loss_tol && v.loss >= -v.overshoot_tol &&
         (!std::isfinite(static_cast<double>(v.angle_tol)) || v.angle <= v.angle_tol);
  return v;
}

}  // namespace bench
