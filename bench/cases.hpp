// The random correlation matrices of the rotation-fit benchmark: H = sum_i w_i qhat_i phat_i^T (paper eq. 6,
// column convention) from weighted, noisy point sets moved by uniformly random rotations, a share of them
// mirrored so that det H < 0. Generated once per process, in double; the float set is the same matrices
// rounded to float. Deterministic for a given seed (tests/support's Rng, no std:: distributions).
#pragma once

#include "tests/support/random.hpp"

#include <mlsdeform/rotation.hpp>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <vector>

namespace bench {

/// The shared generator (tests/support/random.hpp: SplitMix64), with variates in double.
using Rng = mlsdeform::testing::Rng;

/// The benchmark's seed (printed in the context; a fixed date).
inline constexpr std::uint64_t kCaseSeed = 20261121;

/// Weighted centroids (eq. 2) and H = sum w qhat phat^T (eq. 6) of n points, in double.
inline Eigen::Matrix3d correlation(const Eigen::Matrix3Xd& p, const Eigen::Matrix3Xd& q, const Eigen::VectorXd& w) {
  const double W = w.sum();
  const Eigen::Vector3d p_star = p * w / W, q_star = q * w / W;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (Eigen::Index i = 0; i < p.cols(); ++i) H += w(i) * (q.col(i) - q_star) * (p.col(i) - p_star).transpose();
  return H;
}

/// One case: 3 to 12 points with anisotropic spread (1 in 10 flat: rank-2 H up to noise), inverse-square
/// distance weights to a random evaluation point as in MLS (Sec. 3), a uniform random rotation, Gaussian
/// noise of 10^-4 .. 10^-0.5 of the spread (log-uniform), and 1 in 5 mirrored, q = R diag(1, 1, -1) p,
/// which makes det H < 0.
inline Eigen::Matrix3d random_correlation(Rng& rng) {
  const int n = rng.integer(3, 12);
  const Eigen::Vector3d spread(rng.uniform<double>(0.05, 1.0), rng.uniform<double>(0.05, 1.0),
                               rng.uniform<double>() < 0.1 ? 0.0 : rng.uniform<double>(0.05, 1.0));
  const Eigen::Matrix3d frame = rng.rotation<double>();
  const Eigen::Vector3d v(rng.gaussian<double>(), rng.gaussian<double>(), rng.gaussian<double>());
  Eigen::Matrix3Xd p(3, n), q(3, n);
  Eigen::VectorXd w(n);
  Eigen::Matrix3d R = rng.rotation<double>();
  if (rng.uniform<double>() < 0.2) R = R * Eigen::Vector3d(1, 1, -1).asDiagonal();
  const double noise = std::pow(10.0, rng.uniform<double>(-4.0, -0.5)) * spread.maxCoeff();
  for (int i = 0; i < n; ++i) {
    p.col(i) = frame * Eigen::Vector3d(spread(0) * rng.gaussian<double>(), spread(1) * rng.gaussian<double>(),
                                       spread(2) * rng.gaussian<double>());
    q.col(i) =
        R * p.col(i) + noise * Eigen::Vector3d(rng.gaussian<double>(), rng.gaussian<double>(), rng.gaussian<double>());
    w(i) = 1.0 / ((p.col(i) - v).squaredNorm() + 1e-3);
  }
  return correlation(p, q, w);
}

/// The shared set: the same matrices in double and rounded to float.
struct CaseSet {
  std::vector<Eigen::Matrix3d> H_double;
  std::vector<Eigen::Matrix3f> H_float;
  std::size_t det_negative = 0;  ///< cases with det H < 0 (in double)

  template <class T>
  const std::vector<mlsdeform::Matrix3<T>>& get() const {
    if constexpr (sizeof(T) == sizeof(float))
      return H_float;
    else
      return H_double;
  }
};

/// The generator of case `index`: its own stream, started at a hashed state so that cases can be made in
/// any order (and in parallel) and streams do not overlap in practice (~200 draws per case in 2^64).
inline Rng case_rng(std::uint64_t seed, std::uint64_t index) {
  Rng mixer(seed ^ (index * 0xd1b54a32d192ed03ULL));
  return Rng(mixer.next());
}

/// Case `index` of the set for `seed` (deterministic).
inline Eigen::Matrix3d make_case(std::uint64_t seed, std::uint64_t index) {
  Rng rng = case_rng(seed, index);
  return random_correlation(rng);
}

/// Case `index` of the Gaussian set for `seed`: entries iid N(0, 1), the stress case of noisy registration
/// (det H of either sign, singular values spread as a random matrix's).
inline Eigen::Matrix3d make_gaussian_case(std::uint64_t seed, std::uint64_t index) {
  Rng rng = case_rng(seed ^ 0x9e3779b97f4a7c15ULL, index);
  Eigen::Matrix3d H;
  for (int e = 0; e < 9; ++e) H(e / 3, e % 3) = rng.gaussian<double>();
  return H;
}

/// A point set moved by a rotation of angle pi - delta about a random axis (the near-half-turn sweep of the
/// error plot): 8 points, isotropic spread, inverse-square weights, no noise (so that the optimum is the
/// generating rotation, up to the rounding of H, and its distance from pi is delta).
inline Eigen::Matrix3d near_half_turn_correlation(Rng& rng, double delta) {
  const int n = 8;
  const Eigen::Vector3d v(rng.gaussian<double>(), rng.gaussian<double>(), rng.gaussian<double>());
  const Eigen::Matrix3d R = Eigen::AngleAxisd(std::numbers::pi - delta, rng.unit_vector<double>()).toRotationMatrix();
  Eigen::Matrix3Xd p(3, n), q(3, n);
  Eigen::VectorXd w(n);
  for (int i = 0; i < n; ++i) {
    p.col(i) = Eigen::Vector3d(rng.gaussian<double>(), rng.gaussian<double>(), rng.gaussian<double>());
    q.col(i) = R * p.col(i);
    w(i) = 1.0 / ((p.col(i) - v).squaredNorm() + 1e-3);
  }
  return correlation(p, q, w);
}

}  // namespace bench
