// The public fits take Eigen expressions and any storage order, not only the exact Matrix3 / Points types.
#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#include <Eigen/Geometry>

using namespace mlsdeform;

TEMPLATE_TEST_CASE("fit_rotation accepts Eigen expressions", "[rotation][api]", float, double) {
  using T = TestType;
  const Vector3<T> p(1, 2, 3), q(-2, 1, 0.5);
  const Vector3<T> p2(0, 1, -1), q2(1, 0, 2);
  // The expression is evaluated into the same Matrix3 first: the result is bitwise that of the plain call.
  const Matrix3<T> H = q * p.transpose() + q2 * p2.transpose();
  const Matrix3<T> R = fit_rotation(H);
  CHECK(fit_rotation(q * p.transpose() + q2 * p2.transpose()) == R);
  const Eigen::Matrix<T, 3, 3, Eigen::RowMajor> row_major = H;
  CHECK(fit_rotation(row_major, RotationMethod::svd) == fit_rotation(H, RotationMethod::svd));
  Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic> big = Eigen::Matrix<T, 5, 5>::Zero();
  big.block(1, 1, 3, 3) = H;
  CHECK(fit_rotation(big.block(1, 1, 3, 3)) == R);
  const Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic> dyn = H;
  CHECK(fit_rotation(dyn) == R);
  CHECK_THROWS_AS(fit_rotation(big.block(0, 0, 2, 3)), std::invalid_argument);
}

TEMPLATE_TEST_CASE("fit_rigid and fit_similarity deduce the precision from their arguments", "[point_fit][api]", float,
                   double) {
  using T = TestType;
  Points<T> P(4, 3);
  P << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  const Matrix3<T> Rz = Eigen::AngleAxis<T>(T(0.5), Vector3<T>::UnitZ()).toRotationMatrix();
  const Points<T> Q = (P * Rz.transpose()).rowwise() + Eigen::Matrix<T, 1, 3>(1, 2, 3);
  const Eigen::Matrix<T, Eigen::Dynamic, 1> w = Eigen::Matrix<T, Eigen::Dynamic, 1>::Ones(4);
  const SimilarityTransform<T> expected = fit_rigid<T>(P, Q, w);
  const SimilarityTransform<T> a = fit_rigid(P, Q, w);  // no explicit <T>
  CHECK(a.rotation == expected.rotation);
  CHECK(a.translation == expected.translation);
  const PointsRowMajor<T> Pr = P, Qr = Q;  // interleaved storage, an expression for the weights
  const SimilarityTransform<T> b = fit_rigid(Pr, Qr, T(2) * w);
  CHECK((b.rotation - Rz).norm() <= 64 * std::numeric_limits<T>::epsilon());
  const SimilarityTransform<T> c = fit_similarity(P * T(2), Q, w.transpose());
  CHECK(std::abs(c.scale - T(0.5)) <= 64 * std::numeric_limits<T>::epsilon());
  const Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic> wrong = Eigen::Matrix<T, 4, 2>::Zero();
  CHECK_THROWS_AS(fit_rigid(wrong, Q, w), std::invalid_argument);
}
