// Random numbers of the tests and benchmarks: one generator (SplitMix64) with variates in long double (the
// accuracy suite's case families) or double (the benchmarks' matrix sets and vertex boxes), and the
// std::mt19937_64 helpers of the deformer tests (random_vector, random_rotation, random_points), kept on that
// engine so that every test's seed still gives the cases it always gave. No Catch2: the benchmarks use it.
#pragma once

#include <mlsdeform/types.hpp>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <random>
#include <type_traits>

namespace mlsdeform::testing {

using Matrix3L = Eigen::Matrix<long double, 3, 3>;
using Vector3L = Eigen::Matrix<long double, 3, 1>;

/// One step of SplitMix64 (Steele, Lea, Flood 2014): advances `state`, returns the next 64 random bits. Also
/// a hash of the state (rotation_cases.cpp derives each case's stream from it).
std::uint64_t splitmix64(std::uint64_t& state);

/// SplitMix64: self-contained, so that a seed means the same numbers with any
/// standard library. Variates in Real = long double (the default) or double; instantiated for float, double
/// and long double (random.cpp).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next();
  /// In [0, 1), as many random bits as Real's significand holds (64 for x86 long double, 53 for double).
  template <class Real = long double>
  Real uniform();
  /// In [lo, hi).
  template <class Real = long double>
  Real uniform(std::type_identity_t<Real> lo, std::type_identity_t<Real> hi);
  int integer(int lo, int hi);  ///< in [lo, hi], inclusive
  /// Standard normal (Box-Muller, computed in double whatever Real: the variates are data, not reference
  /// values, and double's log/cos are several times faster than long double's).
  template <class Real = long double>
  Real gaussian();
  /// Uniform on the sphere (a normalised Gaussian vector).
  template <class Real = long double>
  Eigen::Matrix<Real, 3, 1> unit_vector();
  /// Uniform on SO(3) (a normalised Gaussian quaternion).
  template <class Real = long double>
  Eigen::Matrix<Real, 3, 3> rotation();

 private:
  std::uint64_t state_;
};

// ---------------------------------------------------------------------------------------------------------
// std::mt19937_64 helpers (the deformer tests' scenes)
// ---------------------------------------------------------------------------------------------------------

/// Uniform in [lo, hi)^3.
inline Eigen::Vector3d random_vector(std::mt19937_64& g, double lo = -1, double hi = 1) {
  std::uniform_real_distribution<double> d(lo, hi);
  return Eigen::Vector3d(d(g), d(g), d(g));
}

/// Uniform on SO(3) (a normalised Gaussian quaternion).
inline Eigen::Matrix3d random_rotation(std::mt19937_64& g) {
  std::normal_distribution<double> n;
  Eigen::Quaterniond q(n(g), n(g), n(g), n(g));
  q.normalize();
  return q.toRotationMatrix();
}

/// n rows uniform in [lo, hi)^3 (drawn in double, rounded to T).
template <class T>
Points<T> random_points(std::mt19937_64& g, Eigen::Index n, double lo = -1, double hi = 1) {
  Points<T> p(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) p.row(i) = random_vector(g, lo, hi).cast<T>().transpose();
  return p;
}

/// The rotation by `angle` about `axis` (normalised here), in double.
inline Eigen::Matrix3d rotation_about(const Eigen::Vector3d& axis, double angle) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

}  // namespace mlsdeform::testing
