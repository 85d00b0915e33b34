// Stage "maximum_root" of Algorithm 1 (eq. 13) in SIMD lanes, mirroring core/src/axis_angle.hpp:
// invariants (eq. 6), then Newton steps from an upper bound of the root (upper_bound_root). Lanes iterate
// under a mask; the loop ends when no lane is active.
#pragma once

#include "simd.hpp"

namespace mlsdeform::kernels {

template <class T, class A>
struct QuarticRoot : Simd<T, A> {
  using typename Simd<T, A>::V;
  using typename Simd<T, A>::M;
  using Simd<T, A>::eps;

  struct Invariants {
    V E;            // trace H
    V z0, z1, z2;   // (H21 - H12, H02 - H20, H10 - H01) = -V of eq. (6)
    V norm2;        // ||H||_F^2
    V det;          // det H
    V c2;           // sum_{i<j} |H_i x H_j|^2 over columns
  };

  /// h[3 r + c] = H(r, c), normalised. Sums of products are fused (xsimd::fma: one rounding on FMA ISAs,
  /// a product and a sum on SSE4.2).
  MLSDEFORM_KERNEL_INLINE static Invariants invariants(const V (&h)[9]) {
    Invariants inv;
    inv.E = h[0] + h[4] + h[8];
    inv.z0 = h[7] - h[5];
    inv.z1 = h[2] - h[6];
    inv.z2 = h[3] - h[1];
    V n = h[0] * h[0];
    for (int i = 1; i < 9; ++i) n = mul_add(h[i], h[i], n);
    inv.norm2 = n;
    // Columns c0 = (h0, h3, h6), c1 = (h1, h4, h7), c2 = (h2, h5, h8); x01 = c0 x c1 and so on.
    const V x01a = mul_sub(h[3], h[7], h[6] * h[4]), x01b = mul_sub(h[6], h[1], h[0] * h[7]), x01c = mul_sub(h[0], h[4], h[3] * h[1]);
    const V x02a = mul_sub(h[3], h[8], h[6] * h[5]), x02b = mul_sub(h[6], h[2], h[0] * h[8]), x02c = mul_sub(h[0], h[5], h[3] * h[2]);
    const V x12a = mul_sub(h[4], h[8], h[7] * h[5]), x12b = mul_sub(h[7], h[2], h[1] * h[8]), x12c = mul_sub(h[1], h[5], h[4] * h[2]);
    inv.det = mul_add(x01a, h[2], mul_add(x01b, h[5], x01c * h[8]));
    const V x[9] = {x01a, x01b, x01c, x02a, x02b, x02c, x12a, x12b, x12c};
    V c2 = x[0] * x[0];
    for (int i = 1; i < 9; ++i) c2 = mul_add(x[i], x[i], c2);
    inv.c2 = c2;
    return inv;
  }

  /// Newton steps allowed; lanes still moving after them take the careful path.
  static constexpr int kMaxNewton = 16;

  /// Eq. (13), the fast path: Newton's method on P(y) = ((y^2 - 2n) y - 8 det) y + (n^2 - 4 c2) from an upper
  /// bound of its largest root y* = s1 + s2 + d s3 (n = ||H||^2 = sum s_i^2, c2 = sum_{i<j} s_i^2 s_j^2):
  ///   det >= 0: y*^2 = n + 2 (s1 s2 + s1 s3 + s2 s3) <= n + 2 sqrt(3 c2)   (Cauchy-Schwarz)
  ///   det <  0: y*^2 = n + 2 (s1 s2 - s1 s3 - s2 s3) <= n + 2 sqrt(c2)     (s1 s2 <= sqrt(c2))
  /// Above y* the quartic is increasing and convex (all four roots are <= y*), so Newton's steps decrease y
  /// monotonically to y* with no bracketing. A lane stops when its step falls below sqrt(eps)/4 of y (the
  /// next error is then O(step^2 / gap): rounding level for a simple root) and counts as converged; it
  /// stops unconverged where P' sinks to its own rounding (64 eps y^3: P and P' are then noise, a (nearly)
  /// multiple root), where a step fails to shrink, or after kMaxNewton steps. `converged` returns the lanes
  /// whose y is the root to rounding; the others take the careful path (fit_rotations.hpp).
  MLSDEFORM_KERNEL_INLINE static V upper_bound_root(const Invariants& inv, M& converged) {
    const V a = V(T(-2)) * inv.norm2, b = V(T(-8)) * inv.det, c = mul_add(inv.norm2, inv.norm2, V(T(-4)) * inv.c2);
    const V cross = select(inv.det < V(T(0)), inv.c2, V(T(3)) * inv.c2);
    V y = sqrt(mul_add(V(T(2)), sqrt(cross), inv.norm2));
    constexpr T tol = T(0.25) * Simd<T, A>::sqrt_eps;
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
};

}  // namespace mlsdeform::kernels
