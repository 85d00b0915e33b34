// A splat's frame in double: quaternions (w x y z), 3 x 3 matrices (row-major) and the affine map of its
// covariance, decomposed again into axes and scales.
#pragma once

#include <array>
#include <cstddef>

namespace mlsdeform::detail {

using Quaternion = std::array<double, 4>;  // w x y z
using Matrix3 = std::array<double, 9>;     // row-major

template <class T>
Matrix3 to_double(const T* m) {
  Matrix3 r;
  for (std::size_t j = 0; j < 9; ++j) r[j] = double(m[j]);
  return r;
}

double determinant(const Matrix3& m);

Quaternion normalised(const Quaternion& q);

/// The Hamilton product a * b: the rotation b, then a.
Quaternion product(const Quaternion& a, const Quaternion& b);

/// The rotation matrix of a unit quaternion.
Matrix3 rotation_matrix(const Quaternion& q);

struct Decomposed {
  Quaternion rotation;  // not normalised (the caller rounds it to T normalised)
  std::array<double, 3> log_scales;
};

/// Sigma' = M Sigma M^T for Sigma = R(q) diag(exp(2 log_scales)) R(q)^T, decomposed again: the eigenvectors of
/// Sigma' (Eigen's symmetric solver) matched to the images M R e_k of the old axes by the permutation that
/// aligns them best, each signed towards its image, the least aligned one flipped if the frame is left-handed;
/// the log scales are log(sqrt(eigenvalue)) of the matched axes (an eigenvalue that rounding made <= 0, possible
/// only where Sigma' is conditioned beyond 1 / epsilon, is taken as the least positive double). The quaternion
/// is the one of the sign nearer q (dot >= 0), so a mild M changes rot_* little.
Decomposed transform_covariance(const Matrix3& M, const Quaternion& q, const std::array<double, 3>& log_scales);

struct Polar {
  Matrix3 rotation;  // det +1
  bool mirror;       // M reflects: its orthogonal polar factor is -rotation
};

/// M = Q P (Q orthogonal, P symmetric positive definite), from M's SVD U S V^T: Q = U V^T. Q is the rotation
/// nearest M (Frobenius norm); a reflecting M gives rotation = -Q and mirror.
Polar polar_rotation(const Matrix3& M);

}  // namespace mlsdeform::detail
