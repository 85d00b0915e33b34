// Stage "maximum_root" of Algorithm 1 (eq. 13), scalar reference: the largest root y of
// y^4 - 2||H||^2 y^2 - 8 det(H) y + (||H||^4 - 4 c2), the optimal trace s1 + s2 + d s3, by Newton's method
// from an upper bound. (The paper's closed form through the resolvent cubic, Sec. 4.4, is exact in exact
// arithmetic but loses up to eps^(1/2) in floating point and needs a Newton polish anyway.) SIMD twin:
// kernels/rotation/maximum_root.hpp.
#pragma once

#include "core/src/rotation/invariants.hpp"

#include "kernels/contract.hpp"

#include <cmath>
#include <limits>

namespace mlsdeform::detail {

/// Eq. (13), the fast path: Newton's method on the quartic from an upper bound of its largest root
/// y* = s1 + s2 + d s3 (n = ||H||^2 = sum s_i^2, c2 = sum_{i<j} s_i^2 s_j^2, d = sign det H):
///   det >= 0: y*^2 = n + 2 (s1 s2 + s1 s3 + s2 s3) <= n + 2 sqrt(3 c2)   (Cauchy-Schwarz)
///   det <  0: y*^2 = n + 2 (s1 s2 - s1 s3 - s2 s3) <= n + 2 sqrt(c2)     (s1 s2 <= sqrt(c2))
/// Above y* the quartic is increasing and convex (its four roots are the eigenvalues of K, all <= y*), so
/// Newton's steps decrease y monotonically to y*: no closed form and no bracketing (3-6 steps on generic H).
/// A step below sqrt(eps)/4 of y ends the iteration converged (the error left is O(step^2 / gap), rounding
/// level for a simple root). It ends unconverged where P' sinks below 64 eps y^3, its own rounding (P and
/// P' are then noise: a (nearly) multiple root, e.g. rank-1 H), where a step fails to shrink, or after
/// kernels::kMaxNewton steps; those H take the careful path (top_eigenvector).
template <class T>
T maximum_root(const Invariants<T>& inv, bool& converged) {
  using std::sqrt;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  const T a = T(-2) * inv.norm2, b = T(-8) * inv.det, c = inv.norm2 * inv.norm2 - T(4) * inv.c2;
  T y = sqrt(inv.norm2 + T(2) * sqrt(inv.det < T(0) ? inv.c2 : T(3) * inv.c2));
  const T tol = T(0.25) * sqrt(eps);
  converged = !(y > T(0));  // H = 0
  T last = std::numeric_limits<T>::infinity();
  for (int it = 0; it < kernels::kMaxNewton && y > T(0); ++it) {
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

}  // namespace mlsdeform::detail
