#include "core/src/splats/covariance.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace mlsdeform::detail {

namespace {

using Mat = Eigen::Matrix3d;

Mat to_eigen(const Matrix3& m) {
  Mat r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = m[std::size_t(3 * i + j)];
  return r;
}

Matrix3 from_eigen(const Mat& m) {
  Matrix3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r[std::size_t(3 * i + j)] = m(i, j);
  return r;
}

}  // namespace

double determinant(const Matrix3& m) {
  return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) + m[2] * (m[3] * m[7] - m[4] * m[6]);
}

Quaternion normalised(const Quaternion& q) {
  const double length = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  return {q[0] / length, q[1] / length, q[2] / length, q[3] / length};
}

Quaternion product(const Quaternion& a, const Quaternion& b) {
  return {a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3], a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
          a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1], a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]};
}

Matrix3 rotation_matrix(const Quaternion& q) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  return {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
          2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
          2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
}

Decomposed transform_covariance(const Matrix3& M, const Quaternion& q, const std::array<double, 3>& log_scales) {
  // A = M R S: Sigma' = A A^T, symmetric by construction; column k of A is the image of the old axis k.
  const Mat R = to_eigen(rotation_matrix(normalised(q)));
  Mat A = to_eigen(M) * R;
  for (int k = 0; k < 3; ++k) A.col(k) *= std::exp(log_scales[std::size_t(k)]);
  const Eigen::SelfAdjointEigenSolver<Mat> eigen(A * A.transpose());
  const Mat& V = eigen.eigenvectors();
  // alignment(e, k): |cos| between eigenvector e and the image of old axis k.
  Mat alignment;
  for (int k = 0; k < 3; ++k) {
    const double length = A.col(k).norm();
    for (int e = 0; e < 3; ++e) alignment(e, k) = std::abs(V.col(e).dot(A.col(k))) / length;
  }
  int perm[3] = {0, 1, 2}, best[3] = {0, 1, 2};
  double best_score = -1;
  do {
    const double score = alignment(perm[0], 0) + alignment(perm[1], 1) + alignment(perm[2], 2);
    if (score > best_score) {
      best_score = score;
      std::copy(perm, perm + 3, best);
    }
  } while (std::next_permutation(perm, perm + 3));
  Mat U;
  Decomposed d{};
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d v = V.col(best[k]);
    U.col(k) = v.dot(A.col(k)) < 0 ? Eigen::Vector3d(-v) : v;
    const double lambda = std::max(eigen.eigenvalues()(best[k]), std::numeric_limits<double>::min());
    d.log_scales[std::size_t(k)] = 0.5 * std::log(lambda);
  }
  if (U.determinant() < 0) {  // a rotation's frame is right-handed: flip the axis least tied to its image
    int least = 0;
    for (int k = 1; k < 3; ++k)
      if (alignment(best[k], k) < alignment(best[least], least)) least = k;
    U.col(least) = -U.col(least);
  }
  const Eigen::Quaterniond e(U);
  d.rotation = {e.w(), e.x(), e.y(), e.z()};
  if (d.rotation[0] * q[0] + d.rotation[1] * q[1] + d.rotation[2] * q[2] + d.rotation[3] * q[3] < 0)
    for (double& c : d.rotation) c = -c;
  return d;
}

Polar polar_rotation(const Matrix3& M) {
  const Eigen::JacobiSVD<Mat> svd(to_eigen(M), Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Mat Q = svd.matrixU() * svd.matrixV().transpose();
  const bool mirror = Q.determinant() < 0;
  return {from_eigen(mirror ? Mat(-Q) : Q), mirror};
}

}  // namespace mlsdeform::detail
