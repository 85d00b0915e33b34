// The baseline of the deformation benchmarks: as-rigid-as-possible MLS written the way a user would write it
// from the paper (Sec. 3-5, Algorithm 1) with Eigen's SVD, one vertex at a time, recomputing everything per
// frame: weights (w_i = |p_i - v|^-u, eq. 1), weighted centroids (eq. 2), the correlation matrix (eq. 6),
// its Jacobi SVD with Umeyama's reflection fix, and v' = R (v - p*) + q* (Algorithm 1, steps 8-10).
//
// Two courtesies a careful user would also extend to this loop, so that the comparison is not inflated:
// u = 2 takes 1 / d^2 instead of std::pow, and a vertex on a handle maps to that handle's target
// (the paper's interpolation property, f(p_i) = q_i) instead of dividing by zero.
//
// naive_reference() is the same formula in double (long-double accumulation), with what the deformation
// checks need per vertex: the condition number of its rotation fit and the size of the sums behind H.
#pragma once

#include <mlsdeform/types.hpp>

#include <Eigen/Core>
#include <Eigen/SVD>

#include <cmath>
#include <limits>
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
      H += w[static_cast<std::size_t>(j)] * (q.row(j).transpose() - q_star) * (p.row(j).transpose() - p_star).transpose();
    // R = U diag(1, 1, det(U V^T)) V^T (Arun et al. 1987, Umeyama 1991).
    Eigen::JacobiSVD<Mat3> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Mat3 D = Mat3::Identity();
    D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < T(0) ? T(-1) : T(1);
    const Mat3 R = svd.matrixU() * D * svd.matrixV().transpose();
    out.row(i) = (R * (v - p_star) + q_star).transpose();
  }
}

/// The naive formula in double with long-double sums, per vertex: the deformed position, and the data of
/// the tolerance a float or double implementation is held to (deform_tolerance below).
struct NaiveReference {
  mlsdeform::Points<double> out;
  std::vector<double> kappa;        ///< s1 / (s2 + d s3) of the vertex's H (+inf: not unique; 0: on a handle)
  std::vector<double> sum_scale;    ///< sum_j w_j |phat_j| (|qhat_j| + |q_j|) / ||H||_F: cancellation in H
  std::vector<double> arm;          ///< |v - p*|
  double diameter = 0;              ///< of the rest vertices' bounding box
  Eigen::Index handles = 0;
};

inline NaiveReference naive_reference(const mlsdeform::Points<double>& vertices, const mlsdeform::Points<double>& p,
                                      const mlsdeform::Points<double>& q, const std::vector<Eigen::Index>& rows,
                                      double u = 2.0) {
  using Vec3 = Eigen::Matrix<long double, 3, 1>;
  using Mat3 = Eigen::Matrix<long double, 3, 3>;
  const Eigen::Index k = p.rows();
  NaiveReference r;
  const std::size_t m = rows.size();
  r.out.resize(static_cast<Eigen::Index>(m), 3);
  r.kappa.assign(m, 0);
  r.sum_scale.assign(m, 0);
  r.arm.assign(m, 0);
  r.diameter = (vertices.colwise().maxCoeff() - vertices.colwise().minCoeff()).norm();
  r.handles = k;
  std::vector<long double> w(static_cast<std::size_t>(k));
  for (std::size_t s = 0; s < m; ++s) {
    const Eigen::Index i = rows[s];
    const Vec3 v = vertices.row(i).transpose().cast<long double>();
    Eigen::Index on_handle = -1;
    long double W = 0;
    for (Eigen::Index j = 0; j < k; ++j) {
      const long double d2 = (p.row(j).transpose().cast<long double>() - v).squaredNorm();
      if (d2 == 0) {
        on_handle = j;
        break;
      }
      w[static_cast<std::size_t>(j)] = std::pow(d2, -static_cast<long double>(u) / 2);
      W += w[static_cast<std::size_t>(j)];
    }
    if (on_handle >= 0) {
      r.out.row(static_cast<Eigen::Index>(s)) = q.row(on_handle);
      continue;
    }
    Vec3 p_star = Vec3::Zero(), q_star = Vec3::Zero();
    for (Eigen::Index j = 0; j < k; ++j) {
      p_star += w[static_cast<std::size_t>(j)] * p.row(j).transpose().cast<long double>();
      q_star += w[static_cast<std::size_t>(j)] * q.row(j).transpose().cast<long double>();
    }
    p_star /= W;
    q_star /= W;
    Mat3 H = Mat3::Zero();
    long double scale = 0;
    for (Eigen::Index j = 0; j < k; ++j) {
      const Vec3 pj = p.row(j).transpose().cast<long double>(), qj = q.row(j).transpose().cast<long double>();
      const Vec3 ph = pj - p_star, qh = qj - q_star;
      H += w[static_cast<std::size_t>(j)] * qh * ph.transpose();
      scale += w[static_cast<std::size_t>(j)] * ph.norm() * (qh.norm() + qj.norm());
    }
    Eigen::JacobiSVD<Mat3> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const long double d = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0L : 1.0L;
    Mat3 D = Mat3::Identity();
    D(2, 2) = d;
    const Mat3 R = svd.matrixU() * D * svd.matrixV().transpose();
    r.out.row(static_cast<Eigen::Index>(s)) = (R * (v - p_star) + q_star).transpose().cast<double>();
    const auto sv = svd.singularValues();
    const long double gap = sv(1) + d * sv(2);
    r.kappa[s] = gap > 0 ? static_cast<double>(sv(0) / gap) : std::numeric_limits<double>::infinity();
    const long double Hn = H.norm();
    r.sum_scale[s] = Hn > 0 ? static_cast<double>(scale / Hn) : std::numeric_limits<double>::infinity();
    r.arm[s] = static_cast<double>((v - p_star).norm());
  }
  return r;
}

/// How far a float or double deformation may be from the reference at sample s, with c = 32 as in
/// bench/reference.hpp. A backward-stable fit of a computed H turns R by at most the H error over the
/// gap, i.e. (relative H error) sqrt(3) kappa; H is a k-term sum whose rounding is at most (c + k) eps times
/// the sum of the terms' sizes (sum_scale ||H||, either Sigma w qhat phat^T or the deformer's Sigma A q^T
/// form), so R turns by (c + k) eps sum_scale (2 + sqrt(3) kappa), moving v' by that times the arm |v - p*|;
/// the centroids and the final sum add c eps times the model's size. An implementation with a real bug
/// misses by O(1) of the arm, far outside this.
inline double deform_tolerance(const NaiveReference& r, std::size_t s, double eps) {
  constexpr double c = 32;
  if (r.kappa[s] == 0) return c * eps * r.diameter;  // on a handle
  if (!std::isfinite(r.kappa[s]) || !std::isfinite(r.sum_scale[s])) return std::numeric_limits<double>::infinity();
  const double turn = (c + static_cast<double>(r.handles)) * eps * r.sum_scale[s] * (2 + std::sqrt(3.0) * r.kappa[s]);
  return c * eps * r.diameter + std::min(turn, 2.0) * r.arm[s];
}

}  // namespace bench
