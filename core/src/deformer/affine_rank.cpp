// check_affine_rank and singular_values (validation.hpp), apart from the other checks: Eigen's SVD is slow to
// compile, and this is its one instantiation.
#include "core/src/deformer/validation.hpp"

#include <Eigen/QR>
#include <Eigen/SVD>

#include <algorithm>
#include <stdexcept>
#include <string>

namespace mlsdeform::detail {

using Vec3d = Eigen::Vector3d;

template <class T>
void check_affine_rank(const std::vector<Vec3d>& P) {
  const std::size_t J = P.size();
  if (J < 4)
    throw std::invalid_argument(
        "Deformer: the affine transform needs handles spanning 3D (at least four non-coplanar "
        "points, segment end points included); got " +
        std::to_string(J));
  Vec3d mean = Vec3d::Zero();
  for (const Vec3d& p : P) mean += p;
  mean /= double(J);
  Eigen::Matrix<double, Eigen::Dynamic, 3> M(static_cast<Eigen::Index>(J), 3);
  for (std::size_t j = 0; j < J; ++j) M.row(static_cast<Eigen::Index>(j)) = (P[j] - mean).transpose();
  const Vec3d sv = singular_values(M);
  const double tol = double(std::max<std::size_t>(J, 3)) * double(std::numeric_limits<T>::epsilon()) * sv[0];
  if (!(sv[2] > tol))
    throw std::invalid_argument("Deformer: the affine transform needs handles spanning 3D, but the handle points are " +
                                std::string(sv[1] > tol ? "coplanar" : "collinear") + " (singular values " +
                                num(sv[0]) + ", " + num(sv[1]) + ", " + num(sv[2]) + ")");
}

Eigen::Vector3d singular_values(const Eigen::Matrix<double, Eigen::Dynamic, 3>& X, Eigen::Matrix3d* V) {
  // X = Q R (Householder, backward stable), so X and R share their singular values and right singular
  // vectors; the 3 x 3 R's SVD is a fixed-size instantiation, much quicker to compile than a dynamic one.
  Eigen::Matrix3d R = Eigen::Matrix3d::Zero();
  if (X.rows() >= 3) {
    const Eigen::HouseholderQR<Eigen::Matrix<double, Eigen::Dynamic, 3>> qr(X);
    R = qr.matrixQR().topRows<3>().triangularView<Eigen::Upper>();
  } else {
    R.topRows(X.rows()) = X;
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d, Eigen::NoQRPreconditioner> svd(R, V ? Eigen::ComputeFullV : 0);
  if (V) *V = svd.matrixV();
  return svd.singularValues();
}

template void check_affine_rank<float>(const std::vector<Vec3d>&);
template void check_affine_rank<double>(const std::vector<Vec3d>&);

}  // namespace mlsdeform::detail
