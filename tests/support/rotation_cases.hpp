// Shared test helpers for the rotation fit: an independent long-double SVD reference, error measures, and
// deterministic random case families. Used by the accuracy suite
// (tests/test_rotation_accuracy*.cpp), the accuracy report (tools/accuracy_report.cpp) and any benchmark
// that wants to check its results; depends on Eigen and the public API only (no Catch2).
//
// Reference. H (as the method sees it, i.e. already rounded to float or double) is converted exactly to
// long double and decomposed by Eigen::JacobiSVD<Matrix<long double,3,3>>: H = U diag(s1, s2, s3) V^T,
// s1 >= s2 >= s3 >= 0, d = sign det(U V^T) = sign det H (where det H != 0). The optimal proper rotation is
// R* = U diag(1, 1, d) V^T, the optimum of trace(R^T H) is s1 + s2 + d s3, and the optimum is unique iff
// s2 + d s3 > 0; its condition number is kappa = s1 / (s2 + d s3) (+infinity when not unique). Long double
// carries 64 significand bits, 11 more than double, so the reference's own error (a few long-double eps
// times kappa) is negligible against any float or double method's.
//
// Case families. Every case is a pure function of (family, seed, index): H is built in long double as
// sum_i w_i qhat_i phat_i^T (or directly, for the matrix families), then rounded once to T, so that the
// reference judges exactly the H the method sees. A failing case is reproduced with make_case(f, seed, i).
#pragma once

#include "tests/support/random.hpp"  // Rng

#include <mlsdeform/rotation.hpp>

#include <Eigen/Core>

#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>

namespace mlsdeform::testing {

// ---------------------------------------------------------------------------------------------------------
// Reference and error measures
// ---------------------------------------------------------------------------------------------------------

/// The long-double SVD reference for one H.
struct Reference {
  Matrix3L rotation = Matrix3L::Identity();  ///< R* = U diag(1, 1, d) V^T
  Vector3L singular = Vector3L::Zero();      ///< s1 >= s2 >= s3 >= 0
  int d = 1;                                 ///< sign det(U V^T) (+1 or -1)
  int sign_det = 0;                          ///< sign of det H computed in long double (-1, 0, +1)
  long double optimum = 0;                   ///< s1 + s2 + d s3 = max over SO(3) of trace(R^T H)
  long double kappa = 0;                     ///< s1 / (s2 + d s3); +inf when the optimum is not unique
  long double norm = 0;                      ///< ||H||_F

  /// Whether a single rotation attains the optimum (s2 + d s3 > 0).
  bool unique() const { return kappa < std::numeric_limits<long double>::infinity(); }
};

Reference reference(const Matrix3L& H);

template <class T>
Reference reference(const Matrix3<T>& H) {
  return reference(Matrix3L(H.template cast<long double>()));
}

/// How far a candidate rotation R (for the matrix H) is from the reference. All in long double, from the
/// exact values of R and H.
struct Errors {
  bool finite = true;              ///< every entry of R finite
  long double orthonormality = 0;  ///< max |(R^T R - I)_ij|
  long double det_error = 0;       ///< |det R - 1|
  long double trace_loss = 0;      ///< (optimum - trace(R^T H)) / ||H||_F, signed (0 when H = 0)
  long double angle = 0;           ///< angle (rad) between R and R*: 2 asin(||R - R*||_F / sqrt(8))
};

template <class T>
Errors measure(const Matrix3<T>& R, const Matrix3<T>& H, const Reference& ref);

/// The angle (rad) between two (nearly) orthonormal matrices: 2 asin(min(1, ||A - B||_F / sqrt(8))),
/// exact for rotations and well conditioned for small angles (unlike acos((trace(A^T B) - 1) / 2)).
long double rotation_angle(const Matrix3L& A, const Matrix3L& B);

/// The rotation by `angle` about the unit vector `axis` (Rodrigues), in long double.
Matrix3L axis_angle_rotation(const Vector3L& axis, long double angle);

// ---------------------------------------------------------------------------------------------------------
// Case families
// ---------------------------------------------------------------------------------------------------------

enum class Family {
  uniform,         ///< R uniform on SO(3); 3..300 points, random positive weights, no noise
  noise_1e_6,      ///< as uniform, Gaussian noise of 1e-6 of the point spread on q
  noise_1e_2,      ///< noise 1e-2 of the spread
  noise_1e_1,      ///< noise 1e-1 of the spread
  near_pi,         ///< rotation angle uniform in [pi - 1e-3, pi]
  exactly_pi,      ///< rotation angle pi (a half-turn about a random axis), exact in long double
  small_angle,     ///< rotation angle uniform in [0, 1e-6]
  three_points,    ///< exactly 3 points (so H has rank <= 2), uniform rotation, no noise
  wide_weights,    ///< weights log-uniform over 1e-6..1e6 (inverse-distance weights near a handle)
  collinear,       ///< all points on a line: rank-1 H, optimum not unique
  coplanar,        ///< all points on a plane: rank-2 H
  reflected,       ///< q = R diag(1, 1, -1) p (mirrored data): det H < 0
  zero,            ///< H = 0
  identity,        ///< H = c I, c > 0 (log-uniform)
  exact_rotation,  ///< H = R (all singular values 1)
  repeated_sv,     ///< H = U diag(s, s, t) V^T and the other patterns (s, t, t), (s, s, s), either sign of det
  gaussian,        ///< entries iid N(0, 1): generic H, det of either sign
  scaled,          ///< a uniform-family H times 10^u, u uniform over +-15 (float) or +-100 (double)
  wide_exponents,  ///< entries of random sign and exponent over most of T's finite range (stress: finiteness)
};

struct FamilyInfo {
  Family family;
  std::string_view name;
  std::string_view description;
};

/// Every family, in declaration order.
std::span<const FamilyInfo> all_families();
std::string_view to_string(Family family);
/// Throws std::invalid_argument on an unknown name.
Family family_from_string(std::string_view name);

/// One generated case. `H` is what the method sees; `H_exact` is the long-double matrix it was rounded from.
template <class T>
struct Case {
  Family family = Family::uniform;
  std::uint64_t seed = 0;
  std::uint64_t index = 0;
  Matrix3<T> H = Matrix3<T>::Zero();
  Matrix3L H_exact = Matrix3L::Zero();
  Matrix3L generator = Matrix3L::Identity();  ///< the rotation the points were moved by (point families)
  int points = 0;                             ///< number of points (0 for the matrix families)
  long double noise = 0;                      ///< noise level relative to the point spread
};

/// The case `index` of `family` for run seed `seed`: deterministic.
template <class T>
Case<T> make_case(Family family, std::uint64_t seed, std::uint64_t index);

/// Weighted points: H = sum_i w_i (q_i - q*)(p_i - p*)^T in long double (eq. 2 and 6, column convention).
Matrix3L correlation_matrix(const Eigen::Matrix<long double, Eigen::Dynamic, 3>& p,
                            const Eigen::Matrix<long double, Eigen::Dynamic, 3>& q,
                            const Eigen::Matrix<long double, Eigen::Dynamic, 1>& w);

/// H written with hex-float entries (exact, pasteable into C++ as an Eigen comma initialiser).
template <class T>
std::string hex(const Matrix3<T>& H);

/// A one-line description of a case for failure messages: family, seed, index, points, noise and H (hex).
template <class T>
std::string describe(const Case<T>& c);

// ---------------------------------------------------------------------------------------------------------
// Run configuration shared by the suite and the report
// ---------------------------------------------------------------------------------------------------------

/// The default seed of the accuracy suite and report (a fixed date, 2026-11-21).
inline constexpr std::uint64_t kDefaultSeed = 20261121;

/// Reads an unsigned integer from the environment (decimal, or hex with 0x); `fallback` when unset.
/// Throws std::invalid_argument when set but not a number.
std::uint64_t env_u64(const char* name, std::uint64_t fallback);

/// Whether this binary was built with AddressSanitizer (then the suite runs fewer cases by default).
constexpr bool built_with_sanitizer() {
#if defined(__SANITIZE_ADDRESS__)
  return true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  return true;
#else
  return false;
#endif
#else
  return false;
#endif
}

/// Whether this test runs under an emulator (a cross build's ctest, tests/CMakeLists.txt): then the suites that
/// judge by long-double references run fewer cases by default. On aarch64 long double is IEEE binary128, computed
/// in software: 100-200x slower than x87's 80 bits, on top of the emulation's 17-36x.
constexpr bool run_emulated() {
#if defined(MLSDEFORM_TEST_EMULATED)
  return true;
#else
  return false;
#endif
}

}  // namespace mlsdeform::testing
