// See random.hpp.
#include "tests/support/random.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace mlsdeform::testing {

std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

std::uint64_t Rng::next() { return splitmix64(state_); }

template <class Real>
Real Rng::uniform() {
  constexpr int bits = std::min(std::numeric_limits<Real>::digits, 64);
  return std::ldexp(static_cast<Real>(next() >> (64 - bits)), -bits);
}

template <class Real>
Real Rng::uniform(std::type_identity_t<Real> lo, std::type_identity_t<Real> hi) {
  return lo + (hi - lo) * uniform<Real>();
}

int Rng::integer(int lo, int hi) {
  const auto span = static_cast<std::uint64_t>(hi - lo) + 1;
  return lo + static_cast<int>(next() % span);
}

template <class Real>
Real Rng::gaussian() {
  const double u1 = 1.0 - uniform<double>();  // (0, 1]
  const double u2 = uniform<double>();
  return static_cast<Real>(std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2));
}

template <class Real>
Eigen::Matrix<Real, 3, 1> Rng::unit_vector() {
  for (;;) {
    const Eigen::Matrix<Real, 3, 1> v(gaussian<Real>(), gaussian<Real>(), gaussian<Real>());
    const Real n = v.norm();
    if (n > static_cast<Real>(1e-3L)) return v / n;
  }
}

// Two spellings of one formula, each kept as it was first written so that every seed still gives the same
// bits: long double builds the matrix from the unit quaternion (w, x, y, z) itself (the accuracy suite's
// families); float and double go through Eigen::Quaternion (the benchmarks' matrix sets), whose norm sums
// the components in the order x, y, z, w.
template <class Real>
Eigen::Matrix<Real, 3, 3> Rng::rotation() {
  for (;;) {
    if constexpr (std::is_same_v<Real, long double>) {
      Eigen::Matrix<long double, 4, 1> q(gaussian(), gaussian(), gaussian(), gaussian());
      const long double n = q.norm();
      if (!(n > 1e-3L)) continue;
      q /= n;
      const long double w = q(0), x = q(1), y = q(2), z = q(3);
      Matrix3L R;
      R << 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),  //
          2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),   //
          2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y);
      return R;
    } else {
      Eigen::Quaternion<Real> q(gaussian<Real>(), gaussian<Real>(), gaussian<Real>(), gaussian<Real>());
      const Real n = q.norm();
      if (!(n > static_cast<Real>(1e-3L))) continue;
      q.coeffs() /= n;
      return q.toRotationMatrix();
    }
  }
}

#define MLSDEFORM_RNG_INSTANCE(Real)                                                        \
  template Real Rng::uniform<Real>();                                                       \
  template Real Rng::uniform<Real>(std::type_identity_t<Real>, std::type_identity_t<Real>); \
  template Real Rng::gaussian<Real>();                                                      \
  template Eigen::Matrix<Real, 3, 1> Rng::unit_vector<Real>();                              \
  template Eigen::Matrix<Real, 3, 3> Rng::rotation<Real>();
MLSDEFORM_RNG_INSTANCE(float)
MLSDEFORM_RNG_INSTANCE(double)
MLSDEFORM_RNG_INSTANCE(long double)
#undef MLSDEFORM_RNG_INSTANCE

}  // namespace mlsdeform::testing
