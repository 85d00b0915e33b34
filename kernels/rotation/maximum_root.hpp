// Stage "maximum_root" of Algorithm 1 (eq. 13) in SIMD lanes, twin of detail::maximum_root in
// core/src/rotation/maximum_root.hpp: Newton steps from an upper bound of the largest root. Lanes iterate
// under a mask; the loop ends when no lane is active.
#pragma once

#include "kernels/contract.hpp"
#include "kernels/rotation/invariants.hpp"

namespace mlsdeform::kernels {

/// Eq. (13), the fast path: Newton's method on P(y) = ((y^2 - 2n) y - 8 det) y + (n^2 - 4 c2) from an upper
/// bound of its largest root y* = s1 + s2 + d s3 (n = ||H||^2 = sum s_i^2, c2 = sum_{i<j} s_i^2 s_j^2):
///   det >= 0: y*^2 = n + 2 (s1 s2 + s1 s3 + s2 s3) <= n + 2 sqrt(3 c2)   (Cauchy-Schwarz)
///   det <  0: y*^2 = n + 2 (s1 s2 - s1 s3 - s2 s3) <= n + 2 sqrt(c2)     (s1 s2 <= sqrt(c2))
/// Above y* the quartic is increasing and convex (all four roots are <= y*), so Newton's steps decrease y
/// monotonically to y* with no bracketing. A lane stops when its step falls below sqrt(eps)/4 of y (the
/// next error is then O(step^2 / gap): rounding level for a simple root) and counts as converged; it
/// stops unconverged where P' sinks to its own rounding (64 eps y^3: P and P' are then noise, a (nearly)
/// multiple root), where a step fails to shrink, or after kMaxNewton steps. `converged` returns the lanes
/// whose y is the root to rounding; the others take the careful path (axis_angle.hpp).
///   Lanes:       float, double (an xsimd batch, or a Pair of them)
///   Error:       a converged y within 2 gamma_8 Pabs(y) / P'(y) + (3/16) (kappa + 1) eps y of the root
///                (Pabs: P with every coefficient's absolute value; kappa = s1 / (s2 + d s3)): the rounding of
///                P over its slope, and the truncation of the last Newton step (tests/test_stages.cpp)
///   Valid range: the invariants of a finite normalised H; y = 0 and converged where H = 0
template <class V, class M = mask_of<V>>
MLSDEFORM_KERNEL_INLINE V maximum_root(const Invariants<V>& inv, M& converged) {
  using T = scalar_of<V>;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  const V a = V(T(-2)) * inv.norm2, b = V(T(-8)) * inv.det, c = mul_add(inv.norm2, inv.norm2, V(T(-4)) * inv.c2);
  const V cross = select(inv.det < V(T(0)), inv.c2, V(T(3)) * inv.c2);
  V y = sqrt(mul_add(V(T(2)), sqrt(cross), inv.norm2));
  constexpr T tol = T(0.25) * SimdCommon<T, 1>::sqrt_eps;
  M active = y > V(T(0));
  converged = !active;  // H = 0 (identity, set by the caller)
  V last(std::numeric_limits<T>::infinity());
  for (int it = 0; it < kMaxNewton && any(active); ++it) {
    const V y2 = y * y;
    const V p = mul_add(mul_add(y2 + a, y, b), y, c);
    const V d = mul_add(mul_add(V(T(4)), y2, V(T(2)) * a), y, b);
    const V step = p / d;
    const M reliable = d > V(T(64) * eps) * y2 * y;
    const M ok = active & reliable & (step > V(T(0))) & (step <= last);
    y = select(ok, y - step, y);
    last = select(ok, step, last);
    converged = converged | (active & reliable & (step <= V(tol) * y));
    active = ok & (step > V(tol) * y);
  }
  return y;
}

}  // namespace mlsdeform::kernels
