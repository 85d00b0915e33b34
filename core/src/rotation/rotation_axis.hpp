// Stage "rotation_axis" of Algorithm 1 (eq. 14, generalised), scalar reference. The rotation's quaternion
// (cos(a/2), e sin(a/2)) is the eigenvector of Davenport's K = [[E, z^T], [z, N - E I]] (z = -V,
// N = H + H^T) for the eigenvalue y; the paper's system (N - lambda I) u = V with lambda = y + E is the last
// three rows of (K - y I) q = 0 divided by q0, u the Gibbs vector e tan(a/2). It is singular as a -> pi
// (q0 -> 0) and when V e = 0. We solve in homogeneous form instead: every column of adj(K - y I) is
// proportional to q q_k, and column 0 is the paper's (14) by Cramer's rule (q0 = det(N - lambda I),
// q_vec = -adj(N - lambda I) z). We take the column k with the largest diagonal cofactor (|q_k| largest, so
// >= 1/2 of |q|): Shuster and Oh's sequential rotations, i.e. (14) written in a frame turned by pi about
// axis k; then one power step with the adjugate (rotation_axis, the fast path). Where the adjugate vanishes
// or is too small to trust (y a (nearly) multiple root) the careful path takes K's top eigenvector
// (jacobi.hpp). SIMD twin: kernels/rotation/rotation_axis.hpp.
#pragma once

#include "core/src/rotation/invariants.hpp"

#include "kernels/contract.hpp"

#include <Eigen/Core>

namespace mlsdeform::detail {

template <class T>
using Matrix4 = Eigen::Matrix<T, 4, 4>;
template <class T>
using Vector4 = Eigen::Matrix<T, 4, 1>;

/// Davenport's symmetric 4x4 K = [[E, z^T], [z, H + H^T - E I]], so that trace(R(q)^T H) = q^T K q / |q|^2
/// (its eigenvalues are the roots of the quartic (13)).
template <class T>
Matrix4<T> davenport(const Matrix3<T>& H, const Invariants<T>& inv) {
  Matrix4<T> A;
  A(0, 0) = inv.E;
  A.template block<3, 1>(1, 0) = inv.z;
  A.template block<1, 3>(0, 1) = inv.z.transpose();
  A.template block<3, 3>(1, 1) = H + H.transpose();
  A.template block<3, 3>(1, 1).diagonal().array() -= inv.E;
  return A;
}

/// Eq. (14), the fast path: with y from maximum_root, the column of A = adj(K - y I) with the largest
/// diagonal entry |a_kk| = dk, then one step of the power method, q = A a_k. Returns q and dk; the caller
/// takes the careful path (top_eigenvector) instead where dk^2 <= tau^2 ||H||^6. S = K - y I is read from
/// K, as the twin does (K's entries are the sums of H's that S needs: 2 H_ii - E, H_ij + H_ji, z).
///
/// Why this suffices, and where it does not. A = sum_i mu_i v_i v_i^T with mu_i = prod_{j != i} (lambda_j - y)
/// (the eigenpairs of K), so a_k = A e_k weights the top eigenvector v1 by mu_1 ~ g (lambda1 - lambda3)
/// (lambda1 - lambda4) and the second by mu_2 = (lambda1 - y) (...): with y off the root by dy, a_k is off v1
/// by an angle theta ~ dy / g (g = lambda1 - lambda2 = 2 (s2 + d s3), kappa = s1 / (s2 + d s3)). y comes from
/// the quartic's coefficients, rounded to eps ||H||^4, and P'(y*) = -mu_1: dy ~ eps ||H||^4 / |mu_1|, i.e.
/// theta ~ eps kappa^2 for well separated lambda3, lambda4. The power step squares it (theta^2); the
/// adjugate's own rounding (a few eps ||H||^3 in each entry, against the gap mu_1 - mu_2 = g (...)(...))
/// adds eps kappa. So the fast path is within the suite's angle bound (55 eps kappa) while
/// (eps kappa^2)^2 <= eps kappa, kappa <= eps^(-1/3) (about 200 in float, 1.6e5 in double). Since
/// dk >= |mu_1| / 4 ~ g ||H||^2 / 4 when lambda3, lambda4 are far, dk > tau ||H||^3 with tau = cbrt(eps)/2
/// keeps the fast path inside that range; a smaller dk also catches the other case where dy is large, a
/// cluster of lambda1, lambda2, lambda3 (det H < 0 near a point reflection: mu_1 small through lambda1 -
/// lambda3).
/// A is symmetric: its 10 distinct entries from 11 complementary 2x2 minors of the row pairs (0, 1) and
/// (2, 3) of S = K - y I (Laplace expansion by complementary minors), as kernels/rotation/rotation_axis.hpp computes
/// them.
template <class T>
Vector4<T> rotation_axis(const Matrix4<T>& K, T y, T& dk) {
  const T S00 = K(0, 0) - y, S11 = K(1, 1) - y, S22 = K(2, 2) - y, S33 = K(3, 3) - y;
  const T S01 = K(0, 1), S02 = K(0, 2), S03 = K(0, 3);
  const T S12 = K(1, 2), S13 = K(1, 3), S23 = K(2, 3);
  const T s0 = S00 * S11 - S01 * S01, s1 = S00 * S12 - S01 * S02, s2 = S00 * S13 - S01 * S03;
  const T s3 = S01 * S12 - S11 * S02, s4 = S01 * S13 - S11 * S03, s5 = S02 * S13 - S12 * S03;
  const T c5 = S22 * S33 - S23 * S23, c4 = S12 * S33 - S13 * S23, c3 = S12 * S23 - S13 * S22;
  const T c2 = S02 * S33 - S03 * S23, c1 = S02 * S23 - S03 * S22;
  Matrix4<T> A;
  A(0, 0) = S11 * c5 + S13 * c3 - S12 * c4;
  A(0, 1) = A(1, 0) = S02 * c4 - (S01 * c5 + S03 * c3);
  A(0, 2) = A(2, 0) = S13 * s5 + S33 * s3 - S23 * s4;
  A(0, 3) = A(3, 0) = S22 * s4 - (S12 * s5 + S23 * s3);
  A(1, 1) = S00 * c5 + S03 * c1 - S02 * c2;
  A(1, 2) = A(2, 1) = S23 * s2 - (S03 * s5 + S33 * s1);
  A(1, 3) = A(3, 1) = S02 * s5 + S23 * s1 - S22 * s2;
  A(2, 2) = S03 * s4 + S33 * s0 - S13 * s2;
  A(2, 3) = A(3, 2) = S12 * s2 - (S02 * s4 + S23 * s0);
  A(3, 3) = S02 * s3 + S22 * s0 - S12 * s1;
  int k;
  dk = A.diagonal().cwiseAbs().maxCoeff(&k);
  return A * A.col(k);
}

}  // namespace mlsdeform::detail
