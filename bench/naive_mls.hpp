// The baseline of the deformation benchmarks: as-rigid-as-possible MLS written the way a user would write it
// from the paper (Sec. 3-5, Algorithm 1) with Eigen's SVD, one vertex at a time, recomputing everything per
// frame: weights (w_i = |p_i - v|^-u, eq. 1), weighted centroids (eq. 2), the correlation matrix (eq. 6),
// its Jacobi SVD with Umeyama's reflection fix, and v' = R (v - p*) + q* (Algorithm 1, steps 8-10).
//
// Two courtesies a careful user would also extend to this loop, so that the comparison is not inflated:
// u = 2 takes 1 / d^2 instead of std::pow, and a vertex on a handle maps to that handle's target
// (the paper's interpolation property, f(p_i) = q_i) instead of dividing by zero.
//
// The benchmarks check it, like the Deformer, against the test-support library's reference deformer
// (tests/support/mls_reference.hpp: sampled_reference, deform_tolerance).
#pragma once

#include <mlsdeform/types.hpp>

#include <Eigen/Core>
#include <Eigen/SVD>

#include <cmath>
#include <vector>

namespace bench {

template <class T>
void naive_mls_deform(const mlsdeform::Points<T>& vertices, const mlsdeform::Points<T>& p,
                      const mlsdeform::Points<T>& q, mlsdeform::Points<T>& out, double u = 2.0) {
  using Vec3 = Eigen::Matrix<T, 3, 1>;
  using Mat3 = Eigen::Matrix<T, 3, 3>;
  const Eigen::Index n = vertices.rows(), k = p.rows();
  out.resize(n, 3);
  std::vector<T> w(static_cast<std::size_t>(k));
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 v = vertices.row(i).transpose();
    // Weights (eq. 1); a vertex on a handle goes to its target.
    Eigen::Index on_handle = -1;
    T W = 0;
    for (Eigen::Index j = 0; j < k; ++j) {
      const T d2 = (p.row(j).transpose() - v).squaredNorm();
      if (d2 == T(0)) {
        on_handle = j;
        break;
      }
      w[static_cast<std::size_t>(j)] = u == 2.0 ? T(1) / d2 : T(std::pow(d2, T(-u / 2)));
      W += w[static_cast<std::size_t>(j)];
    }
    if (on_handle >= 0) {
      out.row(i) = q.row(on_handle);
      continue;
    }
    // Weighted centroids (eq. 2).
    Vec3 p_star = Vec3::Zero(), q_star = Vec3::Zero();
    for (Eigen::Index j = 0; j < k; ++j) {
      p_star += w[static_cast<std::size_t>(j)] * p.row(j).transpose();
      q_star += w[static_cast<std::size_t>(j)] * q.row(j).transpose();
    }
    p_star /= W;
    q_star /= W;
    // Correlation matrix (eq. 6, column convention: H = sum w qhat phat^T).
    Mat3 H = Mat3::Zero();
    for (Eigen::Index j = 0; j < k; ++j)
      H += w[static_cast<std::size_t>(j)] * (q.row(j).transpose() - q_star) *
           (p.row(j).transpose() - p_star).transpose();
    // R = U diag(1, 1, det(U V^T)) V^T (Arun et al. 1987, Umeyama 1991).
    Eigen::JacobiSVD<Mat3> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Mat3 D = Mat3::Identity();
    D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < T(0) ? T(-1) : T(1);
    const Mat3 R = svd.matrixU() * D * svd.matrixV().transpose();
    out.row(i) = (R * (v - p_star) + q_star).transpose();
  }
}

}  // namespace bench
