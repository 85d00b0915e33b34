// The RBF centroid tests' own header (tests/test_rbf_centroids*.cpp): Centroids::rbf (paper Sec. 7-8),
// q* = g(p*) with g the polyharmonic RBF interpolant of the handles, and the bound on q* that the deformer
// tests add to the MLS path's own, for each kernel of core/src/deformer/rbf_centroids.hpp (r, the library's,
// and r^3, which bench_quality --centroids measures against it).
//
// Bounds. The centroid weights beta(p*) come from one solve with the interpolant's matrix M in double:
// backward stable (partial pivoting), so each beta carries a relative error of at most (J + 4) eps(double)
// kappa(M) (kappa computed here independently, in long double), and is then rounded to T. The kernels form
// q* = sum_j beta_j q_j in T: at most (J + 1) roundings of terms of size |beta_j| |q_j|. So q* is off g(p*)
// by at most eps(T) (J + 2) B Q + (J + 4) eps(double) kappa(M) B Q with B = sum_j |beta_j| and Q = max |q_j|.
// What the rest of a vertex's transform adds (the rotation, mu) is the MLS path's own, bounded per vertex by
// the direct evaluation (tests/support/mls_reference.hpp, the bound the deformer tests use).
#pragma once

#include "tests/test_deformer_common.hpp"

#include "core/src/deformer/rbf_centroids.hpp"

#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace rbf_test {

using namespace deformer_test;
using mlsdeform::detail::RbfCentroids;
using mlsdeform::detail::RbfKernel;
using LD = long double;

inline const char* kernel_name(RbfKernel kernel) { return kernel == RbfKernel::r ? "r" : "r^3"; }

/// kappa(M) of the interpolant's matrix for the centres P (long double, the polynomial in raw centred
/// coordinates: an orthonormal change of the polynomial basis is an orthogonal similarity of M, so kappa is
/// the same as the library's).
inline LD kappa_of(const std::vector<Vec3d>& P, RbfKernel kernel) {
  const auto m = Eigen::Index(P.size());
  Eigen::Matrix<LD, Eigen::Dynamic, Eigen::Dynamic> M =
      Eigen::Matrix<LD, Eigen::Dynamic, Eigen::Dynamic>::Zero(m + 4, m + 4);
  Vec3d mean = Vec3d::Zero();
  for (const Vec3d& p : P) mean += p;
  mean /= double(m);
  for (Eigen::Index i = 0; i < m; ++i) {
    for (Eigen::Index j = 0; j < m; ++j) {
      const LD r = (P[std::size_t(i)] - P[std::size_t(j)]).cast<LD>().norm();
      M(i, j) = kernel == RbfKernel::r ? r : r * r * r;
    }
    M(i, m) = M(m, i) = 1;
    for (int c = 0; c < 3; ++c) M(i, m + 1 + c) = M(m + 1 + c, i) = LD(P[std::size_t(i)][c] - mean[c]);
  }
  const auto sv = Eigen::JacobiSVD<Eigen::Matrix<LD, Eigen::Dynamic, Eigen::Dynamic>>(M).singularValues();
  return sv(0) / sv(sv.size() - 1);
}

/// The pseudo-handles of h (points, then each segment's two ends: core/src/deformer/data.hpp).
template <class T>
std::vector<Vec3d> pseudo_handles(const Handles<T>& h) {
  std::vector<Vec3d> P;
  for (Eigen::Index i = 0; i < h.points.rows(); ++i) P.push_back(h.points.row(i).transpose().template cast<double>());
  for (Eigen::Index i = 0; i < h.segment_a.rows(); ++i) {
    P.push_back(h.segment_a.row(i).transpose().template cast<double>());
    P.push_back(h.segment_b.row(i).transpose().template cast<double>());
  }
  return P;
}

/// The scale of the deformer's local frame (core/src/deformer/local_frame.hpp): 2^-e, e the exponent of the
/// bounding-box diagonal of the rest vertices and handles.
template <class T>
double local_scale(const DeformCase<T>& sc) {
  return std::ldexp(1.0, -std::ilogb(scene_size(sc.vertices, sc.rest)));
}

/// The rest pseudo-handles in the deformer's local frame (scaled by local_scale; the translation cancels in
/// M): beta does not depend on the frame (phi is homogeneous and the linear polynomials are invariant under
/// similarity), but kappa(M) does.
template <class T>
std::vector<Vec3d> handle_points(const DeformCase<T>& sc) {
  const double scale = local_scale(sc);
  std::vector<Vec3d> P = pseudo_handles(sc.rest);
  for (Vec3d& p : P) p *= scale;
  return P;
}

/// p* of vertex v (eq. 2, u = 2; paper_constant segments: weight d^-u at their midpoint, Sec. 6.2). At a
/// point handle, that handle (the deformer interpolates there and uses no centroid weights).
template <class T>
Vec3d rest_centroid(const Vec3d& v, const Handles<T>& rest) {
  Vec3d s = Vec3d::Zero();
  double W = 0;
  for (Eigen::Index j = 0; j < rest.points.rows(); ++j) {
    const Vec3d p = rest.points.row(j).transpose().template cast<double>();
    if (p == v) return p;
    const double w = 1 / (p - v).squaredNorm();
    s += w * p, W += w;
  }
  for (Eigen::Index j = 0; j < rest.segment_a.rows(); ++j) {
    const Vec3d a = rest.segment_a.row(j).transpose().template cast<double>();
    const Vec3d b = rest.segment_b.row(j).transpose().template cast<double>();
    const double t = std::clamp((v - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
    const double w = 1 / (a + t * (b - a) - v).squaredNorm();
    s += w * 0.5 * (a + b), W += w;
  }
  return s / W;
}

/// The extra bound of the file comment for every vertex of a scene: max over vertices of the RBF terms, with
/// Q the largest |q_j| (so that sum_j |beta_j| |q_j| <= B Q bounds the error of q* in norm).
template <class T>
double rbf_extra(const DeformCase<T>& sc, const Handles<T>& moved) {
  const double scale = local_scale(sc);
  const std::vector<Vec3d> P = handle_points(sc);
  const RbfCentroids rbf(P);  // the kernel the deformer used: rbf_kernel()
  const LD kappa = kappa_of(P, mlsdeform::detail::rbf_kernel());
  double Q = 0;
  for (const Vec3d& q : pseudo_handles(moved)) Q = std::max(Q, q.norm());
  const double J = double(P.size());
  std::vector<double> beta;
  Eigen::VectorXd rhs;
  double B = 0;
  for (Eigen::Index i = 0; i < sc.vertices.rows(); ++i) {
    const Vec3d p_star = rest_centroid(sc.vertices.row(i).transpose().template cast<double>(), sc.rest);
    rbf.weights(scale * p_star, beta, rhs);  // in the frame of P (the same beta as in any other)
    double b = 0;
    for (double x : beta) b += std::abs(x);
    B = std::max(B, b);
  }
  return (std::numeric_limits<T>::epsilon() * (J + 2) +
          (J + 4) * std::numeric_limits<double>::epsilon() * double(kappa)) *
         B * Q;
}

}  // namespace rbf_test
