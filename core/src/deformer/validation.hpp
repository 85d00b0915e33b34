// The deformer's input validation: options, rest and moved handles, rest vertices, the affine transform's
// rank condition and coincident point handles. Every check throws std::invalid_argument with a message that
// names the culprit, before anything is changed; the per-frame ones allocate only on error (deform() must
// not allocate).
#pragma once

#include <mlsdeform/deformer.hpp>

#include <Eigen/Core>

#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace mlsdeform::detail {

/// x with 17 significant digits (messages).
std::string num(double x);

/// Coordinates of targets may not exceed this: with |A_j| summing to O(1) (data.hpp, units), the
/// correlation matrix, q* and their intermediate differences then stay finite.
template <class T>
constexpr T coordinate_limit() {
  return std::numeric_limits<T>::max() / 64;
}

void check_options(const Options& o);

/// `what` and `part` name the array in messages (no std::string is built unless there is an error).
template <class T>
void check_points(const Points<T>& p, const char* what, const char* part, T limit);

template <class T>
void check_handles(const Handles<T>& h, const char* what, T limit);

/// Moved handles must match the rest handles one to one.
template <class T>
void check_moved(const Handles<T>& moved, const Handles<T>& rest);

/// Affine MLS needs handles spanning 3D (otherwise G is singular at every vertex): numerical rank of the
/// centred pseudo-handle positions P (local frame), with the usual relative tolerance max(J, 3) eps(T) sigma_1.
template <class T>
void check_affine_rank(const std::vector<Eigen::Vector3d>& P);

/// The singular values (descending) and, if V is not null, the right singular vectors of an m x 3 matrix:
/// one instantiation of Eigen's dynamic-size SVD for the library (affine_rank.cpp), which is slow to compile.
Eigen::Vector3d singular_values(const Eigen::Matrix<double, Eigen::Dynamic, 3>& X, Eigen::Matrix3d* V = nullptr);

/// The tolerance on R of a rigid motion (Deformer::transform_handles): the largest entry of |R^T R - I|,
/// evaluated in T, may be at most 64 eps(T), the bound fit_rotation guarantees for its own results
/// (tests/support/accuracy_bounds.hpp, c_o), so that every rotation the library returns is accepted. An R
/// whose entries are each within c eps of those of an exact rotation Q (R = Q + E) has
/// (R^T R - I)_ij = sum_k (Q_ki E_kj + E_ki Q_kj) + O(eps^2), at most 2 sqrt(3) c eps since a column of Q is a
/// unit vector (sum_k |Q_ki| <= sqrt(3)); evaluating the three products, their sum and the subtraction of I in
/// T adds at most gamma_4 (sum_k |R_ki R_kj| + 1) <= 4 eps. 64 eps thus accepts every R within 17 eps per
/// entry of a rotation. Measured (tests/test_handle_groups.cpp): Eigen's AngleAxis and Quaternion matrices
/// reach 8 eps, a product of two 10 eps, fit_rotation 17 eps (kanatani, svd; rank-deficient H). An accepted R
/// changes lengths by at most 32 eps relative (|R x|^2 = x^T R^T R x), far below a handle's own rounding in
/// a deformation; a matrix scaled by 1 + 33 eps, or any reflection, is refused.
template <class T>
constexpr T rotation_tolerance() {
  return 64 * std::numeric_limits<T>::epsilon();
}

/// The largest entry of |R^T R - I|, evaluated in T (rotation_tolerance).
template <class T>
T orthonormality_error(const Matrix3<T>& R);

/// The rigid motion x -> R (x - pivot) + pivot + t of Deformer::transform_handles: R finite, orthonormal
/// (rotation_tolerance) and proper (det R > 0: not a reflection), t and pivot finite. `what` names the caller.
template <class T>
void check_rigid_motion(const Matrix3<T>& R, const Vector3<T>& t, const Vector3<T>& pivot, const char* what);

/// Pairs (i, j), i < j, of point handles at the same rest position. A vertex there is snapped to one of them,
/// while the map's limit at that position is the mean of their targets: such pairs must keep equal targets.
using CoincidentPairs = std::vector<std::pair<Eigen::Index, Eigen::Index>>;
template <class T>
CoincidentPairs coincident_points(const Points<T>& p);

/// Coincident point handles must be moved together (see coincident_points). Allocates only on error.
template <class T>
void check_coincident(const Handles<T>& moved, const CoincidentPairs& pairs);

}  // namespace mlsdeform::detail
