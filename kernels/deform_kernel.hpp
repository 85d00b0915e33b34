// One frame of the MLS deformation in SIMD lanes, one vertex per lane, mirroring the scalar reference
// core/src/deformer_scalar.hpp stage by stage over the precomputed table of core/src/deformer_data.hpp:
//   weighted_centroid   q* = sum_j omega_j q_j                         (eq. 2)
//   correlation_matrix  H  = sum_j (q_j - c) A_j^T                     (eq. 6, Sec. 6.2)
//   fit                 R  (FitRotations: eqs. 13-15; or HornJacobi)
//   scale               mu = trace(R^T H) / D (similarity, Sec. 6.1), else 1
//   apply               v' = q* + mu R vhat                            (Algorithm 1 steps 8-10)
// Affine: v' = sum_j alpha_j q_j. The pseudo-handles are visited in the same order as the scalar code, so a
// vertex's sums see the same terms in the same order (its lane), whatever the thread or block schedule.
#pragma once

#include "fit_rotations.hpp"
#include "horn_jacobi.hpp"
#include "kernel_table.hpp"

namespace mlsdeform::kernels {

template <class T, class A>
struct DeformKernel : Simd<T, A> {
  using typename Simd<T, A>::V;
  using typename Simd<T, A>::M;
  using Simd<T, A>::W;
  static constexpr std::size_t kBlock = 16;  // detail::kLanes
  static_assert(kBlock % W == 0, "a block holds a whole number of batches");

  /// f(j, x, y, z) for every pseudo-handle in the scalar code's order: points, then each segment's ends.
  template <class F>
  static void for_each_target(const DeformFrame<T>& fr, F&& f) {
    std::size_t j = 0;
    for (std::size_t i = 0; i < fr.k; ++i, ++j) f(j, fr.points[i], fr.points[fr.k + i], fr.points[2 * fr.k + i]);
    for (std::size_t i = 0; i < fr.s; ++i) {
      f(j++, fr.seg_a[i], fr.seg_a[fr.s + i], fr.seg_a[2 * fr.s + i]);
      f(j++, fr.seg_b[i], fr.seg_b[fr.s + i], fr.seg_b[2 * fr.s + i]);
    }
  }

  /// w = (dref2 / d2)^(u/2); u = 2 (the default) needs no power.
  MLSDEFORM_KERNEL_INLINE static V relative_weight(V r2, T half_u) {
    if (half_u == T(1)) return r2;
    return exp2(V(half_u) * log2(r2));
  }

  /// The rotation stage shared by both weight storages: R from H (fit or Horn-Jacobi), mu, and
  /// out = q* + mu R vhat. `scale` multiplies vhat for rigid (the on-the-fly local frame).
  MLSDEFORM_KERNEL_INLINE static void apply_rotation(const DeformFrame<T>& fr, const V (&h)[9], const V (&qs)[3],
                                                     const V (&vh)[3], V D, V scale, V (&out)[3],
                                                     RotationStats& stats) {
    V hn[9], r[9];
    for (int i = 0; i < 9; ++i) hn[i] = h[i];  // fit normalises its argument in place
    if (fr.method == 1) {
      HornJacobi<T, A>::fit(hn, r);
    } else {
      FitRotations<T, A>::fit(hn, r, stats);
    }
    V mu = scale;
    if (fr.transform == 1) {
      V tr = r[0] * h[0];
      for (int i = 1; i < 9; ++i) tr = tr + r[i] * h[i];
      mu = select(D > V(T(0)), tr / D, scale);  // scalar: if (D > 0) mu = trace(R^T H) / D
    }
    for (int i = 0; i < 3; ++i) {
      const V rv = r[3 * i] * vh[0] + r[3 * i + 1] * vh[1] + r[3 * i + 2] * vh[2];
      out[i] = qs[i] + mu * rv;
    }
  }

  /// On-the-fly weights, mirroring the scalar deform_block_on_the_fly (two passes over the point handles).
  static void batch_on_the_fly(const DeformFrame<T>& fr, std::size_t b, std::size_t g, RotationStats& stats) {
    const std::size_t v0 = b * kBlock + g;
    const V vx = V::load_aligned(fr.v_local + v0), vy = V::load_aligned(fr.v_local + fr.padded + v0),
            vz = V::load_aligned(fr.v_local + 2 * fr.padded + v0), dref2 = V::load_aligned(fr.dref2 + v0);
    const T *px = fr.p_local, *py = px + fr.k, *pz = px + 2 * fr.k;
    V S(T(0)), ps[3] = {V(T(0)), V(T(0)), V(T(0))}, qs[3] = {V(T(0)), V(T(0)), V(T(0))};
    for (std::size_t j = 0; j < fr.k; ++j) {
      const V dx = V(px[j]) - vx, dy = V(py[j]) - vy, dz = V(pz[j]) - vz;
      const V w = relative_weight(dref2 / (dx * dx + dy * dy + dz * dz), fr.half_u);
      S = S + w;
      ps[0] = ps[0] + w * dx, ps[1] = ps[1] + w * dy, ps[2] = ps[2] + w * dz;
      qs[0] = qs[0] + w * V(fr.points[j]), qs[1] = qs[1] + w * V(fr.points[fr.k + j]);
      qs[2] = qs[2] + w * V(fr.points[2 * fr.k + j]);
    }
    const V inv_S = V(T(1)) / S;
    for (V& x : ps) x = x * inv_S;
    for (V& x : qs) x = x * inv_S;
    V h[9], sum_a[3] = {V(T(0)), V(T(0)), V(T(0))}, D(T(0));
    for (V& e : h) e = V(T(0));
    for (std::size_t j = 0; j < fr.k; ++j) {
      const V dx = V(px[j]) - vx, dy = V(py[j]) - vy, dz = V(pz[j]) - vz;
      const V w = relative_weight(dref2 / (dx * dx + dy * dy + dz * dz), fr.half_u) * inv_S;
      const V ph[3] = {dx - ps[0], dy - ps[1], dz - ps[2]};
      const V a[3] = {w * ph[0], w * ph[1], w * ph[2]};
      const V d[3] = {V(fr.points[j] - fr.centre[0]), V(fr.points[fr.k + j] - fr.centre[1]),
                      V(fr.points[2 * fr.k + j] - fr.centre[2])};
      for (int r = 0; r < 3; ++r) {
        h[3 * r + 0] = h[3 * r + 0] + d[r] * a[0];
        h[3 * r + 1] = h[3 * r + 1] + d[r] * a[1];
        h[3 * r + 2] = h[3 * r + 2] + d[r] * a[2];
      }
      for (int r = 0; r < 3; ++r) sum_a[r] = sum_a[r] + a[r];
      D = D + (a[0] * ph[0] + a[1] * ph[1] + a[2] * ph[2]);
    }
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) h[3 * r + c] = h[3 * r + c] - (qs[r] - V(fr.centre[r])) * sum_a[c];
    const V vh[3] = {-ps[0], -ps[1], -ps[2]};
    V out[3];
    apply_rotation(fr, h, qs, vh, D, V(fr.world_scale), out, stats);
    // Vertices on a handle (scalar: write q_j exactly); padding lanes have snap = -1.
    const V snap = V::load_aligned(fr.snap + v0);
    if (any(snap >= V(T(0)))) {
      alignas(64) T buf[3][W], sb[W];
      for (int c = 0; c < 3; ++c) out[c].store_aligned(buf[c]);
      snap.store_aligned(sb);
      for (std::size_t l = 0; l < W; ++l)
        if (sb[l] >= T(0)) {
          const std::size_t j = static_cast<std::size_t>(sb[l]);
          for (std::size_t c = 0; c < 3; ++c) buf[c][l] = fr.points[c * fr.k + j];
        }
      for (int c = 0; c < 3; ++c) out[c] = V::load_aligned(buf[c]);
    }
    store(fr, v0, out);
  }

  /// The W vertices starting at lane `g` of block b.
  static void batch(const DeformFrame<T>& fr, std::size_t b, std::size_t g, RotationStats& stats) {
    if (fr.on_the_fly) return batch_on_the_fly(fr, b, g, stats);
    const std::size_t J = fr.k + 2 * fr.s;
    V out[3];
    if (fr.transform == 2) {
      V x(T(0)), y(T(0)), z(T(0));
      for_each_target(fr, [&](std::size_t j, T qx, T qy, T qz) {
        const V alpha = V::load_aligned(fr.table + (b * J + j) * kBlock + g);
        x = x + alpha * V(qx);
        y = y + alpha * V(qy);
        z = z + alpha * V(qz);
      });
      out[0] = x, out[1] = y, out[2] = z;
    } else {
      V qs[3] = {V(T(0)), V(T(0)), V(T(0))};
      V h[9];
      for (V& e : h) e = V(T(0));
      for_each_target(fr, [&](std::size_t j, T qx, T qy, T qz) {
        const T* co = fr.table + (b * J + j) * 4 * kBlock + g;
        const V omega = V::load_aligned(co), ax = V::load_aligned(co + kBlock), ay = V::load_aligned(co + 2 * kBlock),
                az = V::load_aligned(co + 3 * kBlock);
        qs[0] = qs[0] + omega * V(qx);
        qs[1] = qs[1] + omega * V(qy);
        qs[2] = qs[2] + omega * V(qz);
        const V d[3] = {V(qx - fr.centre[0]), V(qy - fr.centre[1]), V(qz - fr.centre[2])};
        for (int r = 0; r < 3; ++r) {
          h[3 * r + 0] = h[3 * r + 0] + d[r] * ax;
          h[3 * r + 1] = h[3 * r + 1] + d[r] * ay;
          h[3 * r + 2] = h[3 * r + 2] + d[r] * az;
        }
      });
      const std::size_t v0 = b * kBlock + g;
      const V vh[3] = {V::load_aligned(fr.vhat + v0), V::load_aligned(fr.vhat + fr.padded + v0),
                       V::load_aligned(fr.vhat + 2 * fr.padded + v0)};
      const V D = fr.transform == 1 ? V::load_aligned(fr.D + v0) : V(T(0));
      apply_rotation(fr, h, qs, vh, D, V(T(1)), out, stats);
    }
    store(fr, b * kBlock + g, out);
  }

  static void store(const DeformFrame<T>& fr, std::size_t v0, const V (&out)[3]) {
    if (v0 >= fr.n) return;
    const std::size_t count = fr.n - v0 < W ? fr.n - v0 : W;
    if (fr.out_vertex_stride == 1 && count == W) {
      for (int c = 0; c < 3; ++c) out[c].store_unaligned(fr.out + c * fr.out_coord_stride + v0);
      return;
    }
    alignas(64) T buf[3][W];
    for (int c = 0; c < 3; ++c) out[c].store_aligned(buf[c]);
    for (std::size_t l = 0; l < count; ++l)
      for (std::size_t c = 0; c < 3; ++c) fr.out[c * fr.out_coord_stride + (v0 + l) * fr.out_vertex_stride] = buf[c][l];
  }

  static void run(const DeformFrame<T>& fr, std::size_t block_begin, std::size_t block_end, RotationStats* stats) {
    RotationStats local;
    for (std::size_t b = block_begin; b < block_end; ++b)
      for (std::size_t g = 0; g < kBlock && b * kBlock + g < fr.n; g += W) batch(fr, b, g, local);
    if (stats) {
      stats->near_double += local.near_double;
    }
  }
};

}  // namespace mlsdeform::kernels
