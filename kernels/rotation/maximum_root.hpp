// Stage "maximum_root" of Algorithm 1 (eq. 13) in SIMD lanes, twin of detail::maximum_root in
// core/src/rotation/maximum_root.hpp: Newton steps from an upper bound of the largest root. Lanes iterate
// under a mask; the loop ends when no lane is active.
#pragma once

#include "kernels/contract.hpp"
#include "kernels/rotation/invariants.hpp"

namespace mlsdeform::kernels {

/// The state of one batch's Newton iteration (maximum_root): the quartic's coefficients, the iterate, the
/// last step taken, and the lanes still stepping and those converged.
template <class V>
struct NewtonState {
  using M = mask_of<V>;
  V a, b, c, y, last;
  M active, converged;
};

/// The start of maximum_root: the coefficients and the upper bound y0 (see maximum_root).
template <class V>
MLSDEFORM_KERNEL_INLINE void newton_start(const Invariants<V>& inv, NewtonState<V>& s) {
  using T = scalar_of<V>;
  s.a = V(T(-2)) * inv.norm2, s.b = V(T(-8)) * inv.det, s.c = mul_add(inv.norm2, inv.norm2, V(T(-4)) * inv.c2);
  const V cross = select(inv.det < V(T(0)), inv.c2, V(T(3)) * inv.c2);
  s.y = sqrt(mul_add(V(T(2)), sqrt(cross), inv.norm2));
  s.active = s.y > V(T(0));
  s.converged = !s.active;  // H = 0 (identity, set by the caller)
  s.last = V(std::numeric_limits<T>::infinity());
}

/// One Newton step of maximum_root in the lanes still active (the others are left exactly as they are, so
/// that a batch may be stepped after its own lanes are done: maximum_root_tile).
template <class V>
MLSDEFORM_KERNEL_INLINE void newton_step(NewtonState<V>& s) {
  using T = scalar_of<V>;
  using M = mask_of<V>;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  constexpr T tol = T(0.25) * SimdCommon<T, 1>::sqrt_eps;
  const V y = s.y, y2 = y * y;
  const V p = mul_add(mul_add(y2 + s.a, y, s.b), y, s.c);
  const V d = mul_add(mul_add(V(T(4)), y2, V(T(2)) * s.a), y, s.b);
  const V step = p / d;
  const M reliable = d > V(T(64) * eps) * y2 * y;
  const M ok = s.active & reliable & (step > V(T(0))) & (step <= s.last);
  s.y = select(ok, y - step, y);
  s.last = select(ok, step, s.last);
  s.converged = s.converged | (s.active & reliable & (step <= V(tol) * s.y));
  s.active = ok & (step > V(tol) * s.y);
}

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
  NewtonState<V> s;
  newton_start(inv, s);
  for (int it = 0; it < kMaxNewton && any(s.active); ++it) newton_step(s);
  converged = s.converged;
  return s.y;
}

/// maximum_root for nb independent batches at once, their Newton steps interleaved: one batch's step is a
/// chain of dependent operations (a division among them) that leaves the core mostly idle; nb chains side
/// by side fill it. A batch whose lanes have all stopped is not stepped further (stepping it would leave it
/// unchanged: on point-set H a tile of four needs 5.6 rounds, its batches 4.7 each on average). Every lane
/// takes the same steps as in maximum_root (each batch steps while it has an active lane, at most
/// kMaxNewton times), so y and converged are bitwise maximum_root's.
///   Lanes, Error, Valid range: as maximum_root
template <std::size_t B, class V>
MLSDEFORM_KERNEL_INLINE void maximum_root_tile(const Invariants<V> (&inv)[B], std::size_t nb, V (&y)[B],
                                               mask_of<V> (&converged)[B]) {
  NewtonState<V> s[B];
  for (std::size_t b = 0; b < nb; ++b) newton_start(inv[b], s[b]);
  for (int it = 0; it < kMaxNewton; ++it) {
    bool more = false;
    for (std::size_t b = 0; b < nb; ++b)
      if (any(s[b].active)) newton_step(s[b]), more = true;
    if (!more) break;
  }
  for (std::size_t b = 0; b < nb; ++b) y[b] = s[b].y, converged[b] = s[b].converged;
}

}  // namespace mlsdeform::kernels
