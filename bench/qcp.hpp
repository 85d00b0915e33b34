// QCP, the quaternion characteristic polynomial method (Theobald 2005, Acta Cryst. A61:478; Liu, Agrafiotis,
// Theobald 2010, J. Comput. Chem. 31:1561), written here from the papers as an extra baseline for the
// rotation-fit benchmark: the fastest widely used alternative to the paper's axis/angle method.
//
// Both methods look for the largest eigenvalue of the same traceless 4x4 matrix K (Davenport's; Theobald's
// "key matrix"), whose characteristic polynomial is the paper's quartic (13):
//   P(lambda) = lambda^4 + c2 lambda^2 + c1 lambda + c0,  c2 = -2 ||H||_F^2,  c1 = -8 det H,  c0 = det K.
// They differ in how they get there and what they do next:
//   * root: Theobald runs Newton on P from an upper bound of the largest root (he uses (G_A + G_B) / 2, the
//     mean inner product of the two point sets, which we do not have from H alone; we start from
//     sqrt(3) ||H||_F >= s1 + s2 + s3 >= lambda_max, Cauchy-Schwarz). Newton from above decreases
//     monotonically to the largest root. Stop as Liu et al. do, when a step is below tau lambda, with
//     tau = eps^(2/3) (the next step would move lambda by ~ tau^2 lambda, below rounding; Liu et al.'s
//     1e-11 in double is this rule), at most 50 steps. We also stop when a step fails to decrease lambda:
//     that happens only once rounding dominates P near a multiple root, where unguarded steps random-walk
//     (and a step at P' ~ 0 can throw lambda to another root).
//   * eigenvector: Liu et al. take a column of adj(K - lambda I), which is P'(lambda) q q^T for the unit
//     eigenvector q, trying columns 0, 1, 2, 3 in turn until one is long enough. Their test is an absolute
//     |column|^2 >= 1e-6 (coordinates in Angstrom); we use the scale-free form |column|^2 >= P'(lambda)^2/256,
//     i.e. |q_k| >= 1/16 (some |q_k| >= 1/2 always exists, so a column always passes unless P' vanishes,
//     a multiple root; then the longest column is taken, and the identity if all are zero, as Liu et al.).
//   * c0 = det K: Theobald expands it in the entries of the correlation matrix; we evaluate det K by Laplace
//     expansion in complementary 2x2 minors (the same polynomial, ~40 flops).
// Like fit_rotation, H is first scaled by an exact power of two (max |H_ij| in [1, 2)) so that the
// degree-4 coefficients cannot overflow; the paper's axis/angle method gets the same treatment.
#pragma once

#include <mlsdeform/rotation.hpp>

#include <Eigen/Core>

#include <cmath>
#include <limits>

namespace bench {

/// Statistics of one QCP fit, for the benchmark's counters.
struct QcpInfo {
  int newton = 0;  ///< Newton steps taken
  int column = 0;  ///< adjugate column used (0..3), 4 for the identity fallback
};

namespace qcp_detail {

template <class T>
using Mat4 = Eigen::Matrix<T, 4, 4>;
template <class T>
using Vec4 = Eigen::Matrix<T, 4, 1>;

/// Column k of adj(A) for a symmetric 4x4 A: adj(A)(i, k) = (-1)^(i+k) det(A with row k and column i
/// removed). The three remaining rows r0 < r1 < r2; the 2x2 minors of rows (r1, r2) are shared, and each
/// 3x3 determinant is expanded along row r0.
template <class T>
Vec4<T> adjugate_column(const Mat4<T>& A, int k) {
  int r[3], n = 0;
  for (int i = 0; i < 4; ++i)
    if (i != k) r[n++] = i;
  const int a = r[1], b = r[2];
  // m(c, d) = A(a, c) A(b, d) - A(a, d) A(b, c), c < d.
  const T m01 = A(a, 0) * A(b, 1) - A(a, 1) * A(b, 0), m02 = A(a, 0) * A(b, 2) - A(a, 2) * A(b, 0);
  const T m03 = A(a, 0) * A(b, 3) - A(a, 3) * A(b, 0), m12 = A(a, 1) * A(b, 2) - A(a, 2) * A(b, 1);
  const T m13 = A(a, 1) * A(b, 3) - A(a, 3) * A(b, 1), m23 = A(a, 2) * A(b, 3) - A(a, 3) * A(b, 2);
  const int t = r[0];
  // det of the 3x3 on rows (t, a, b) and the columns other than i, expanded along row t.
  const T d0 = A(t, 1) * m23 - A(t, 2) * m13 + A(t, 3) * m12;  // columns 1, 2, 3
  const T d1 = A(t, 0) * m23 - A(t, 2) * m03 + A(t, 3) * m02;  // columns 0, 2, 3
  const T d2 = A(t, 0) * m13 - A(t, 1) * m03 + A(t, 3) * m01;  // columns 0, 1, 3
  const T d3 = A(t, 0) * m12 - A(t, 1) * m02 + A(t, 2) * m01;  // columns 0, 1, 2
  // Removing row k moves row t to position 0 of the minor only when k > t, etc.; the sign of the cofactor
  // is (-1)^(i+k), and the minor's own row order (t, a, b) is the natural order, so no extra sign.
  const T s = (k % 2 == 0) ? T(1) : T(-1);
  return Vec4<T>(s * d0, -s * d1, s * d2, -s * d3);
}

/// det of a 4x4 by Laplace expansion along rows (0, 1) against rows (2, 3).
template <class T>
T det4(const Mat4<T>& A) {
  const T s0 = A(0, 0) * A(1, 1) - A(1, 0) * A(0, 1), s1 = A(0, 0) * A(1, 2) - A(1, 0) * A(0, 2);
  const T s2 = A(0, 0) * A(1, 3) - A(1, 0) * A(0, 3), s3 = A(0, 1) * A(1, 2) - A(1, 1) * A(0, 2);
  const T s4 = A(0, 1) * A(1, 3) - A(1, 1) * A(0, 3), s5 = A(0, 2) * A(1, 3) - A(1, 2) * A(0, 3);
  const T c5 = A(2, 2) * A(3, 3) - A(3, 2) * A(2, 3), c4 = A(2, 1) * A(3, 3) - A(3, 1) * A(2, 3);
  const T c3 = A(2, 1) * A(3, 2) - A(3, 1) * A(2, 2), c2 = A(2, 0) * A(3, 3) - A(3, 0) * A(2, 3);
  const T c1 = A(2, 0) * A(3, 2) - A(3, 0) * A(2, 2), c0 = A(2, 0) * A(3, 1) - A(3, 0) * A(2, 1);
  return s0 * c5 - s1 * c4 + s2 * c3 + s3 * c2 - s4 * c1 + s5 * c0;
}

/// The rotation of the (unnormalised) quaternion q = (w, x, y, z).
template <class T>
mlsdeform::Matrix3<T> rotation(const Vec4<T>& q) {
  const T w = q(0), x = q(1), y = q(2), z = q(3);
  const T n = T(1) / q.squaredNorm();
  mlsdeform::Matrix3<T> R;
  R << (w * w + x * x - y * y - z * z) * n, T(2) * (x * y - w * z) * n, T(2) * (x * z + w * y) * n,
      T(2) * (x * y + w * z) * n, (w * w - x * x + y * y - z * z) * n, T(2) * (y * z - w * x) * n,
      T(2) * (x * z - w * y) * n, T(2) * (y * z + w * x) * n, (w * w - x * x - y * y + z * z) * n;
  return R;
}

}  // namespace qcp_detail

/// The proper rotation maximising trace(R^T H) by QCP (see the file comment). H must be finite.
template <class T>
mlsdeform::Matrix3<T> fit_rotation_qcp(const mlsdeform::Matrix3<T>& H_in, QcpInfo* info = nullptr) {
  using namespace qcp_detail;
  using std::abs;
  using std::sqrt;
  const T m = H_in.cwiseAbs().maxCoeff();
  if (m == T(0)) return mlsdeform::Matrix3<T>::Identity();
  const mlsdeform::Matrix3<T> H = H_in * std::ldexp(T(1), -std::ilogb(m));

  // K (column convention; trace(R(q)^T H) = q^T K q / |q|^2): [[E, z^T], [z, H + H^T - E I]].
  const T E = H.trace();
  Mat4<T> K;
  K(0, 0) = E;
  K(1, 0) = K(0, 1) = H(2, 1) - H(1, 2);
  K(2, 0) = K(0, 2) = H(0, 2) - H(2, 0);
  K(3, 0) = K(0, 3) = H(1, 0) - H(0, 1);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) K(1 + i, 1 + j) = H(i, j) + H(j, i) - (i == j ? E : T(0));

  const T norm2 = H.squaredNorm();
  const T c2 = T(-2) * norm2;
  const T c1 = T(-8) * H.determinant();
  const T c0 = det4(K);

  // Newton from the upper bound.
  const T tau = std::cbrt(std::numeric_limits<T>::epsilon() * std::numeric_limits<T>::epsilon());
  T lambda = sqrt(T(3) * norm2);
  T dP = T(0);
  int it = 0;
  for (; it < 50; ++it) {
    const T l2 = lambda * lambda;
    const T P = ((l2 + c2) * lambda + c1) * lambda + c0;
    dP = (T(4) * l2 + T(2) * c2) * lambda + c1;
    const T step = P / dP;
    // From above the largest root, P > 0 and P' > 0: a step that does not decrease lambda (or a NaN from
    // P' = 0) means rounding has taken over near a multiple root; stop rather than wander.
    if (!(step > T(0))) break;
    lambda -= step;
    if (abs(step) < tau * abs(lambda)) {
      ++it;
      break;
    }
  }
  {
    const T l2 = lambda * lambda;
    dP = (T(4) * l2 + T(2) * c2) * lambda + c1;
  }

  // Eigenvector: the first adjugate column with |q_k| >= 1/16, else the longest.
  Mat4<T> A = K;
  A.diagonal().array() -= lambda;
  const T threshold = dP * dP / T(256);
  Vec4<T> q, best = Vec4<T>::Zero();
  T best_sq = T(0);
  int column = 4;
  for (int k = 0; k < 4; ++k) {
    q = adjugate_column(A, k);
    const T sq = q.squaredNorm();
    if (sq > T(0) && sq >= threshold) {
      column = k;
      best = q;
      best_sq = sq;
      break;
    }
    if (sq > best_sq) {
      best_sq = sq;
      best = q;
      column = k;
    }
  }
  if (info) {
    info->newton = it;
    info->column = best_sq > T(0) ? column : 4;
  }
  if (!(best_sq > T(0))) return mlsdeform::Matrix3<T>::Identity();
  return rotation(best);
}

}  // namespace bench
