// Fixed point handles folded into four (a region's ring, region.hpp). A point handle j whose target is its rest
// position p_j for good enters every frame only through the constant terms omega_j p_j of q* and p_j A_j^T of H
// (data.hpp), or alpha_j p_j of the affine v'. Those terms of any number of such handles equal the terms of
// four pseudo-handles with fixed targets z_0 = o and z_m = o + s e_m (m = 1, 2, 3: o moved by s along axis
// m - 1), with coefficients
//   c'_0 = sum_j (1 - d_j0 - d_j1 - d_j2) c_j,   c'_m = sum_j d_j(m-1) c_j,   d_j = (p_j - o) / s,
// for every per-handle coefficient c (omega, the three components of A, alpha): since sum_m beta_jm = 1 and
// sum_m beta_jm z_m = o + s d_j = p_j for beta_j = (1 - d_j0 - d_j1 - d_j2, d_j0, d_j1, d_j2), the sums
// sum_j c_j = sum_m c'_m and sum_j c_j p_j = sum_m c'_m z_m hold exactly in real arithmetic, and the per-frame
// algebra (linear in the coefficients) gives the same q*, H and v'. A frame then costs 4 columns for them
// instead of one per handle.
//
// Rounding. o is the handles' bounding-box centre rounded to a multiple of s, and s a power of two at least the
// box's extent (and at least 2^-(digits(T) - 2) |o|, so that o / s has fewer than digits(T) - 1 bits): then o and
// o + s e_m are exact in T, |d_jc| <= 1, |beta_j0| <= 4 and |beta_jm| <= 1 for m > 0, so the folded
// coefficients are at most 7 sum_j |c_j|, with targets no farther from the handles than 2 s. The kernels' rounding of
// the four folded terms is then that of at most 16 terms of the handles' own size, instead of one per handle; only a
// vertex snapped to a fixed handle (snap.hpp) loses its exact interpolation, and lands within a few eps(T) |z| of
// it. Callers fold more than four handles only (fewer would add columns).
#pragma once

#include <mlsdeform/types.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace mlsdeform::detail {

/// The pseudo-handles that fixed handles fold into.
inline constexpr std::size_t kFoldedHandles = 4;

/// The targets z_0 .. z_3 (rows) for fixed handles at the rows of `p` (see the file comment); p has a row.
template <class T>
Points<T> fold_targets(const Points<T>& p) {
  Eigen::Vector3d lo = p.row(0).template cast<double>().transpose(), hi = lo;
  for (Eigen::Index i = 1; i < p.rows(); ++i) {
    lo = lo.cwiseMin(p.row(i).template cast<double>().transpose());
    hi = hi.cwiseMax(p.row(i).template cast<double>().transpose());
  }
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const double extent = (hi - lo).maxCoeff(), size = centre.cwiseAbs().maxCoeff();
  int e = extent > 0 ? std::ilogb(extent) + 1 : std::numeric_limits<T>::min_exponent;  // 2^e > extent
  if (size > 0) e = std::max(e, std::ilogb(size) - std::numeric_limits<T>::digits + 2);
  const double s = std::ldexp(1.0, e);
  Points<T> z(Eigen::Index(kFoldedHandles), 3);
  for (int c = 0; c < 3; ++c) {
    const double o = s * std::nearbyint(centre[c] / s);
    for (Eigen::Index m = 0; m < Eigen::Index(kFoldedHandles); ++m) z(m, c) = T(m == c + 1 ? o + s : o);
  }
  return z;
}

/// beta_j (file comment) of every fixed handle at the rows of `p`, for the targets z = fold_targets(p):
/// 4 values per handle, in the rows' order.
template <class T>
std::vector<std::array<double, kFoldedHandles>> fold_weights(const Points<T>& p, const Points<T>& z) {
  const double s = double(z(1, 0)) - double(z(0, 0));  // exact: both are multiples of s below 2^digits(T) s
  std::vector<std::array<double, kFoldedHandles>> beta(std::size_t(p.rows()));
  for (Eigen::Index j = 0; j < p.rows(); ++j) {
    double d[3];
    for (int c = 0; c < 3; ++c) d[c] = (double(p(j, c)) - double(z(0, c))) / s;
    beta[std::size_t(j)] = {1 - d[0] - d[1] - d[2], d[0], d[1], d[2]};
  }
  return beta;
}

/// Replaces x[first .. first + F) (F = beta.size()) by the 4 folded coefficients sum_j beta_jm x[first + j],
/// moving the entries after them down: x.size() becomes J - F + 4. X is double or Eigen::Vector3d.
template <class X>
void fold_columns(std::vector<X>& x, std::size_t first, const std::vector<std::array<double, kFoldedHandles>>& beta) {
  std::array<X, kFoldedHandles> sum;
  sum.fill(X(x[first] * 0.0));
  for (std::size_t j = 0; j < beta.size(); ++j)
    for (std::size_t m = 0; m < kFoldedHandles; ++m) sum[m] += beta[j][m] * x[first + j];
  std::copy(sum.begin(), sum.end(), x.begin() + std::ptrdiff_t(first));
  x.erase(x.begin() + std::ptrdiff_t(first + kFoldedHandles), x.begin() + std::ptrdiff_t(first + beta.size()));
}

}  // namespace mlsdeform::detail
