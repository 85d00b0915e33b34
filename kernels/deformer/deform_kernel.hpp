// One frame of the MLS deformation in SIMD lanes, one vertex per lane: the kernel-table entry
// (DeformBlocksFn), twin of core/src/deformer/reference.hpp over the same DeformFrame (kernels/contract.hpp),
// stage by stage (stages.hpp; the rotation fit of kernels/rotation/):
//   weighted_centroid, correlation_matrix    one pass over the pseudo-handles
//   fit                                      R (fit_rotation_axis_angle, or the Horn-Jacobi baseline)
//   similarity_scale                         mu (similarity), else 1
//   apply                                    v' = q* + mu R vhat
// Affine: v' = sum_j alpha_j q_j. The pseudo-handles are visited in the same order as the scalar code, so a
// vertex's sums see the same terms in the same order (its lane), whatever the thread or block schedule. As
// there, everything is in the local frame: targets times local_scale as they are read, results times
// world_scale before they are stored.
#pragma once

#include "kernels/contract.hpp"
#include "kernels/deformer/stages.hpp"
#include "kernels/kernel_table.hpp"
#include "kernels/rotation/axis_angle.hpp"
#include "kernels/rotation/horn_jacobi.hpp"

namespace mlsdeform::kernels {

template <class T, class A>
struct DeformKernel : Simd<T, A> {
  using typename Simd<T, A>::V;
  using typename Simd<T, A>::M;
  using Simd<T, A>::W;
  static_assert(kLanes % W == 0, "a block holds a whole number of batches");

  /// f(j, q) for every pseudo-handle in the scalar code's order (points, then each segment's ends), q in the
  /// local frame.
  template <class F>
  static void for_each_target(const DeformFrame<T>& fr, F&& f) {
    const T ls = fr.local_scale;
    std::size_t j = 0;
    for (std::size_t i = 0; i < fr.k; ++i, ++j)
      f(j, fr.points[i] * ls, fr.points[fr.k + i] * ls, fr.points[2 * fr.k + i] * ls);
    for (std::size_t i = 0; i < fr.s; ++i) {
      f(j++, fr.seg_a[i] * ls, fr.seg_a[fr.s + i] * ls, fr.seg_a[2 * fr.s + i] * ls);
      f(j++, fr.seg_b[i] * ls, fr.seg_b[fr.s + i] * ls, fr.seg_b[2 * fr.s + i] * ls);
    }
  }

  /// From the local frame to the caller's units.
  MLSDEFORM_KERNEL_INLINE static void to_world(const DeformFrame<T>& fr, V (&out)[3]) {
    for (V& x : out) x = x * V(fr.world_scale);
  }

  /// w = (dref2 / d2)^(u/2); u = 2 (the default) needs no power.
  MLSDEFORM_KERNEL_INLINE static V relative_weight(V r2, T half_u) {
    if (half_u == T(1)) return r2;
    return exp2(V(half_u) * log2(r2));
  }

  /// The stages after H, shared by both weight sources: R from H, mu (similarity_scale, else `scale`), and
  /// apply. `scale` multiplies vhat for rigid (the on-the-fly local frame).
  MLSDEFORM_KERNEL_INLINE static void rotate_and_apply(const DeformFrame<T>& fr, const V (&h)[9], const V (&qs)[3],
                                                       const V (&vh)[3], V D, V scale, V (&out)[3]) {
    V hn[9], r[9];
    for (int i = 0; i < 9; ++i) hn[i] = h[i];  // the fit normalises its argument in place
    std::size_t careful = 0;                   // not reported per frame
    if (fr.method == RotationMethod::horn_quaternion) {
      fit_rotation_horn_jacobi(hn, r);
    } else {
      fit_rotation_axis_angle(hn, r, careful);
    }
    const V mu = fr.transform == Transform::similarity ? similarity_scale(r, h, D, scale) : scale;
    apply(qs, mu, r, vh, out);
  }

  /// On-the-fly weights, twin of the scalar deform_block_on_the_fly (two passes over the point handles).
  static void batch_on_the_fly(const DeformFrame<T>& fr, std::size_t v0) {
    const V vx = V::load_aligned(fr.v_local + v0), vy = V::load_aligned(fr.v_local + fr.padded + v0),
            vz = V::load_aligned(fr.v_local + 2 * fr.padded + v0), dref2 = V::load_aligned(fr.dref2 + v0);
    const T *px = fr.p_local, *py = px + fr.k, *pz = px + 2 * fr.k;
    const T ls = fr.local_scale;
    V S(T(0)), ps[3] = {V(T(0)), V(T(0)), V(T(0))}, qs[3] = {V(T(0)), V(T(0)), V(T(0))};
    for (std::size_t j = 0; j < fr.k; ++j) {
      const V dx = V(px[j]) - vx, dy = V(py[j]) - vy, dz = V(pz[j]) - vz;
      const V w = relative_weight(dref2 / (dx * dx + dy * dy + dz * dz), fr.half_u);
      S = S + w;
      ps[0] = ps[0] + w * dx, ps[1] = ps[1] + w * dy, ps[2] = ps[2] + w * dz;
      weighted_centroid(qs, w, {V(fr.points[j] * ls), V(fr.points[fr.k + j] * ls), V(fr.points[2 * fr.k + j] * ls)});
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
      const V d[3] = {V(fr.points[j] * ls - fr.centre[0]), V(fr.points[fr.k + j] * ls - fr.centre[1]),
                      V(fr.points[2 * fr.k + j] * ls - fr.centre[2])};
      correlation_matrix(h, d, a);
      for (int r = 0; r < 3; ++r) sum_a[r] = sum_a[r] + a[r];
      D = D + (a[0] * ph[0] + a[1] * ph[1] + a[2] * ph[2]);
    }
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) h[3 * r + c] = h[3 * r + c] - (qs[r] - V(fr.centre[r])) * sum_a[c];
    const V vh[3] = {-ps[0], -ps[1], -ps[2]};
    V out[3];
    rotate_and_apply(fr, h, qs, vh, D, V(T(1)), out);
    // Vertices on a handle (scalar: q_j exactly, in the local frame); padding lanes have snap = -1.
    const V snap = V::load_aligned(fr.snap + v0);
    if (any(snap >= V(T(0)))) {
      alignas(64) T buf[3][W], sb[W];
      for (int c = 0; c < 3; ++c) out[c].store_aligned(buf[c]);
      snap.store_aligned(sb);
      for (std::size_t l = 0; l < W; ++l)
        if (sb[l] >= T(0)) {
          const std::size_t j = static_cast<std::size_t>(sb[l]);
          for (std::size_t c = 0; c < 3; ++c) buf[c][l] = fr.points[c * fr.k + j] * ls;
        }
      for (int c = 0; c < 3; ++c) out[c] = V::load_aligned(buf[c]);
    }
    to_world(fr, out);
    store(fr, v0, out);
  }

  /// The W vertices starting at lane `g` of block b.
  static void batch(const DeformFrame<T>& fr, std::size_t b, std::size_t g) {
    const std::size_t v0 = b * kLanes + g;
    if (fr.weights == WeightSource::on_the_fly) return batch_on_the_fly(fr, v0);
    const std::size_t J = fr.k + 2 * fr.s;
    V out[3];
    if (fr.transform == Transform::affine) {
      for (V& x : out) x = V(T(0));
      for_each_target(fr, [&](std::size_t j, T qx, T qy, T qz) {
        const V alpha = V::load_aligned(fr.table + table_offset(b, j, J, fr.transform) + g);
        weighted_centroid(out, alpha, {V(qx), V(qy), V(qz)});
      });
    } else {
      V qs[3] = {V(T(0)), V(T(0)), V(T(0))};
      V h[9];
      for (V& e : h) e = V(T(0));
      for_each_target(fr, [&](std::size_t j, T qx, T qy, T qz) {
        const T* co = fr.table + table_offset(b, j, J, fr.transform) + g;
        const V omega = V::load_aligned(co);
        const V a[3] = {V::load_aligned(co + kLanes), V::load_aligned(co + 2 * kLanes),
                        V::load_aligned(co + 3 * kLanes)};
        weighted_centroid(qs, omega, {V(qx), V(qy), V(qz)});
        correlation_matrix(h, {V(qx - fr.centre[0]), V(qy - fr.centre[1]), V(qz - fr.centre[2])}, a);
      });
      const V vh[3] = {V::load_aligned(fr.vhat + v0), V::load_aligned(fr.vhat + fr.padded + v0),
                       V::load_aligned(fr.vhat + 2 * fr.padded + v0)};
      const V D = fr.transform == Transform::similarity ? V::load_aligned(fr.D + v0) : V(T(0));
      rotate_and_apply(fr, h, qs, vh, D, V(T(1)), out);
    }
    to_world(fr, out);
    store(fr, v0, out);
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

  /// The kernel-table entry: blocks [block_begin, block_end).
  static void run(const DeformFrame<T>& fr, std::size_t block_begin, std::size_t block_end) {
    for (std::size_t b = block_begin; b < block_end; ++b)
      for (std::size_t g = 0; g < kLanes && b * kLanes + g < fr.n; g += W) batch(fr, b, g);
  }
};

}  // namespace mlsdeform::kernels
