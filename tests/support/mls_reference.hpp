// The MLS reference deformer of the tests and benchmarks: an independent direct per-vertex evaluation in
// double, with the error bound a deformer's output is held to (compare_with_direct: the deformer tests) and
// the looser per-vertex tolerance of the benchmarks' checks (sampled_reference, deform_tolerance, below).
//
// Direct evaluation (the reference). For each vertex v, straight from the paper, with no precomputed table:
//   w_i = |p_i - v|^-u (points); segments: the paper's constant d^-u with W_i and midpoint centroids (Sec. 6.2)
//   p*, q* (eq. 2), H = sum w qhat phat^T / S (eq. 6), R = fit_rotation(H, svd), mu = trace(R^T H) / D
//   (Sec. 6.1), v' = q* + mu R (v - p*); affine: v' = q* + H G^-1 (v - p*), G = sum w phat phat^T / S.
// A vertex at distance 0 from a point handle maps to its target; one on a segment takes the map's limit there
// (that segment alone, constant weight).
//
// Error bound of the precomputed path in precision T against the exact result (first order, per vertex;
// eps = eps(T), m = J + 16: J rounded additions of the per-vertex sums plus at most 16 roundings of each
// stored coefficient in the precomputation). The precomputation (core/src/deformer/precompute_table.cpp)
// removes the common rounding error of p* from the A_j, so each A_j is accurate relative to itself,
// |dA_j| <= m eps |A_j|; p* and vhat carry an absolute error of eps times the scene size l (the local frame):
//   |dq*| <= m eps sum_j omega_j |q_j|                                       (weighted_centroid)
//   |dH|_F <= m eps Habs, Habs = sum_j (|q_j - c| + |q_j|) |A_j|              (correlation_matrix; the |q_j|
//                                                                             term covers targets rounded to T)
//   |dR|_F <= 2 (|dH|_F + 16 eps |H|_F) / gap                                (perturbation of the polar
//            factor, gap = s2 + sign(det H) s3 (Kenney-Laub); 16 eps |H|_F is the fit's own backward error)
//   |dmu| <= mu m eps + (sqrt(3) |dH|_F + 16 eps |H|_F) / D                  (similarity; the optimum
//            trace(R^T H) is stationary in R, so dR enters only at second order)
//   |dv'| <= |dq*| + mu |dR| |vhat| + |dmu| |vhat| + mu m eps (|vhat| + l) + 8 eps (|q*| + mu |vhat|)
// Affine: |dv'| <= m eps sum_j |alpha_j| |q_j| + m eps kappa(G) |x| sum_j |A_j| |q_j - q*| + 8 eps |v'|,
// x = G^-1 vhat: the rounding of the alpha_j to T, and of the double-precision solve that produced them.
// The reference itself obeys the same bound with eps(double); comparisons add both.
#pragma once

#include <mlsdeform/deformer.hpp>

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace mlsdeform::testing {

/// One vertex of the direct evaluation, with what the error bound needs.
struct DirectVertex {
  Eigen::Vector3d out = Eigen::Vector3d::Zero();
  bool snapped = false;        ///< at distance 0 from a handle
  bool well_posed = true;      ///< gap > 0 (rigid, similarity), G invertible (affine)
  double bound_unit = 0;       ///< the bound of the file comment divided by eps (so bound = eps * bound_unit)
  double gap = 0, norm_H = 0;  ///< conditioning of the rotation fit (rigid, similarity)
  double dH_unit = 0;          ///< the bound on |dH|_F divided by eps
  double mu = 1, D = 0, vhat_norm = 0, q_star_norm = 0;
  double s1 = 0;         ///< largest singular value of H (rigid, similarity)
  double sum_scale = 0;  ///< sum_j |A_j| (|qhat_j| + |q_j|) / |H|_F: the cancellation in H (rigid, similarity)
};

/// The direct evaluation of one vertex (double). rest/moved may include segments (paper_constant weights).
template <class T>
DirectVertex direct_vertex(const Eigen::Vector3d& v, const Handles<T>& rest, const Handles<T>& moved, const Options& o,
                           double scene);

/// Statistics of a comparison of the deformer's output with the direct evaluation.
struct Comparison {
  double max_dev = 0;       ///< largest |v'_path - v'_direct|
  double max_ratio = 0;     ///< largest deviation / bound
  Eigen::Index worst = -1;  ///< vertex of max_ratio
  Eigen::Index checked = 0, ill_posed = 0, snapped = 0, failures = 0;
};

/// Compares `out` (from the deformer in precision T) with the direct evaluation of every vertex; a vertex
/// fails if its deviation exceeds the bound of T plus the bound of the double reference.
template <class T>
Comparison compare_with_direct(const Points<T>& out, const Points<T>& rest_vertices, const Handles<T>& rest,
                               const Handles<T>& moved, const Options& o);

// ---------------------------------------------------------------------------------------------------------
// The benchmarks' check
// ---------------------------------------------------------------------------------------------------------
//
// The deformation benchmarks (rigid, point handles, float) check every variant, the naive per-vertex loop
// (bench/naive_mls.hpp) included, against direct_vertex on all vertices or a sample, with a tolerance that
// does not assume the precomputed path's error structure:
//   A backward-stable fit of a computed H turns R by at most the H error over the gap, i.e. (relative H
//   error) sqrt(3) kappa, kappa = s1 / (s2 + d s3); H is a k-term sum whose rounding is at most (c + k) eps
//   times the sum of the terms' sizes (sum_scale |H|_F, either Sigma w qhat phat^T or the deformer's
//   Sigma A q^T form), so R turns by (c + k) eps sum_scale (2 + sqrt(3) kappa), moving v' by that times the
//   arm |v - p*|; the centroids and the final sum add c eps times the model's size (c = 32, as for the
//   rotation fits' checks: bench/reference.hpp). An implementation with a real bug misses by O(1) of the
//   arm, far outside this. The reference's own error, eps(double) times the same factors, is 2^-29 of
//   float's and neglected.

/// direct_vertex (rigid, weight exponent u) at the given rows of a scene with point handles p -> q, with
/// what deform_tolerance needs per row.
struct SampledReference {
  Points<double> out;             ///< the reference's v', one row per sample
  std::vector<double> kappa;      ///< s1 / (s2 + d s3) of the vertex's H (+inf: not unique; 0: on a handle)
  std::vector<double> sum_scale;  ///< sum_j |A_j| (|qhat_j| + |q_j|) / |H|_F: cancellation in H
  std::vector<double> arm;        ///< |v - p*|
  double diameter = 0;            ///< of the rest vertices' bounding box
  Eigen::Index handles = 0;
  /// Centroids::rbf (rbf_centroid_reference): per sample, the RBF centroid's own error bound relative to
  /// eps(T) (times eps(T)) and in absolute terms (eps(double) kappa(M) part); empty for MLS centroids.
  std::vector<double> rbf_unit, rbf_abs;
};

SampledReference sampled_reference(const Points<double>& vertices, const Points<double>& p, const Points<double>& q,
                                   const std::vector<Eigen::Index>& rows, double u = 2.0);

/// The same reference with Centroids::rbf: v' = g(p*) + R vhat (R, vhat as with MLS centroids), g the
/// biharmonic RBF interpolant of the handles (r plus a linear polynomial, the library's choice), solved
/// here directly in double with a full-pivoting LU, independently of core/src/deformer/rbf_centroids.cpp.
/// The library forms q* = sum_j beta_j q_j from weights beta(p*) computed in double ((J + 4) eps(double)
/// kappa(M) relative) and rounded to T, then summed in T ((J + 2) roundings): its q* is within
/// eps(T) (J + 2) B Q + (J + 4) eps(double) kappa(M) B Q of g(p*), B = sum_j |beta_j|, Q = max |q_j|; that is
/// added to the tolerance (rbf_unit, rbf_abs). Point handles spanning 3D, u = 2.
SampledReference rbf_centroid_reference(const SampledReference& mls, const Points<double>& vertices,
                                        const Points<double>& p, const Points<double>& q,
                                        const std::vector<Eigen::Index>& rows);

/// How far a float or double deformation may be from the reference at sample s (see above).
double deform_tolerance(const SampledReference& r, std::size_t s, double eps);

/// Rows checked: all when n <= max_rows, else max_rows spread evenly (a stride).
std::vector<Eigen::Index> check_rows(Eigen::Index n, Eigen::Index max_rows);

}  // namespace mlsdeform::testing
