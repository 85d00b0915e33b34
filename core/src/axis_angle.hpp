// The paper's closed-form rotation fit (Sec. 4.3-4.6, Algorithm 1 steps 3-7), scalar reference.
//
// Written to be read beside the paper; the SIMD kernels (kernels/fit_rotations.hpp and the stage headers it
// includes) compute the same stages in the same order. Column-vector convention (see rotation.hpp):
// H = sum w q p^T is the paper's M.
//
// Two paths. The fast path settles almost every H (all but ~1e-3 of random point-set matrices, none of 10^6
// Gaussian H): upper_bound_root, fast_axis, sin_cos. The careful path takes the rest (a multiple or nearly
// multiple root of (13), e.g. rank-1 H from collinear handles; a gap s2 + d s3 below cbrt(eps) s1; three
// clustered eigenvalues of K): top_eigenvector (Jacobi), sin_cos.
//
// Stages, with the paper's routine names (Table 1):
//   normalise          H <- 2^-e H so that max |H_ij| is in [1, 2): exact, so the result is bitwise
//                      invariant under power-of-two scaling and no product (det^2, ||H||^4) can overflow.
//   invariants (6)     E = trace H, V, ||H||^2, det H, and c2 = sum_{i<j} |H_i x H_j|^2 (columns H_i).
//   maximum_root (13)  largest root y of y^4 - 2||H||^2 y^2 - 8 det(H) y + (||H||^4 - 4 c2), the optimal
//                      trace s1 + s2 + d s3, by Newton's method from an upper bound (upper_bound_root). (The
//                      paper's closed form through the resolvent cubic, Sec. 4.4, is exact in exact
//                      arithmetic but loses up to eps^(1/2) in floating point and needs a Newton polish anyway.)
//   rotation_axis (14) The rotation's quaternion (cos(a/2), e sin(a/2)) is the eigenvector of Davenport's
//                      K = [[E, z^T], [z, N - E I]] (z = -V, N = H + H^T) for the eigenvalue y; the
//                      paper's system (N - lambda I) u = V with lambda = y + E is the last three rows of
//                      (K - y I) q = 0 divided by q0, u the Gibbs vector e tan(a/2). It is singular as
//                      a -> pi (q0 -> 0) and when V e = 0. We solve in homogeneous form instead: every
//                      column of adj(K - y I) is proportional to q q_k, and column 0 is the paper's
//                      (14) by Cramer's rule (q0 = det(N - lambda I), q_vec = -adj(N - lambda I) z). We take
//                      the column k with the largest diagonal cofactor (|q_k| largest, so >= 1/2 of |q|):
//                      Shuster and Oh's sequential rotations, i.e. (14) written in a frame turned by pi
//                      about axis k; then one power step with the adjugate (fast_axis). Where the adjugate
//                      vanishes or is too small to trust (y a (nearly) multiple root) the careful path
//                      takes K's top eigenvector, or, for a multiple top eigenvalue, the optimal rotation
//                      closest to the identity (top_eigenvector).
//   sin_cos (15)       cos a = (q0^2 - |q_vec|^2) / |q|^2 and sin a = 2 q0 |q_vec| / |q|^2, the homogeneous
//                      forms of (1 - |u|^2)/(1 + |u|^2) and 2|u|/(1 + |u|^2); with e = q_vec / |q_vec|,
//                      (5) becomes R = ((q0^2 - |q_vec|^2) I + 2 q_vec q_vec^T + 2 q0 [q_vec]_x) / |q|^2.
#pragma once

#include <mlsdeform/rotation.hpp>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>

namespace mlsdeform::detail {

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
/// kMaxNewtonFast steps; those H take the careful path (top_eigenvector).
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

/// The careful path's eigensolver: cyclic Jacobi on the symmetric 4x4 a, in the order, with the skip threshold
/// (|a_pq| <= eps ||a||_F) and the stopping rule of kernels/jacobi.hpp (see there); v receives the
/// eigenvectors (columns), a's diagonal the eigenvalues.
template <class T>
void jacobi_eigen(Eigen::Matrix<T, 4, 4>& a, Eigen::Matrix<T, 4, 4>& v) {
  using std::abs;
  using std::sqrt;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  v.setIdentity();
  const T small = eps * a.norm();
  for (int sweep = 0; sweep < 12; ++sweep) {
    for (int p = 0; p < 3; ++p)
      for (int q = p + 1; q < 4; ++q) {
        const T apq = a(p, q);
        if (abs(apq) <= small) {
          a(p, q) = a(q, p) = T(0);
          continue;
        }
        const T theta = (a(q, q) - a(p, p)) / (T(2) * apq);
        const T t0 = T(1) / (abs(theta) + sqrt(theta * theta + T(1)));  // 0 where theta^2 overflows
        const T t = theta < T(0) ? -t0 : t0;
        const T c = T(1) / sqrt(t * t + T(1)), s = t * c;
        a(p, p) -= t * apq;
        a(q, q) += t * apq;
        a(p, q) = a(q, p) = T(0);
        for (int k = 0; k < 4; ++k) {
          if (k == p || k == q) continue;
          const T akp = a(k, p), akq = a(k, q);
          a(k, p) = a(p, k) = c * akp - s * akq;
          a(k, q) = a(q, k) = s * akp + c * akq;
        }
        for (int k = 0; k < 4; ++k) {
          const T vkp = v(k, p), vkq = v(k, q);
          v(k, p) = c * vkp - s * vkq;
          v(k, q) = s * vkp + c * vkq;
        }
      }
    if (sweep < 2) continue;
    T off = T(0);
    for (int p = 0; p < 3; ++p)
      for (int q = p + 1; q < 4; ++q) off = std::max(off, abs(a(p, q)));
    if (!(off > small)) break;
  }
}

/// Eq. (14) on the careful path: the (unnormalised) top eigenvector of K, or where the top eigenvalue is
/// multiple to rounding (within 8 eps max|K_ij|: rank-1 H, a point reflection H = -s R, H = s diag(1, -1, -1)
/// ...) the vector of its eigenspace closest to e0 = (1, 0, 0, 0), the identity rotation: q = sum_{j in top}
/// v_j v_j(m) with m = 0, or where e0 is nearly orthogonal to the eigenspace (its projection below a quarter
/// of the largest) the axis e_m with the largest projection; so that neighbouring vertices of a deformation
/// make the same choice. With a single top eigenvalue the same formula gives v_1 v_1(m), a non-zero multiple
/// of v_1. Jacobi is backward stable whatever the spectrum (multiple, clustered or nearly double
/// eigenvalues), which is what the careful path's lanes have.
template <class T>
Eigen::Matrix<T, 4, 1> top_eigenvector(const Eigen::Matrix<T, 4, 4>& K) {
  using Vec4 = Eigen::Matrix<T, 4, 1>;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  Eigen::Matrix<T, 4, 4> a = K, v;
  jacobi_eigen(a, v);
  const Vec4 d = a.diagonal();
  const T floor = d.maxCoeff() - T(8) * eps * K.cwiseAbs().maxCoeff();
  Vec4 proj = Vec4::Zero();
  for (int j = 0; j < 4; ++j)
    if (d(j) >= floor) proj += v.col(j).cwiseAbs2();
  int m;
  const T pm = proj.maxCoeff(&m);
  if (proj(0) >= T(0.25) * pm) m = 0;
  Vec4 q = Vec4::Zero();
  for (int j = 0; j < 4; ++j)
    if (d(j) >= floor) q += v.col(j) * v(m, j);
  return q;
}

/// The careful path, for H the fast one cannot settle (a (nearly) multiple root of the quartic, a gap below
/// cbrt(eps) ||H||, a cluster of three eigenvalues of K): top_eigenvector.
template <class T>
Matrix3<T> fit_rotation_careful(const Matrix3<T>& H, const Invariants<T>& inv) {
  return rotation_from_quaternion(top_eigenvector(shifted_davenport(H, inv, T(0))));
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
/// (2, 3) of S = K - y I (Laplace expansion by complementary minors), as kernels/rotation_axis.hpp computes them.
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
