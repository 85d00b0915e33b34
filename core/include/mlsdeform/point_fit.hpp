// mlsdeform: weighted point-set fits (Umeyama-style), built on fit_rotation.
#pragma once

#include <mlsdeform/rotation.hpp>
#include <mlsdeform/types.hpp>

namespace mlsdeform {

/// x -> scale * rotation * x + translation.
template <class T>
struct SimilarityTransform {
  Matrix3<T> rotation = Matrix3<T>::Identity();
  Vector3<T> translation = Vector3<T>::Zero();
  T scale = T(1);

  Vector3<T> operator()(const Vector3<T>& x) const { return scale * (rotation * x) + translation; }
};

/// The rigid motion minimising sum_i w_i |R p_i + t - q_i|^2 (paper eqs. 1-4; scale is 1).
/// p, q: n x 3 with n >= 1; w: n non-negative weights with a positive sum (empty w means all ones).
/// Throws std::invalid_argument on mismatched sizes, non-finite input, negative weights or a zero weight sum.
template <class T>
SimilarityTransform<T> fit_rigid(const Eigen::Ref<const Points<T>>& p, const Eigen::Ref<const Points<T>>& q,
                                 const Eigen::Ref<const Eigen::Matrix<T, Eigen::Dynamic, 1>>& w,
                                 RotationMethod method = RotationMethod::axis_angle);

/// As fit_rigid, with a uniform scale (paper Sec. 6.1): mu_s = trace(R^T H) / sum_i w_i |phat_i|^2.
/// If all p coincide the scale is 1.
template <class T>
SimilarityTransform<T> fit_similarity(const Eigen::Ref<const Points<T>>& p, const Eigen::Ref<const Points<T>>& q,
                                      const Eigen::Ref<const Eigen::Matrix<T, Eigen::Dynamic, 1>>& w,
                                      RotationMethod method = RotationMethod::axis_angle);

}  // namespace mlsdeform
