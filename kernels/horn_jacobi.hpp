// Baseline in the same lanes: Horn 1987 (the unit quaternion is the eigenvector of the largest eigenvalue
// of the symmetric 4x4 matrix K), with the eigenproblem solved by cyclic Jacobi rotations (Jacobi 1846;
// Golub & Van Loan Alg. 8.5.2) in branch-free form: sweeps over the six pivot pairs, each rotation
// t = sign(theta) / (|theta| + sqrt(theta^2 + 1)), theta = (a_qq - a_pp) / (2 a_pq), skipped by select where
// |a_pq| <= eps ||K||_F (setting it to zero is then a backward error of eps ||K||, as in Rutishauser's
// threshold). Jacobi is the dense method of choice for small symmetric eigenproblems in lanes (no data-
// dependent branching; McAdams et al. 2011 use it for their 3x3 SIMD SVD); it converges quadratically,
// and the sweeps go on until every lane's off-diagonal entries are below that threshold (checked from
// the third sweep on; at most kMaxSweeps). Without the threshold, an off-diagonal entry of 1e-229 between
// equal diagonal entries (a wide_exponents matrix) drew a 45-degree rotation that mixed two decoupled
// blocks, and convergence fell to a factor 2 per sweep: 6 sweeps left 5e11 eps of trace loss.
#pragma once

#include "fit_rotations.hpp"

namespace mlsdeform::kernels {

template <class T, class A>
struct HornJacobi : Simd<T, A> {
  using typename Simd<T, A>::V;
  using typename Simd<T, A>::M;
  using Simd<T, A>::W;
  using Simd<T, A>::eps;
  static constexpr int kMaxSweeps = 12;

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
      for (int j = 0; j < 4; ++j) {
        a[i][j] = K(i, j);
        v[i][j] = V(i == j ? T(1) : T(0));
      }
    // ||K||_F^2 = 4 ||H||_F^2 (K's blocks: |E|^2 + 2|z|^2 + ||H + H^T - E I||^2).
    const V small = V(eps) * sqrt(V(T(4)) * inv.norm2);
    for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
      for (int p = 0; p < 3; ++p)
        for (int q = p + 1; q < 4; ++q) rotate(a, v, p, q, small);
      if (sweep < 2) continue;
      V off = abs(a[0][1]);
      for (int p = 0; p < 3; ++p)
        for (int q = p + 1; q < 4; ++q) off = max(off, abs(a[p][q]));
      if (none(off > small)) break;
    }
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

  /// One Jacobi rotation annihilating a[p][q] (skipped where |a[p][q]| <= small: it is set to zero);
  /// v accumulates the eigenvectors (columns).
  MLSDEFORM_KERNEL_INLINE static void rotate(V (&a)[4][4], V (&v)[4][4], int p, int q, V small) {
    const V apq = a[p][q];
    const M skip = abs(apq) <= small;
    const V theta = (a[q][q] - a[p][p]) / (V(T(2)) * select(skip, V(T(1)), apq));
    const V t0 = V(T(1)) / (abs(theta) + sqrt(theta * theta + V(T(1))));
    // theta^2 may overflow to inf for a tiny a_pq: then t0 = 0, the rotation is the identity (as it should be).
    const V t = select(skip, V(T(0)), select(theta < V(T(0)), -t0, t0));
    const V c = V(T(1)) / sqrt(t * t + V(T(1))), s = t * c;
    a[p][p] = a[p][p] - t * apq;
    a[q][q] = a[q][q] + t * apq;
    a[p][q] = a[q][p] = V(T(0));
    for (int k = 0; k < 4; ++k) {
      if (k == p || k == q) continue;
      const V akp = a[k][p], akq = a[k][q];
      a[k][p] = a[p][k] = c * akp - s * akq;
      a[k][q] = a[q][k] = s * akp + c * akq;
    }
    for (int k = 0; k < 4; ++k) {
      const V vkp = v[k][p], vkq = v[k][q];
      v[k][p] = c * vkp - s * vkq;
      v[k][q] = s * vkp + c * vkq;
    }
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
