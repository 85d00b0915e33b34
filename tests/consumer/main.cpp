// Consumer of the installed package: fits a known rotation in float and double with every method, and a
// rigid motion from points. Exits non-zero on any failure.
#include <mlsdeform/mlsdeform.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

namespace {

int failures = 0;

template <class T>
void check_rotation() {
  // A rotation by 2 rad about (1, 2, 2) / 3 (Rodrigues), and H = R diag(3, 2, 1): the optimum is R.
  const mlsdeform::Vector3<T> e = mlsdeform::Vector3<T>(1, 2, 2) / T(3);
  mlsdeform::Matrix3<T> K;
  K << 0, -e(2), e(1), e(2), 0, -e(0), -e(1), e(0), 0;
  const T a = 2;
  const mlsdeform::Matrix3<T> R = mlsdeform::Matrix3<T>::Identity() + std::sin(a) * K + (1 - std::cos(a)) * K * K;
  const mlsdeform::Matrix3<T> H = R * mlsdeform::Vector3<T>(3, 2, 1).asDiagonal();
  for (mlsdeform::RotationMethod m : mlsdeform::all_rotation_methods) {
    const mlsdeform::Matrix3<T> got = mlsdeform::fit_rotation(H, m);
    // kappa = 3 / (2 + 1) = 1: a few hundred eps covers every method (tests/test_rotation_accuracy.cpp).
    const T err = (got - R).cwiseAbs().maxCoeff();
    if (!(err <= T(256) * std::numeric_limits<T>::epsilon())) {
      std::printf("FAIL fit_rotation<%s>(%s): max error %g\n", sizeof(T) == 4 ? "float" : "double",
                  std::string(mlsdeform::to_string(m)).c_str(), double(err));
      ++failures;
    }
  }
}

void check_rigid() {
  mlsdeform::Points<double> p(4, 3), q(4, 3);
  p << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  // A quarter turn about z and a translation (5, 6, 7).
  for (int i = 0; i < 4; ++i) q.row(i) << 5 - p(i, 1), 6 + p(i, 0), 7 + p(i, 2);
  const auto x = mlsdeform::fit_rigid<double>(p, q, Eigen::VectorXd());
  mlsdeform::Matrix3<double> R;
  R << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const double err = std::max((x.rotation - R).cwiseAbs().maxCoeff(),
                              (x.translation - mlsdeform::Vector3<double>(5, 6, 7)).cwiseAbs().maxCoeff());
  if (!(err <= 1e-12)) {
    std::printf("FAIL fit_rigid: max error %g\n", err);
    ++failures;
  }
}

}  // namespace

int main() {
  check_rotation<float>();
  check_rotation<double>();
  check_rigid();
  std::printf("mlsdeform %d.%d.%d consumer: %s\n", MLSDEFORM_VERSION_MAJOR, MLSDEFORM_VERSION_MINOR,
              MLSDEFORM_VERSION_PATCH, failures ? "FAILED" : "ok");
  return failures ? 1 : 0;
}
