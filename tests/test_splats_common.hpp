// The splat tests' independent references, in long double: the real SH basis from its textbook normalisations
// with the Condon-Shortley phase (3DGS's basis, derived here rather than copied from its constants), the colour
// function, rotation matrices and covariances.
#pragma once

#include "tests/support/random.hpp"
#include "tests/support/splats.hpp"

#include <mlsdeform/splats.hpp>

#include <array>
#include <cmath>
#include <cstddef>
#include <numbers>
#include <vector>

namespace splat_test {

using mlsdeform::testing::Matrix3L;
using mlsdeform::testing::Vector3L;
using L = long double;

/// The orthonormal real SH Y_lm of bands 1-3 at unit d, m = -l..l, times (-1)^m (Condon-Shortley).
inline std::array<L, 15> reference_basis(const Vector3L& d) {
  const L x = d(0), y = d(1), z = d(2), pi = std::numbers::pi_v<L>;
  const L n1 = std::sqrt(3 / (4 * pi)), n2 = std::sqrt(15 / pi) / 2, n20 = std::sqrt(5 / pi) / 4,
          n22 = std::sqrt(15 / pi) / 4, n33 = std::sqrt(35 / (2 * pi)) / 4, n32 = std::sqrt(105 / pi) / 2,
          n31 = std::sqrt(21 / (2 * pi)) / 4, n30 = std::sqrt(7 / pi) / 4, n32b = std::sqrt(105 / pi) / 4;
  const std::array<L, 15> y_lm = {n1 * y,
                                  n1 * z,
                                  n1 * x,
                                  n2 * x * y,
                                  n2 * y * z,
                                  n20 * (3 * z * z - 1),
                                  n2 * x * z,
                                  n22 * (x * x - y * y),
                                  n33 * y * (3 * x * x - y * y),
                                  n32 * x * y * z,
                                  n31 * y * (5 * z * z - 1),
                                  n30 * z * (5 * z * z - 3),
                                  n31 * x * (5 * z * z - 1),
                                  n32b * z * (x * x - y * y),
                                  n33 * x * (x * x - 3 * y * y)};
  // m of each entry; (-1)^m for odd m.
  constexpr int m[15] = {-1, 0, 1, -2, -1, 0, 1, 2, -3, -2, -1, 0, 1, 2, 3};
  std::array<L, 15> b;
  for (std::size_t j = 0; j < 15; ++j) b[j] = (m[j] % 2 != 0 ? -1 : 1) * y_lm[j];
  return b;
}

/// Channel `channel`'s colour (bands 1..degree) of f_rest coefficients c (3 x k, channel-major) at d.
template <class T>
L colour(const T* c, int degree, int channel, const Vector3L& d) {
  const int k = (degree + 1) * (degree + 1) - 1;
  const std::array<L, 15> b = reference_basis(d);
  L f = 0;
  for (int j = 0; j < k; ++j) f += L(c[channel * k + j]) * b[std::size_t(j)];
  return f;
}

/// The rotation of a quaternion w x y z of any nonzero length (normalised in long double).
template <class T>
Matrix3L rotation_of(const T* q) {
  Eigen::Quaternion<L> e{L(q[0]), L(q[1]), L(q[2]), L(q[3])};
  e.normalize();
  return e.toRotationMatrix();
}

/// R diag(exp(2 s)) R^T.
template <class T>
Matrix3L covariance(const T* q, const T* log_scales) {
  const Matrix3L R = rotation_of(q);
  Matrix3L D = Matrix3L::Zero();
  for (int k = 0; k < 3; ++k) D(k, k) = std::exp(2 * L(log_scales[k]));
  return R * D * R.transpose();
}

/// A unit quaternion in T, normalised in T (as a frames output would be).
template <class T>
std::array<T, 4> random_unit_quaternion(mlsdeform::testing::Rng& rng) {
  std::array<double, 4> q;
  double n = 0;
  for (double& x : q) {
    x = rng.gaussian<double>();
    n += x * x;
  }
  std::array<T, 4> r;
  for (std::size_t j = 0; j < 4; ++j) r[j] = T(q[j] / std::sqrt(n));
  return r;
}

inline L max_abs(const Matrix3L& m) { return m.cwiseAbs().maxCoeff(); }

/// The f_rest norm of one channel's coefficients (the bound's scale).
template <class T>
L norm(const T* c, int count) {
  L s = 0;
  for (int j = 0; j < count; ++j) s += L(c[j]) * L(c[j]);
  return std::sqrt(s);
}

/// A random splat cloud (tests/support/splats.hpp) in T, with the SplatArrays view the splat functions take.
template <class T>
struct Cloud {
  std::size_t n;
  int degree;
  std::vector<T> rotations, log_scales, sh;
  mlsdeform::SplatArrays<T> arrays() { return {rotations.data(), log_scales.data(), sh.data(), degree}; }
};

template <class T>
Cloud<T> cloud(std::size_t n, std::uint64_t seed, int degree = 3) {
  const mlsdeform::testing::SplatCloud c = mlsdeform::testing::random_splat_cloud(n, seed, degree);
  return {n,
          degree,
          {c.rotations.begin(), c.rotations.end()},
          {c.log_scales.begin(), c.log_scales.end()},
          {c.f_rest.begin(), c.f_rest.end()}};
}

}  // namespace splat_test
