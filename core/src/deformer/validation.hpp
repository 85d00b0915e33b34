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

/// Pairs (i, j), i < j, of point handles at the same rest position. A vertex there is snapped to one of them,
/// while the map's limit at that position is the mean of their targets: such pairs must keep equal targets.
using CoincidentPairs = std::vector<std::pair<Eigen::Index, Eigen::Index>>;
template <class T>
CoincidentPairs coincident_points(const Points<T>& p);

/// Coincident point handles must be moved together (see coincident_points). Allocates only on error.
template <class T>
void check_coincident(const Handles<T>& moved, const CoincidentPairs& pairs);

}  // namespace mlsdeform::detail
