// Centroids::rbf (paper Sec. 7-8, Fig. 8): q* = g(p*) instead of the weighted centroid of the targets, with
// g: R^3 -> R^3 the radial-basis interpolant of the pseudo-handles, g(p_j) = q_j. The kernel is the
// biharmonic phi(r) = r with a linear polynomial (the polyharmonic spline of 3D that minimises the thin-plate
// energy), exact for affine maps of the handles. It was chosen over the triharmonic r^3 (Botsch & Kobbelt
// 2005, the RBF deformation the paper cites) by measurement, rbf_centroids.cpp says with which numbers.
//
// g is linear in the targets, so for each vertex q* = sum_j beta_j q_j with weights beta(p*) that depend on
// the rest pose only: the precomputation stores beta in the table where plain MLS stores omega (data.hpp), and
// the per-frame kernels are the same. With M = [[Phi, Q], [Q^T, 0]] (Phi_ij = phi(|p_i - p_j|), Q = [1, the
// centres' coordinates]), g(x) = [phi(|x - p_j|)_j; 1; x]^T M^-1 [q; 0], so beta = the first J entries of
// M^-1 [phi(|p* - p_j|)_j; 1; x] (M is symmetric). The polynomial's linear part is taken in the affine hull of
// the centres (an orthonormal basis of their span, of dimension 0 to 3), where p* always lies: M is then
// nonsingular for distinct centres, whatever their number or configuration. Pseudo-handles at one rest
// position share a centre, which takes the first one's target.
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>

#include <cstddef>
#include <vector>

namespace mlsdeform::detail {

/// The radial kernel phi of g: the polyharmonic splines of 3D with a linear polynomial, r (biharmonic) or
/// r^3 (triharmonic). Both are homogeneous, so beta does not depend on the local frame's scale.
enum class RbfKernel { r, r3 };

inline double phi(RbfKernel kernel, double r) { return kernel == RbfKernel::r ? r : r * r * r; }

/// The kernel of Centroids::rbf: r unless set_rbf_kernel chose another. A measurement switch, not an option
/// (bench_quality --centroids compares the two, the tests cover both): it is read when a Deformer is
/// constructed, is process-wide and thread-safe; restore it after use (ScopedRbfKernel).
RbfKernel rbf_kernel();
void set_rbf_kernel(RbfKernel kernel);

/// Sets the kernel for its lifetime and restores the previous one.
class ScopedRbfKernel {
 public:
  explicit ScopedRbfKernel(RbfKernel kernel) : previous_(rbf_kernel()) { set_rbf_kernel(kernel); }
  ~ScopedRbfKernel() { set_rbf_kernel(previous_); }
  ScopedRbfKernel(const ScopedRbfKernel&) = delete;
  ScopedRbfKernel& operator=(const ScopedRbfKernel&) = delete;

 private:
  RbfKernel previous_;
};

class RbfCentroids {
 public:
  /// P: the pseudo-handles' rest positions (local frame). Throws std::invalid_argument when the interpolant's
  /// matrix is too ill-conditioned to trust (handles nearly coincident: rcond below 1e-10, so that beta would
  /// carry relative errors above eps(double) / rcond = 2e-6).
  explicit RbfCentroids(const std::vector<Eigen::Vector3d>& P, RbfKernel kernel = rbf_kernel());

  /// The centroid weights of a vertex whose rest centroid is p_star: beta[j] for every pseudo-handle j
  /// (q* = sum_j beta_j q_j). `rhs` is scratch (resized on first use).
  void weights(const Eigen::Vector3d& p_star, std::vector<double>& beta, Eigen::VectorXd& rhs) const;

  /// The interpolant's matrix M of the file comment (centres, then the constant, then the basis of the
  /// centres' span), rebuilt: for measuring its condition.
  Eigen::MatrixXd matrix() const;

 private:
  RbfKernel kernel_;
  std::vector<std::size_t> centre_of_;  ///< pseudo-handle -> centre
  std::vector<std::size_t> owner_;      ///< centre -> the first pseudo-handle there
  std::vector<Eigen::Vector3d> centres_;
  Eigen::Vector3d mean_;
  Eigen::Matrix<double, 3, Eigen::Dynamic> basis_;  ///< the centres' span, orthonormal columns (0 to 3)
  Eigen::PartialPivLU<Eigen::MatrixXd> lu_;
};

}  // namespace mlsdeform::detail
