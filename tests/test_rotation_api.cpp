// The public rotation API: names, errors on bad input, and the special matrices (zero, rank-deficient, reflections,
// extreme scales).
#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#include <cmath>
#include <limits>

using namespace mlsdeform;

TEMPLATE_TEST_CASE("fit_rotation rejects non-finite H", "[rotation]", float, double) {
  for (RotationMethod m : all_rotation_methods) {
    Matrix3<TestType> H = Matrix3<TestType>::Identity();
    H(1, 2) = std::numeric_limits<TestType>::quiet_NaN();
    CHECK_THROWS_AS(fit_rotation(H, m), std::invalid_argument);
    H(1, 2) = std::numeric_limits<TestType>::infinity();
    CHECK_THROWS_WITH(fit_rotation(H, m), Catch::Matchers::ContainsSubstring("NaN or infinite"));
  }
}

TEST_CASE("rotation method names round-trip", "[rotation]") {
  for (RotationMethod m : all_rotation_methods) CHECK(rotation_method_from_string(to_string(m)) == m);
  CHECK_THROWS_AS(rotation_method_from_string("quest"), std::invalid_argument);
}

TEMPLATE_TEST_CASE("exact special matrices give exact answers", "[rotation]", float, double) {
  using T = TestType;
  // H = 0 and H = I: the identity, exactly (the paper's (14) alone divides 0 by 0 for H = I, V = 0).
  for (RotationMethod m : all_rotation_methods) {
    INFO(to_string(m));
    CHECK(fit_rotation<T>(Matrix3<T>::Zero(), m) == Matrix3<T>::Identity());
    const Matrix3<T> R = fit_rotation<T>(Matrix3<T>::Identity(), m);
    CHECK((R - Matrix3<T>::Identity()).cwiseAbs().maxCoeff() <= T(4) * std::numeric_limits<T>::epsilon());
    // A half-turn about z: H = diag(-1, -1, 1); every method must find it (the paper's (14) is singular here).
    const Matrix3<T> Hpi = Vector3<T>(-1, -1, 1).asDiagonal();
    const Matrix3<T> Rpi = fit_rotation<T>(Hpi, m);
    CHECK((Rpi - Hpi).cwiseAbs().maxCoeff() <= T(4) * std::numeric_limits<T>::epsilon());
  }
}
