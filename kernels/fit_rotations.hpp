// The batched axis/angle rotation fit (Algorithm 1 steps 3-7), one matrix per SIMD lane:
// normalise -> invariants (6) -> maximum_root (13) -> rotation_axis (14) -> sin_cos (15)/(5) for every lane,
// and for the lanes this fast path cannot settle a careful path: K's top eigenvector by Jacobi.
// Same stages, same order as detail::fit_rotation_axis_angle in core/src/axis_angle.hpp.
#pragma once

#include "jacobi.hpp"
#include "kernel_table.hpp"
#include "quartic_root.hpp"
#include "rotation_axis.hpp"
#include "sin_cos.hpp"

namespace mlsdeform::kernels {

template <class T, class A>
struct FitRotations : Simd<T, A> {
  using typename Simd<T, A>::V;
  using typename Simd<T, A>::M;
  using Simd<T, A>::W;
  using Q = QuarticRoot<T, A>;
  using RA = RotationAxis<T, A>;

  /// The careful path's trigger, tau = cbrt(eps) / 2 on |adj_kk| / ||H||^3 (scalar: kCarefulTau; derived
  /// there). cbrt(eps) as a literal: no std::cbrt may be emitted in an ISA object.
  static constexpr T tau = sizeof(T) == 4 ? T(0.5 * 4.92156660e-3) : T(0.5 * 6.0554544523933395e-6);

  /// h: 9 lanes of H (row-major entries), not yet normalised; r: the rotations. Lanes with H = 0 get the
  /// identity. Every lane takes the fast path (upper_bound_root, fast_axis); the lanes it cannot settle
  /// (a multiple or unconverged root, or a gap below cbrt(eps)) take the careful path, the top eigenvector
  /// of K by Jacobi (run only when some lane needs it). Counts the careful lanes in stats.near_double.
  MLSDEFORM_KERNEL_INLINE static void fit(V (&h)[9], V (&r)[9], RotationStats& stats) {
    V m = abs(h[0]);
    for (int i = 1; i < 9; ++i) m = max(m, abs(h[i]));
    const M zero = m == V(T(0));
    const V scale = Simd<T, A>::pow2_inverse_exponent(select(zero, V(T(1)), m));
    for (int i = 0; i < 9; ++i) h[i] = h[i] * scale;
    const typename Q::Invariants inv = Q::invariants(h);
    M converged;
    const V y = Q::upper_bound_root(inv, converged);
    const typename RA::Mat4 K = RA::davenport(h, inv.E, inv.z0, inv.z1, inv.z2);
    V dk;
    typename RA::Vec4 q = RA::fast_axis(K, y, dk);
    const V n3 = inv.norm2 * inv.norm2 * inv.norm2;
    const M careful = ~zero & (~converged | ~(dk * dk > V(tau * tau) * n3));
    if (any(careful)) {
      V q1[4];
      Jacobi<T, A>::top_eigenvector(K.k, sqrt(V(T(4)) * inv.norm2), q1);
      for (int i = 0; i < 4; ++i) q.v[i] = select(careful, q1[i], q.v[i]);
      stats.near_double += count(careful);
    }
    SinCos<T, A>::rotation_from_quaternion(q.v[0], q.v[1], q.v[2], q.v[3], r);
    for (int i = 0; i < 9; ++i) r[i] = select(zero, V(i % 4 == 0 ? T(1) : T(0)), r[i]);
  }

  static std::size_t count(M m) {
    alignas(64) T tmp[W];
    select(m, V(T(1)), V(T(0))).store_aligned(tmp);
    std::size_t c = 0;
    for (std::size_t i = 0; i < W; ++i) c += tmp[i] != T(0);
    return c;
  }

  /// One batch of W matrices at H + offset (loads of W consecutive values per entry).
  MLSDEFORM_KERNEL_INLINE static void run_batch(const T* H, T* R, std::size_t stride, std::size_t offset, RotationStats& stats) {
    V h[9], r[9];
    for (int i = 0; i < 9; ++i) h[i] = V::load_unaligned(H + std::size_t(i) * stride + offset);
    fit(h, r, stats);
    for (int i = 0; i < 9; ++i) r[i].store_unaligned(R + std::size_t(i) * stride + offset);
  }

  /// The kernel-table entry: matrices [begin, end).
  static void run(const T* H, T* R, std::size_t stride, std::size_t begin, std::size_t end, RotationStats* stats) {
    RotationStats local;
    Simd<T, A>::for_each_batch(H, R, stride, begin, end, [&](const T* src, T* dst, std::size_t st, std::size_t off) {
      run_batch(src, dst, st, off, local);
    });
    if (stats) {
      stats->near_double += local.near_double;
    }
  }
};

}  // namespace mlsdeform::kernels
