// The paper's closed-form rotation fit (Sec. 4.3-4.6, Algorithm 1 steps 3-7), scalar reference.
//
// Written to be read beside the paper; the SIMD kernels (kernels/fit_rotations.hpp and the stage headers it
// includes) compute the same stages in the same order. Column-vector convention (see rotation.hpp):
// H = sum w q p^T is the paper's M.
//
// Two paths through the stages. The fast path settles almost every H (all but ~1e-3 of random point-set
// matrices, none of 10^6 Gaussian H): upper_bound_root, then fast_axis, then sin_cos. The careful path takes
// the rest (a multiple or nearly multiple root of (13), e.g. rank-1 H from collinear handles; a gap
// s2 + d s3 below cbrt(eps) s1; three clustered eigenvalues of K): maximum_root, then rotation_axis.
//
// Stages, with the paper's routine names (Table 1):
//   normalise          H <- 2^-e H so that max |H_ij| is in [1, 2): exact, so the result is bitwise
//                      invariant under power-of-two scaling and no product (det^2, ||H||^4) can overflow.
//   invariants (6)     E = trace H, V, ||H||^2, det H, and c2 = sum_{i<j} |H_i x H_j|^2 (columns H_i).
//   maximum_root (13)  largest root y of y^4 - 2||H||^2 y^2 - 8 det(H) y + (||H||^4 - 4 c2).
//                      Fast path (upper_bound_root): Newton's method from an upper bound of the root.
//                      Careful path (maximum_root): the paper's closed form through the resolvent cubic
//                      (Sec. 4.4, whose largest root is 4 s1^2), then Newton steps on (13) from just above,
//                      which decrease monotonically to the largest root. The closed form alone loses up to
//                      eps^(1/2) (eps^(1/3) near triple roots) when singular values nearly coincide; the
//                      Newton polish restores full accuracy.
//   rotation_axis (14) Fast path (fast_axis): the column of adj(K - y I) with the largest diagonal, then
//                      one power step with that adjugate. Careful path (rotation_axis), as follows:
//   rotation_axis (14) The rotation's quaternion (cos(a/2), e sin(a/2)) is the eigenvector of Davenport's
//                      K = [[E, z^T], [z, N - E I]] (z = -V, N = H + H^T) for the eigenvalue y; the
//                      paper's system (N - lambda I) u = V with lambda = y + E is the last three rows of
//                      (K - y I) q = 0 divided by q0, u the Gibbs vector e tan(a/2). It is singular as
//                      a -> pi (q0 -> 0) and when V e = 0. We solve in homogeneous form instead: every
//                      column of adj(K - y I) is proportional to q q_k, and column 0 is the paper's
//                      (14) by Cramer's rule (q0 = det(N - lambda I), q_vec = -adj(N - lambda I) z). We take
//                      the column k with the largest diagonal cofactor (|q_k| largest, so >= 1/2 of |q|):
//                      Shuster and Oh's sequential rotations, i.e. (14) written in a frame turned by pi
//                      about axis k. Where the adjugate vanishes (y is a multiple root: rank-1 H, H = 0,
//                      or H = -s I) every unit vector of the null space of K - y I is optimal, and we take
//                      the one closest to the identity rotation (the projection of (1, 0, 0, 0)).
//   sin_cos (15)       cos a = (q0^2 - |q_vec|^2) / |q|^2 and sin a = 2 q0 |q_vec| / |q|^2, the homogeneous
//                      forms of (1 - |u|^2)/(1 + |u|^2) and 2|u|/(1 + |u|^2); with e = q_vec / |q_vec|,
//                      (5) becomes R = ((q0^2 - |q_vec|^2) I + 2 q_vec q_vec^T + 2 q0 [q_vec]_x) / |q|^2.
#pragma once

#include <mlsdeform/rotation.hpp>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace mlsdeform::detail {

/// Newton steps allowed in maximum_root; a simple root needs 2-4, a double root (rank-1 H) up to ~40.
inline constexpr int kMaxNewton = 64;

template <class T>
struct Invariants {
  T E;          // trace H (paper's E)
  Vector3<T> z; // (H21 - H12, H02 - H20, H10 - H01) = -V (paper's V, eq. 6), 0-based indices
  T norm2;      // ||H||_F^2
  T det;        // det H
  T c2;         // sum_{i<j} |H_i x H_j|^2: second invariant of H^T H (Lagrange identity)
};

/// Eq. (6) and the coefficients of (13), on a normalised H.
template <class T>
Invariants<T> invariants(const Matrix3<T>& H) {
  Invariants<T> inv;
  inv.E = H.trace();
  inv.z = Vector3<T>(H(2, 1) - H(1, 2), H(0, 2) - H(2, 0), H(1, 0) - H(0, 1));
  inv.norm2 = H.squaredNorm();
  const Vector3<T> c01 = H.col(0).cross(H.col(1));
  const Vector3<T> c02 = H.col(0).cross(H.col(2));
  const Vector3<T> c12 = H.col(1).cross(H.col(2));
  inv.det = c01.dot(H.col(2));
  inv.c2 = c01.squaredNorm() + c02.squaredNorm() + c12.squaredNorm();
  return inv;
}

/// Sec. 4.4: the largest root 4 s1^2 of the resolvent cubic Q(z) is 4 times the largest eigenvalue of H^T H,
/// mu^3 - ||H||^2 mu^2 + c2 mu - det^2 = 0. Trigonometric (Viete) solution in the shifted variable.
template <class T>
T largest_eigenvalue_HtH(const Invariants<T>& inv) {
  using std::acos;
  using std::cos;
  using std::sqrt;
  const T shift = inv.norm2 / T(3);
  // mu = shift + t: t^3 + p t + q = 0 with p = c2 - n^2/3 <= 0 and q = -2n^3/27 + n c2/3 - det^2 (n = ||H||^2).
  const T p = inv.c2 - inv.norm2 * shift;
  const T q = -T(2) * shift * shift * shift + shift * inv.c2 - inv.det * inv.det;
  if (!(p < T(0))) return shift;  // triple root (H^T H = s^2 I)
  const T m = sqrt(-p / T(3));
  T r = T(-0.5) * q / (m * m * m);  // cos(3 phi)
  r = r > T(1) ? T(1) : (r < T(-1) ? T(-1) : r);
  return shift + T(2) * m * cos(acos(r) / T(3));
}

/// Eq. (13): the largest root y of the depressed quartic, i.e. the optimal value of trace(R^T H), which is
/// s1 + s2 + sign(det H) s3. Returns the root and, through `iterations`, the Newton steps it took.
template <class T>
T maximum_root(const Invariants<T>& inv, int* iterations = nullptr) {
  using std::sqrt;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  const T mu1 = largest_eigenvalue_HtH(inv);
  const T s1 = sqrt(mu1 > T(0) ? mu1 : T(0));
  // Sec. 4.4 with p = sqrt(4 mu1) = 2 s1: y = p/2 + sqrt(-p^2/4 + ||M||^2 + 4 det(M)/p) = s1 + (s2 + s3').
  // (The paper's other candidate, -p/2 + sqrt(...), is never larger for the largest root of Q.)
  T rest = inv.norm2 - mu1 + (s1 > T(0) ? T(2) * inv.det / s1 : T(0));
  const T y_closed = s1 + sqrt(rest > T(0) ? rest : T(0));
  // Quartic (13): P(y) = ((y^2 + a) y + b) y + c.
  const T a = -T(2) * inv.norm2, b = -T(8) * inv.det, c = inv.norm2 * inv.norm2 - T(4) * inv.c2;
  auto P = [&](T y) { return ((y * y + a) * y + b) * y + c; };
  auto dP = [&](T y) { return (T(4) * y * y + T(2) * a) * y + b; };
  // Start just above the root. The closed form is good to a few eps relative for well-separated singular
  // values, to sqrt(eps) near a double root of (13), and to eps^(1/3) near a triple root of the cubic
  // (s1 = s2 = s3, H a scaled rotation). Try 64 eps above it first, then one or two Newton steps suffice;
  // it is taken only where it is clearly above a simple root: P >= 0 and P' > 4 sqrt(eps) ||H||^3 (P' at the
  // root is the product of the gaps to the other roots, about g 4 s1^2: a smaller slope means a nearly
  // double root, where P there is rounding noise and a step from it could land anywhere). Otherwise take
  // 4 eps^(1/3) above; where that is not above the root either (P < 0), the bound s1 + s2 + s3 <= sqrt(3) ||H||.
  const T norm = sqrt(inv.norm2);
  const T upper = sqrt(T(3)) * norm;
  const T near = std::min(y_closed + T(64) * eps * norm, upper);
  const T far = std::min(y_closed + T(4) * std::cbrt(eps) * norm, upper);
  const bool near_ok = P(near) >= T(0) && dP(near) > T(4) * sqrt(eps) * inv.norm2 * norm;
  T y = near_ok ? near : (P(far) >= T(0) ? far : upper);
  // From above the largest root, on the convex part of P, Newton's steps decrease y monotonically and
  // shrink from one step to the next (by half at a double root, quadratically at a simple one). A step
  // that does not decrease y, or is longer than the previous one, means P and P' have sunk into rounding
  // (near a double root that happens about sqrt(eps) ||H|| above it): stop there, never below the root.
  int it = 0;
  T last_step = std::numeric_limits<T>::infinity();
  for (; it < kMaxNewton; ++it) {
    const T d = dP(y);
    if (!(d > T(0))) break;
    const T step = P(y) / d;
    if (!(step > T(0)) || !(step <= last_step) || !(y - step < y)) break;
    y -= step;
    last_step = step;
  }
  if (iterations) *iterations = it;
  return y;
}


/// Newton steps allowed in upper_bound_root (the fast path); lanes still moving take the careful path.
inline constexpr int kMaxNewtonFast = 16;

/// Eq. (13), the fast path: Newton's method on the quartic from an upper bound of its largest root
/// y* = s1 + s2 + d s3 (n = ||H||^2 = sum s_i^2, c2 = sum_{i<j} s_i^2 s_j^2, d = sign det H):
///   det >= 0: y*^2 = n + 2 (s1 s2 + s1 s3 + s2 s3) <= n + 2 sqrt(3 c2)   (Cauchy-Schwarz)
///   det <  0: y*^2 = n + 2 (s1 s2 - s1 s3 - s2 s3) <= n + 2 sqrt(c2)     (s1 s2 <= sqrt(c2))
/// Above y* the quartic is increasing and convex (its four roots are the eigenvalues of K, all <= y*), so
/// Newton's steps decrease y monotonically to y*: no closed form and no bracketing (3-6 steps on generic H).
/// A step below sqrt(eps)/4 of y ends the iteration converged (the error left is O(step^2 / gap), rounding
/// level for a simple root). It ends unconverged where P' sinks below 64 eps y^3, its own rounding (P and
/// P' are then noise: a (nearly) multiple root, e.g. rank-1 H), where a step fails to shrink, or after
/// kMaxNewtonFast steps; those H take the careful path (maximum_root).
template <class T>
T upper_bound_root(const Invariants<T>& inv, bool& converged) {
  using std::sqrt;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  const T a = T(-2) * inv.norm2, b = T(-8) * inv.det, c = inv.norm2 * inv.norm2 - T(4) * inv.c2;
  T y = sqrt(inv.norm2 + T(2) * sqrt(inv.det < T(0) ? inv.c2 : T(3) * inv.c2));
  const T tol = T(0.25) * sqrt(eps);
  converged = !(y > T(0));  // H = 0
  T last = std::numeric_limits<T>::infinity();
  for (int it = 0; it < kMaxNewtonFast && y > T(0); ++it) {
    const T y2 = y * y;
    const T p = ((y2 + a) * y + b) * y + c;
    const T d = (T(4) * y2 + T(2) * a) * y + b;
    const T step = p / d;
    if (!(d > T(64) * eps * y2 * y)) break;  // P' is rounding noise
    if (step <= tol * y) {
      if (step > T(0) && step <= last) y -= step;
      converged = true;
      break;
    }
    if (!(step <= last)) break;
    y -= step;
    last = step;
  }
  return y;
}

/// The symmetric 4x4 matrix K - y I (Davenport's K, so that trace(R(q)^T H) = q^T K q / |q|^2).
template <class T>
Eigen::Matrix<T, 4, 4> shifted_davenport(const Matrix3<T>& H, const Invariants<T>& inv, T y) {
  Eigen::Matrix<T, 4, 4> A;
  A(0, 0) = inv.E - y;
  A.template block<3, 1>(1, 0) = inv.z;
  A.template block<1, 3>(0, 1) = inv.z.transpose();
  A.template block<3, 3>(1, 1) = H + H.transpose();
  A.template block<3, 3>(1, 1).diagonal().array() -= inv.E + y;
  return A;
}

/// adj(A) of a symmetric 4x4 A, through the 2x2 minors of its upper and lower row pairs (Laplace
/// expansion by complementary minors). Every column of adj(A) lies in the null space of A when det A = 0.
template <class T>
Eigen::Matrix<T, 4, 4> adjugate4(const Eigen::Matrix<T, 4, 4>& A) {
  // 2x2 minors of rows (0,1) and of rows (2,3), over column pairs (01, 02, 03, 12, 13, 23).
  const T s0 = A(0, 0) * A(1, 1) - A(1, 0) * A(0, 1), s1 = A(0, 0) * A(1, 2) - A(1, 0) * A(0, 2);
  const T s2 = A(0, 0) * A(1, 3) - A(1, 0) * A(0, 3), s3 = A(0, 1) * A(1, 2) - A(1, 1) * A(0, 2);
  const T s4 = A(0, 1) * A(1, 3) - A(1, 1) * A(0, 3), s5 = A(0, 2) * A(1, 3) - A(1, 2) * A(0, 3);
  const T c5 = A(2, 2) * A(3, 3) - A(3, 2) * A(2, 3), c4 = A(2, 1) * A(3, 3) - A(3, 1) * A(2, 3);
  const T c3 = A(2, 1) * A(3, 2) - A(3, 1) * A(2, 2), c2 = A(2, 0) * A(3, 3) - A(3, 0) * A(2, 3);
  const T c1 = A(2, 0) * A(3, 2) - A(3, 0) * A(2, 2), c0 = A(2, 0) * A(3, 1) - A(3, 0) * A(2, 1);
  Eigen::Matrix<T, 4, 4> adj;
  adj(0, 0) = A(1, 1) * c5 - A(1, 2) * c4 + A(1, 3) * c3;
  adj(0, 1) = -A(0, 1) * c5 + A(0, 2) * c4 - A(0, 3) * c3;
  adj(0, 2) = A(3, 1) * s5 - A(3, 2) * s4 + A(3, 3) * s3;
  adj(0, 3) = -A(2, 1) * s5 + A(2, 2) * s4 - A(2, 3) * s3;
  adj(1, 0) = -A(1, 0) * c5 + A(1, 2) * c2 - A(1, 3) * c1;
  adj(1, 1) = A(0, 0) * c5 - A(0, 2) * c2 + A(0, 3) * c1;
  adj(1, 2) = -A(3, 0) * s5 + A(3, 2) * s2 - A(3, 3) * s1;
  adj(1, 3) = A(2, 0) * s5 - A(2, 2) * s2 + A(2, 3) * s1;
  adj(2, 0) = A(1, 0) * c4 - A(1, 1) * c2 + A(1, 3) * c0;
  adj(2, 1) = -A(0, 0) * c4 + A(0, 1) * c2 - A(0, 3) * c0;
  adj(2, 2) = A(3, 0) * s4 - A(3, 1) * s2 + A(3, 3) * s0;
  adj(2, 3) = -A(2, 0) * s4 + A(2, 1) * s2 - A(2, 3) * s0;
  adj(3, 0) = -A(1, 0) * c3 + A(1, 1) * c1 - A(1, 2) * c0;
  adj(3, 1) = A(0, 0) * c3 - A(0, 1) * c1 + A(0, 2) * c0;
  adj(3, 2) = -A(3, 0) * s3 + A(3, 1) * s1 - A(3, 2) * s0;
  adj(3, 3) = A(2, 0) * s3 - A(2, 1) * s1 + A(2, 2) * s0;
  return adj;
}

/// A unit vector of the null space of a symmetric 4x4 A of rank <= 2 (a multiple largest eigenvalue of K),
/// chosen closest to e0 = (1, 0, 0, 0), the identity rotation: e0 minus its projection on the column space
/// of A, found by Gram-Schmidt with column pivoting. If e0 is (nearly) in that column space the axis e_k
/// with the largest remainder is projected instead (then the optimal rotations are all half-turns or so).
/// `rank_tol` is the relative size under which a remaining column counts as zero.
template <class T>
Eigen::Matrix<T, 4, 1> null_vector_closest_to_identity(const Eigen::Matrix<T, 4, 4>& A, T rank_tol) {
  using Vec4 = Eigen::Matrix<T, 4, 1>;
  Eigen::Matrix<T, 4, 4> C = A;
  std::array<Vec4, 2> basis;
  int rank = 0;
  const T scale = C.colwise().norm().maxCoeff();
  for (; rank < 2; ++rank) {
    int best;
    const T n = C.colwise().norm().maxCoeff(&best);
    if (!(n > rank_tol * scale)) break;
    basis[rank] = C.col(best) / n;
    for (int j = 0; j < 4; ++j) C.col(j) -= basis[rank] * basis[rank].dot(C.col(j));
  }
  auto remainder = [&](int k) {
    Vec4 r = Vec4::Unit(k);
    for (int i = 0; i < rank; ++i) r -= basis[i] * basis[i].dot(r);
    return r;
  };
  Vec4 q = remainder(0);
  // The remainders' squared norms sum to 4 - rank >= 2, so the best one has norm >= 1/sqrt(2).
  if (q.squaredNorm() < T(0.25)) {
    for (int k = 1; k < 4; ++k) {
      const Vec4 r = remainder(k);
      if (r.squaredNorm() > q.squaredNorm()) q = r;
    }
  }
  return q;
}

/// Rayleigh-Ritz on the span of column k of an adjugate of K - y I and the column l most independent of it
/// (largest remainder after removing its component along column k: pivoted Gram-Schmidt; near a double
/// root the adjugate is nearly the projector onto the top two eigenvectors, and columns of equal size can
/// be parallel). The top eigenvector of the 2x2 matrix [[B11, B12], [B12, B22]] = [b1 b2]^T K [b1 b2] is
/// backward stable: whatever mixture of the top two eigenvectors the columns hold (y inexact), the Ritz
/// vector is the best unit vector of their plane. Where the two Ritz values coincide to rounding (a double
/// eigenvalue: the optimum is not unique) it returns the vector of the plane closest to e0 (the identity
/// rotation), or to e_m, the axis with the largest projection, if e0 is nearly orthogonal to the plane, so
/// that neighbouring vertices of a deformation make the same choice.
/// `gap` receives the gap between the two Ritz values (an estimate of g = lambda1 - lambda2 when the plane
/// holds the top two eigenvectors; O(a) when column l is noise), or infinity if the columns span a line.
template <class T>
Eigen::Matrix<T, 4, 1> ritz_top(const Eigen::Matrix<T, 4, 4>& adj, int k, const Eigen::Matrix<T, 4, 4>& K, T a,
                                T& gap) {
  using Vec4 = Eigen::Matrix<T, 4, 1>;
  using std::sqrt;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  const Vec4 b1 = adj.col(k) / sqrt(adj.col(k).squaredNorm());
  // l: the largest remainder |c_j|^2 - (b1 . c_j)^2 over j != k (first index on ties).
  int l = k == 0 ? 1 : 0;  // (stays if the remainders are NaN: an all-zero adjugate, rejected by the caller)
  T best = T(-1);
  for (int j = 0; j < 4; ++j) {
    if (j == k) continue;
    const T p = b1.dot(adj.col(j)), rem = adj.col(j).squaredNorm() - p * p;
    if (rem > best) best = rem, l = j;
  }
  Vec4 b2 = adj.col(l) - b1 * b1.dot(adj.col(l));
  gap = std::numeric_limits<T>::infinity();
  if (!(b2.squaredNorm() > T(64 * 64) * eps * eps * adj.col(l).squaredNorm())) return b1;  // a line only
  // Twice is enough (Kahan, Parlett): the first pass may cancel almost all of column l, leaving a residual
  // whose rounding is not orthogonal to b1; a second pass makes it so to working precision.
  b2 -= b1 * b1.dot(b2);
  b2 /= sqrt(b2.squaredNorm());
  const Vec4 Kb1 = K * b1, Kb2 = K * b2;
  const T B11 = b1.dot(Kb1), B12 = b1.dot(Kb2), B22 = b2.dot(Kb2);
  const T d = T(0.5) * (B11 - B22);
  const T r = sqrt(d * d + B12 * B12);  // half the gap between the two Ritz values
  gap = T(2) * r;
  // B carries rounding of a few eps ||K||: a smaller gap is a double eigenvalue.
  if (!(r > T(8) * eps * a)) {
    const Vec4 proj = b1.cwiseProduct(b1) + b2.cwiseProduct(b2);
    int m;
    const T pm = proj.maxCoeff(&m);
    if (proj(0) >= T(0.25) * pm) m = 0;
    return b1 * b1(m) + b2 * b2(m);
  }
  return d >= T(0) ? Vec4((d + r) * b1 + B12 * b2) : Vec4(B12 * b1 + (r - d) * b2);
}

/// The column k: the paper's frame (k = 0, system (14) as written) unless |q0| is below half the largest
/// |q_k| (diagonal cofactor ratio 1/4), then the largest (Shuster's sequential rotation about axis k; at
/// most a factor 2 in accuracy is given up for continuity). dk: the largest |diagonal cofactor|.
template <class T>
void strongest_column(const Eigen::Matrix<T, 4, 4>& adj, int& k, T& dk) {
  const Eigen::Matrix<T, 4, 1> diag = adj.diagonal().cwiseAbs();
  dk = diag.maxCoeff(&k);
  if (diag(0) >= T(0.25) * dk) k = 0;
}

/// Near a point reflection (det H < 0 and s1^2, s2^2, s3^2 spread less than their mean: the top three
/// eigenvalues of K then cluster within 2 (s1 - s3)) the quartic's coefficients fix y only to eps ||K||^3 / w^2
/// (w the cluster width, down to eps^(1/3) relative), and the adjugate's columns mix three eigenvectors, which
/// two-column Rayleigh-Ritz cannot separate: such H go to top_eigenvector (a symmetric eigensolver), in the
/// SIMD kernels through the scalar fallback (counted in BatchStats::scalar_fallback).
template <class T>
bool clustered_top_three(const Invariants<T>& inv) {
  if (!(inv.det < T(0))) return false;
  const T shift = inv.norm2 / T(3), p = inv.c2 - inv.norm2 * shift;  // as in largest_eigenvalue_HtH
  return -p / T(3) < shift * shift / T(4);                            // m < shift / 2
}

/// The slow path for clustered lanes: the top eigenvector of K from a symmetric eigensolver (backward
/// stable), or, where the top eigenvalue is multiple to rounding (8 eps a), the vector of its eigenspace
/// closest to e0 (or e_m, as in ritz_top). Used where the top three eigenvalues of K cluster: there the
/// quartic's root is only good to eps^(1/3) and two-column Rayleigh-Ritz cannot separate three vectors.
template <class T>
Eigen::Matrix<T, 4, 1> top_eigenvector(const Eigen::Matrix<T, 4, 4>& K, T a) {
  using Vec4 = Eigen::Matrix<T, 4, 1>;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<T, 4, 4>> es(K);  // eigenvalues ascending
  const T top = es.eigenvalues()(3);
  int first = 3;
  while (first > 0 && es.eigenvalues()(first - 1) >= top - T(8) * eps * a) --first;
  if (first == 3) return es.eigenvectors().col(3);
  Vec4 proj = Vec4::Zero();
  for (int j = first; j < 4; ++j) proj += es.eigenvectors().col(j).cwiseAbs2();
  int m;
  const T pm = proj.maxCoeff(&m);
  if (proj(0) >= T(0.25) * pm) m = 0;
  Vec4 q = Vec4::Zero();
  for (int j = first; j < 4; ++j) q += es.eigenvectors().col(j) * es.eigenvectors()(m, j);
  return q;
}

/// Eq. (14), generalised: the (unnormalised) quaternion (q0, q_vec) of the optimal rotation.
///
/// Every column of adj(K - y I) is proportional to q q_k when y is a simple root; column 0 is the paper's
/// (14) solved by Cramer's rule (q0 = det(N - lambda I), q_vec = adj(N - lambda I) V), column k is (14) in a
/// frame turned by pi about axis k (Shuster and Oh's sequential rotations), which stays regular as the angle
/// approaches pi. y comes from the quartic's coefficients and is good to about eps ||K||^2 / g, g the gap to
/// the next eigenvalue of K (g = 2 (s2 + sign(det H) s3)), so a single column mixes in the second
/// eigenvector by eps ||K||^2 / g^2 (an error of eps kappa^2): Rayleigh-Ritz on the two strongest columns
/// removes that mixture and leaves eps kappa.
/// Near a double root (g below sqrt(eps) ||K||: nearly collinear data, kappa > 1/sqrt(eps)) y is good only
/// to about sqrt(eps) ||K|| and the adjugate at y can sink into rounding; there we evaluate it at
/// y + sqrt(eps) ||K||, whose columns span the top two eigenvectors up to O(sqrt(eps)) (costing O(eps) in
/// trace and O(sqrt(eps)) <= eps kappa in angle), and Rayleigh-Ritz picks the optimum in that plane (or the
/// optimum closest to the identity, when the root is exactly double: rank-1 H).
/// A triple root (H = -s R, a point reflection, where every half-turn is optimal) leaves even that adjugate
/// at rounding level; then the null space of K - y I is used directly. `path` reports which branch ran:
/// 0 regular, 1 near-double (shifted), 2 null space.
template <class T>
Eigen::Matrix<T, 4, 1> rotation_axis(const Matrix3<T>& H, const Invariants<T>& inv, T y, int* path = nullptr) {
  using std::sqrt;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  const Eigen::Matrix<T, 4, 4> K = shifted_davenport(H, inv, T(0));
  const T a = K.cwiseAbs().maxCoeff();
  // For a simple root the strongest diagonal cofactor is q_k^2 g1 g2 g3 >= g1 a^2 / 4 roughly (g1 the gap
  // to the next eigenvalue of K, g2, g3 ~ 2 s1 ~ a): below sqrt(eps) a^3 the gap is under a few
  // sqrt(eps) a, kappa is above 1/sqrt(eps), and the shifted evaluation's O(sqrt(eps)) is within eps kappa.
  // Cofactors are sums of six products of three entries of K - y I (|entries| <= a + y <= 3a): their
  // rounding is a few eps a^3, and the shifted adjugate must stand above 64 eps a^3.
  const T a3 = a * a * a;
  if (clustered_top_three(inv)) {
    if (path) *path = 3;
    return top_eigenvector(K, a);
  }
  int k;
  T dk, gap;
  Eigen::Matrix<T, 4, 4> adj = adjugate4(shifted_davenport(H, inv, y));
  strongest_column(adj, k, dk);
  Eigen::Matrix<T, 4, 1> q;
  bool noise = false;
  if (dk > sqrt(eps) * a3) {
    if (path) *path = 0;
    q = ritz_top(adj, k, K, a, gap);
  } else {
    adj = adjugate4(shifted_davenport(H, inv, y + sqrt(eps) * a));
    strongest_column(adj, k, dk);
    noise = !(dk > T(64) * eps * a3);
    if (path) *path = noise ? 2 : 1;
    q = noise ? null_vector_closest_to_identity(shifted_davenport(H, inv, y), T(64) * eps) : ritz_top(adj, k, K, a, gap);
  }
  // Refinement passes at the Rayleigh quotient rho(q), which is backward stable (good to eps a):
  //  - gap between a / 64 and sqrt(eps) a (kappa between ~100 and 1/sqrt(eps)): y carried eps a^2 / g,
  //    leaving eps a / g of the far eigenvectors in the Ritz plane; a pass at rho brings that to eps.
  //    (Beyond 1/sqrt(eps) a pass is no better than the rounding of the adjugate itself, eps a / g.)
  //    Below kappa ~100 that residue is a few eps kappa, inside the accuracy suite's bound, and no pass runs
  //    (the careful path sees such gaps only for lanes the fast path left unconverged).
  //  - the adjugate was rounding noise.
  // A pass is kept unless rho drops beyond its rounding (8 eps a): at an exactly multiple root the
  // adjugate is noise and its Ritz vector lowers rho by O(a); NaN (an all-zero adjugate) too.
  const bool refine = noise || (!(gap > a / T(64)) && gap > sqrt(eps) * a);
  if (refine) {
    T rho = q.dot(K * q) / q.squaredNorm();
    for (int pass = 0; pass < 2; ++pass) {
      adj = adjugate4(shifted_davenport(H, inv, rho));
      strongest_column(adj, k, dk);
      const Eigen::Matrix<T, 4, 1> next = ritz_top(adj, k, K, a, gap);
      const T rho_next = next.dot(K * next) / next.squaredNorm();
      if (!(rho_next >= rho - T(8) * eps * a)) break;
      q = next;
      rho = rho_next;
    }
  }
  // Polish: one step of the power method on K + y I, whose eigenvalues lambda_i + y lie in [0, 2 y] with the
  // top one 2 y (|lambda_i| <= s1 + s2 + s3 and lambda_4 + y >= -2 s3 + ... >= 0): every component of q off
  // the top eigenvector shrinks by (lambda_i + y) / (2 y) <= 1 and none grows. Near a double root the
  // columns above carry O(sqrt(eps)) of the bottom eigenvectors (lambda = -s1 for rank-1 H), which this step
  // removes (factor O(sqrt(eps)) again), while the top plane is kept as it is (a multiple eigenvalue is
  // scaled uniformly, so the choice closest to the identity stands). Its own rounding is eps ||K|| / (2 y).
  // (Written out in the SIMD kernel's order of operations.)
  Eigen::Matrix<T, 4, 1> polished;
  for (int i = 0; i < 4; ++i)
    polished(i) = (K(i, 0) * q(0) + K(i, 1) * q(1) + K(i, 2) * q(2) + K(i, 3) * q(3)) + y * q(i);
  const T n2 = polished(0) * polished(0) + polished(1) * polished(1) + polished(2) * polished(2) +
               polished(3) * polished(3);
  if (n2 > T(0)) q = polished;  // y = 0: H = 0, q stays e0
  return q;
}

/// Eqs. (15) and (5) in homogeneous form: the rotation matrix of the unnormalised quaternion q = (w, x),
/// R = ((w^2 - |x|^2) I + 2 x x^T + 2 w [x]_x) / |q|^2, written entry by entry as kernels/sin_cos.hpp does.
template <class T>
Matrix3<T> rotation_from_quaternion(const Eigen::Matrix<T, 4, 1>& q) {
  const T w = q(0), x0 = q(1), x1 = q(2), x2 = q(3);
  const T inv_n = T(1) / (w * w + x0 * x0 + x1 * x1 + x2 * x2);
  const T c = w * w - (x0 * x0 + x1 * x1 + x2 * x2);
  const T xy = T(2) * x0 * x1, xz = T(2) * x0 * x2, yz = T(2) * x1 * x2;
  const T wx = T(2) * w * x0, wy = T(2) * w * x1, wz = T(2) * w * x2;
  Matrix3<T> R;
  R << (c + T(2) * x0 * x0) * inv_n, (xy - wz) * inv_n, (xz + wy) * inv_n,  //
      (xy + wz) * inv_n, (c + T(2) * x1 * x1) * inv_n, (yz - wx) * inv_n,   //
      (xz - wy) * inv_n, (yz + wx) * inv_n, (c + T(2) * x2 * x2) * inv_n;
  return R;
}

/// The careful path, for H the fast one cannot settle (a (nearly) multiple root of the quartic, a gap below
/// cbrt(eps) ||H||, a cluster of three eigenvalues of K): the closed form polished by Newton, then the
/// adjugate with Rayleigh-Ritz and its shifted, refined and null-space variants (maximum_root, rotation_axis).
template <class T>
Matrix3<T> fit_rotation_careful(const Matrix3<T>& H, const Invariants<T>& inv) {
  return rotation_from_quaternion(rotation_axis(H, inv, maximum_root(inv)));
}

/// The careful path's trigger (see fast_axis): tau = cbrt(eps) / 2 (cbrt(2^-23) = 2^-7.67, cbrt(2^-52) = 2^-17.33).
template <class T>
inline constexpr T kCarefulTau = sizeof(T) == 4 ? T(0.5 * 4.92156660e-3) : T(0.5 * 6.0554544523933395e-6);

/// Eq. (14), the fast path: with y from upper_bound_root, the column of A = adj(K - y I) with the largest
/// diagonal entry |a_kk| = dk, then one step of the power method, q = A a_k. Returns q and dk; the caller
/// takes the careful path (rotation_axis) instead where dk^2 <= tau^2 ||H||^6.
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
/// lambda3). Measured (proto at 4,000 cases per family): no case beyond the bound at tau = cbrt(eps) / 2,
/// and careful lanes are 0 on gaussian H and < 1e-3 on the point-set families.
/// A is symmetric: its 10 distinct entries from 11 complementary 2x2 minors of the row pairs (0, 1) and
/// (2, 3) of S = K - y I (the expressions of adjugate4 above), as kernels/rotation_axis.hpp computes them.
template <class T>
Eigen::Matrix<T, 4, 1> fast_axis(const Matrix3<T>& H, const Invariants<T>& inv, T y, T& dk) {
  const T S00 = inv.E - y, S11 = (T(2) * H(0, 0) - inv.E) - y, S22 = (T(2) * H(1, 1) - inv.E) - y,
          S33 = (T(2) * H(2, 2) - inv.E) - y;
  const T S01 = inv.z(0), S02 = inv.z(1), S03 = inv.z(2);
  const T S12 = H(0, 1) + H(1, 0), S13 = H(0, 2) + H(2, 0), S23 = H(1, 2) + H(2, 1);
  const T s0 = S00 * S11 - S01 * S01, s1 = S00 * S12 - S01 * S02, s2 = S00 * S13 - S01 * S03;
  const T s3 = S01 * S12 - S11 * S02, s4 = S01 * S13 - S11 * S03, s5 = S02 * S13 - S12 * S03;
  const T c5 = S22 * S33 - S23 * S23, c4 = S12 * S33 - S13 * S23, c3 = S12 * S23 - S13 * S22;
  const T c2 = S02 * S33 - S03 * S23, c1 = S02 * S23 - S03 * S22;
  Eigen::Matrix<T, 4, 4> A;
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

/// The whole fit (Algorithm 1, steps 3-7) on a finite, normalised H (max |H_ij| in [1, 2), or H = 0).
template <class T>
Matrix3<T> fit_rotation_axis_angle(const Matrix3<T>& H) {
  const Invariants<T> inv = invariants(H);
  bool converged;
  const T y = upper_bound_root(inv, converged);
  T dk;
  const Eigen::Matrix<T, 4, 1> q = fast_axis(H, inv, y, dk);
  const T n3 = inv.norm2 * inv.norm2 * inv.norm2;
  if (converged && dk * dk > kCarefulTau<T> * kCarefulTau<T> * n3) return rotation_from_quaternion(q);
  return fit_rotation_careful(H, inv);
}

}  // namespace mlsdeform::detail
