// Baseline in the same lanes: Horn 1987 (the unit quaternion is the eigenvector of the largest eigenvalue
// of the symmetric 4x4 matrix K), with the eigenproblem solved by cyclic Jacobi rotations (kernels/jacobi.hpp,
// swept to convergence). Jacobi is the dense method of choice for small symmetric eigenproblems in lanes (no
// data-dependent branching; McAdams et al. 2011 use it for their 3x3 SIMD SVD).
#pragma once

#include "fit_rotations.hpp"
#include "jacobi.hpp"

namespace mlsdeform::kernels {

template <class T, class A>
struct HornJacobi : Simd<T, A> {
  using typename Simd<T, A>::V;
  using typename Simd<T, A>::M;
  using Simd<T, A>::W;

  MLSDEFORM_KERNEL_INLINE static void fit(V (&h)[9], V (&r)[9]) {
    V m = abs(h[0]);
    for (int i = 1; i < 9; ++i) m = max(m, abs(h[i]));
    const M zero = m == V(T(0));
    const V scale = Simd<T, A>::pow2_inverse_exponent(select(zero, V(T(1)), m));
    for (int i = 0; i < 9; ++i) h[i] = h[i] * scale;
    const typename QuarticRoot<T, A>::Invariants inv = QuarticRoot<T, A>::invariants(h);
    typename RotationAxis<T, A>::Mat4 K = RotationAxis<T, A>::davenport(h, inv.E, inv.z0, inv.z1, inv.z2);
    V a[4][4], v[4][4];
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) a[i][j] = K(i, j);
    // ||K||_F^2 = 4 ||H||_F^2 (K's blocks: |E|^2 + 2|z|^2 + ||H + H^T - E I||^2).
    Jacobi<T, A>::eigen(a, v, sqrt(V(T(4)) * inv.norm2));
    // The eigenvector of the largest diagonal entry (first index on ties).
    V best = a[0][0];
    V w = v[0][0], x0 = v[1][0], x1 = v[2][0], x2 = v[3][0];
    for (int j = 1; j < 4; ++j) {
      const M better = a[j][j] > best;
      best = select(better, a[j][j], best);
      w = select(better, v[0][j], w);
      x0 = select(better, v[1][j], x0);
      x1 = select(better, v[2][j], x1);
      x2 = select(better, v[3][j], x2);
    }
    SinCos<T, A>::rotation_from_quaternion(w, x0, x1, x2, r);
    for (int i = 0; i < 9; ++i) r[i] = select(zero, V(i % 4 == 0 ? T(1) : T(0)), r[i]);
  }

  static void run(const T* H, T* R, std::size_t stride, std::size_t begin, std::size_t end, RotationStats*) {
    Simd<T, A>::for_each_batch(H, R, stride, begin, end, [](const T* src, T* dst, std::size_t st, std::size_t off) {
      V h[9], r[9];
      for (std::size_t i = 0; i < 9; ++i) h[i] = V::load_unaligned(src + i * st + off);
      fit(h, r);
      for (std::size_t i = 0; i < 9; ++i) r[i].store_unaligned(dst + i * st + off);
    });
  }
};

}  // namespace mlsdeform::kernels
