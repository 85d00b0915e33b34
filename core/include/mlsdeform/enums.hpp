// mlsdeform: the enumerations shared by the public API and the kernels' typed contract (kernels/contract.hpp),
// in a header of their own so that the per-ISA kernel objects see them without Eigen.
#pragma once

namespace mlsdeform {

/// The rotation solvers. All return the same optimum (where it is unique) to within rounding.
enum class RotationMethod {
  /// The paper's method (Sec. 4.3-4.6): largest root of the depressed quartic (13), rotation axis from the
  /// 3x3 system (14) (generalised to the best-conditioned of the four equivalent systems, Shuster's
  /// sequential rotations, so that it stays exact near 180 degrees), sine and cosine from (15).
  axis_angle,
  /// Horn 1987: unit quaternion = eigenvector of the largest eigenvalue of the symmetric 4x4 matrix.
  horn_quaternion,
  /// Horn, Hilden, Negahdaripour 1988: R = H (H^T H)^{-1/2}, with the correction for det H < 0 (and rank 2).
  horn_matrix,
  /// Kanatani 1994: R = V diag(1, 1, det(V U^T)) U^T from the SVD of the correlation matrix
  /// K = sum_i w_i phat_i qhat_i^T = H^T (Kanatani's own orientation of the data).
  kanatani,
  /// Arun, Huang, Blostein 1987 (SVD, R = U V^T) with Umeyama's 1991 reflection fix diag(1, 1, det(U V^T)).
  svd,
};

/// The transform each vertex gets (paper Sec. 4 rigid, Sec. 6.1 similarity; affine as in Schaefer et al. 2006).
enum class Transform { rigid, similarity, affine };

}  // namespace mlsdeform
