// The accuracy suite's bounds, shared by tests/test_rotation_accuracy.cpp and
// tools/accuracy_report.cpp so that the report counts exactly the cases the suite would reject.
//
// eps = std::numeric_limits<T>::epsilon(). Two constants state what "small multiple" means,
// counted from the operations the methods perform, not from measured errors:
//   c_b = 16  backward error (per method: see c_b() below): each method returns (up to the departure from
//             orthonormality below) the exact optimum for some H + dH with ||dH||_F <= c_b eps ||H||_F.
//             fit_rotation's normalisation by a power of two is exact; after it every entry of H reaches the
//             result through at most ~16 roundings (axis_angle: invariants <= 5, 4x4 cofactors <= 8,
//             quaternion to matrix <= 3; the Jacobi/QR solvers: a few per sweep, 2-3 sweeps on a 3x3), and
//             first-order errors add.
//   c_o = 64  orthonormality: max_ij |(R^T R - I)_ij| <= c_o eps. An entry of R is a sum of products of
//             order-1 numbers: <= 8 roundings for the quaternion-to-matrix formula (5)/(15), and up to ~30
//             plane rotations of ~2 eps each accumulated into U and V for the SVD/eigen solvers; an entry of
//             R^T R is a 3-term inner product of two such columns, which doubles the count.
// From these:
//   det:   det(R)^2 = det(I + F) = 1 + trace(F) + O(eps^2) with F = R^T R - I, so
//          |det R - 1| <= (3/2) c_o eps.
//   trace: write R = Rt + E with Rt the nearest rotation, ||E||_F <= (1/2) ||F||_F <= (3/2) c_o eps. Since the
//          optimum opt(H) = max_R trace(R^T H) is sqrt(3)-Lipschitz in ||.||_F and Rt is optimal for H + dH:
//            opt(H) - trace(R^T H) <= 2 sqrt(3) c_b eps ||H||_F + (3/2) c_o eps ||H||_F   (loss)
//            trace(R^T H) - opt(H) <= (3/2) c_o eps ||H||_F                              (overshoot)
//          This holds whatever the conditioning (it is a backward-error statement), so it is checked on
//          every case, unique optimum or not.
//   angle: the optimal quaternion is the top eigenvector of Davenport's K (||dK||_F <= 2 ||dH||_F) with
//          eigengap 2 (s2 + d s3), so the rotation moves by at most 2 * 2 ||dH|| / (2 (s2 + d s3)); with
//          ||H||_F <= sqrt(3) s1 and kappa = s1 / (s2 + d s3):
//            angle(R, R*) <= 2 sqrt(3) c_b eps kappa + (3/2) c_o eps.
//          Checked where the optimum is unique and the bound is below pi (beyond it, it says nothing).
//   The reference's own error (long-double eps = 2^-64, i.e. 2^-11 of double's eps) is neglected.
#pragma once

#include "tests/support/rotation_cases.hpp"

#include <limits>
#include <numbers>
#include <sstream>
#include <string>

namespace mlsdeform::testing {

inline constexpr long double c_o = 64;

/// The a-priori constant counted above, common to every method.
inline constexpr long double c_b_uniform = 16;

/// c_b per method: every method is held to the uniform constant.
inline long double c_b(RotationMethod) { return c_b_uniform; }

template <class T>
inline constexpr long double eps = std::numeric_limits<T>::epsilon();

template <class T>
long double tol_orthonormality() {
  return c_o * eps<T>;
}
template <class T>
long double tol_det() {
  return 1.5L * c_o * eps<T>;
}
/// Relative to ||H||_F.
template <class T>
long double tol_trace_loss(long double cb) {
  return (2 * std::numbers::sqrt3_v<long double> * cb + 1.5L * c_o) * eps<T>;
}
/// Relative to ||H||_F.
template <class T>
long double tol_trace_overshoot() {
  return 1.5L * c_o * eps<T>;
}
template <class T>
long double tol_angle(long double kappa, long double cb) {
  return 2 * std::numbers::sqrt3_v<long double> * cb * eps<T> * kappa + 1.5L * c_o * eps<T>;
}
template <class T>
long double tol_angle(long double kappa, RotationMethod m) {
  return tol_angle<T>(kappa, c_b(m));
}

/// Checks one result against every bound above with backward-error constant `cb`; returns a description of
/// the violations ("" when none).
template <class T>
std::string violations(const Errors& e, const Reference& ref, long double cb) {
  std::ostringstream out;
  out.precision(3);
  if (!e.finite) return "non-finite result";
  if (!(e.orthonormality <= tol_orthonormality<T>()))
    out << " orthonormality " << double(e.orthonormality / eps<T>) << " eps > " << double(c_o) << " eps;";
  if (!(e.det_error <= tol_det<T>())) out << " |det - 1| " << double(e.det_error / eps<T>) << " eps;";
  if (!(e.trace_loss <= tol_trace_loss<T>(cb)))
    out << " trace loss " << double(e.trace_loss / eps<T>) << " eps ||H|| > " << double(tol_trace_loss<T>(cb) / eps<T>)
        << " eps ||H||;";
  if (!(e.trace_loss >= -tol_trace_overshoot<T>()))
    out << " trace overshoot " << double(-e.trace_loss / eps<T>) << " eps ||H||;";
  if (ref.unique()) {
    const long double tol = tol_angle<T>(ref.kappa, cb);
    if (tol < std::numbers::pi_v<long double> && !(e.angle <= tol))
      out << " angle " << double(e.angle) << " rad > " << double(tol) << " rad (kappa " << double(ref.kappa) << ");";
  }
  return out.str();
}

/// The same with method m's constant c_b(m): what the accuracy suite checks.
template <class T>
std::string violations(const Errors& e, const Reference& ref, RotationMethod m) {
  return violations<T>(e, ref, c_b(m));
}

}  // namespace mlsdeform::testing
