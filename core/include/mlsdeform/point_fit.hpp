// mlsdeform: weighted point-set fits (Umeyama-style), built on fit_rotation.
#pragma once

#include <mlsdeform/rotation.hpp>
#include <mlsdeform/types.hpp>

#include <stdexcept>
#include <string>
#include <type_traits>

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
/// Throws std::invalid_argument on mismatched sizes, non-finite input, negative weights or a zero weight sum,
/// and where the translation (or fit_similarity's scale) is beyond T's range. Any scale of p and q works (the
/// fit runs on them scaled by powers of two: point_fit.cpp); scaling both by 2^k leaves rotation and scale
/// unchanged and scales the translation by 2^k, bitwise (rounded once more only in T's subnormal range).
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

namespace detail {
/// p (n x 3, any storage order or expression) as Points<T>; std::invalid_argument if it has not 3 columns.
template <class T, class P>
Points<T> as_points(const Eigen::MatrixBase<P>& p, const char* fn, const char* what) {
  if (p.cols() != 3)
    throw std::invalid_argument(std::string(fn) + ": " + what + " must have 3 columns (got " +
                                std::to_string(p.cols()) + ")");
  return Points<T>(p);
}
}  // namespace detail

/// fit_rigid and fit_similarity of any Eigen arguments (n x 3 matrices in any storage order, expressions, and a
/// vector of weights) with the same float or double entries: T is deduced, no explicit fit_rigid<T> needed.
template <class P, class Q, class W>
SimilarityTransform<typename P::Scalar> fit_rigid(const Eigen::MatrixBase<P>& p, const Eigen::MatrixBase<Q>& q,
                                                  const Eigen::MatrixBase<W>& w,
                                                  RotationMethod method = RotationMethod::axis_angle) {
  using T = typename P::Scalar;
  static_assert(std::is_same_v<T, typename Q::Scalar> && std::is_same_v<T, typename W::Scalar>,
                "fit_rigid: p, q and w must have the same scalar type");
  return fit_rigid<T>(detail::as_points<T>(p, "fit_rigid", "p"), detail::as_points<T>(q, "fit_rigid", "q"),
                      Eigen::Matrix<T, Eigen::Dynamic, 1>(w.reshaped()), method);
}

template <class P, class Q, class W>
SimilarityTransform<typename P::Scalar> fit_similarity(const Eigen::MatrixBase<P>& p, const Eigen::MatrixBase<Q>& q,
                                                       const Eigen::MatrixBase<W>& w,
                                                       RotationMethod method = RotationMethod::axis_angle) {
  using T = typename P::Scalar;
  static_assert(std::is_same_v<T, typename Q::Scalar> && std::is_same_v<T, typename W::Scalar>,
                "fit_similarity: p, q and w must have the same scalar type");
  return fit_similarity<T>(detail::as_points<T>(p, "fit_similarity", "p"),
                           detail::as_points<T>(q, "fit_similarity", "q"),
                           Eigen::Matrix<T, Eigen::Dynamic, 1>(w.reshaped()), method);
}

}  // namespace mlsdeform
