// The session's moved handles (deformer.hpp: targets, set_point_target, set_segment_target,
// transform_handles), and the centring point of a frame's targets that the kernels receive.
#pragma once

#include <mlsdeform/deformer.hpp>

#include <span>

namespace mlsdeform::detail {

/// The centring point c of the correlation matrix, in the local frame: the mean of the targets q_j 2^-e
/// (`local_scale` = 2^-e), summed in pseudo-handle order in T, each term also divided by 2^m >= J so that
/// the sum cannot overflow (in the normal range those scalings are exact: the same bits as the plain mean of
/// the q_j, times 2^-e). Throws std::invalid_argument for a target beyond `limit` (data.hpp, Units).
template <class T>
Vector3<T> local_target_centre(const Handles<T>& q, T local_scale, T limit);

/// Deformer::set_point_target and set_segment_target on the session's targets: std::out_of_range for an
/// index out of range, std::invalid_argument for a non-finite or too large coordinate; nothing changed then.
template <class T>
void set_point_target(Handles<T>& targets, Eigen::Index i, const Vector3<T>& target);
template <class T>
void set_segment_target(Handles<T>& targets, Eigen::Index i, const Vector3<T>& a, const Vector3<T>& b);

/// Deformer::transform_handles: the targets of the given handles become the images of their `rest`
/// positions under x -> R (x - pivot) + pivot + t, computed as deformer.hpp documents; strong guarantee.
template <class T>
void transform_targets(Handles<T>& targets, const Handles<T>& rest, std::span<const Eigen::Index> point_indices,
                       std::span<const Eigen::Index> segment_indices, const Matrix3<T>& R, const Vector3<T>& t,
                       const Vector3<T>& pivot);

}  // namespace mlsdeform::detail
