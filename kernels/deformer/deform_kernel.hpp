// One frame of the MLS deformation, the kernel-table entry (DeformBlocksFn) of every table: one driver over
// a lane policy L, W vertices at a time (one per lane), which the SIMD tables instantiate with a batch
// (kernels/deformer/simd_lanes.hpp) and the scalar reference with one vertex (core/src/deformer/reference.hpp),
// over the same DeformFrame (kernels/contract.hpp), stage by stage (stages.hpp):
//   weighted_centroid, correlation_matrix    one pass over the pseudo-handles (for_each_target)
//   fit                                      R from H, kFitTile batches side by side (L::fit_tile: the
//                                            lanes' rotation fit, each lane bitwise as alone; the scalar
//                                            reference: fit_rotation, one vertex at a time)
//   similarity_scale                         mu (similarity), else 1
//   apply                                    v' = q* + mu R vhat
//   store_frames (when wanted)               R, mu, mu R and rotation_quaternion(R) into the FramesOut rows
// Affine: v' = sum_j alpha_j q_j, and when `linear` is wanted L = sum_j (q_j - c) B_j^T (correlation_matrix
// again). The pseudo-handles are visited in one order, so a vertex's sums see the same
// terms in the same order whatever the width, thread or block schedule. Everything is in the local frame:
// targets times local_scale as they are read, results times world_scale before they are stored.
//
// A lane policy L provides: T (the element type), V (the lane type), W (its width, dividing kLanes);
// load(p) (W lanes from p, aligned for W > 1), store(v, p) (W lanes to p); relative_weight(r2, half_u)
// (the on-the-fly weight (r2)^(u/2)); fit_tile<B>(method, h, r, nb) (R from the unnormalised H of nb <= B
// batches, h row-major, overwritten), with kFitTile = B. The two
// policies differ only there: the scalar reference fits by fit_rotation, which has every RotationMethod and
// std::pow, the lanes by their branch-free fits and exp2(log2) (the SIMD tables run axis_angle and
// horn_quaternion).
#pragma once

#include "kernels/contract.hpp"
#include "kernels/deformer/stages.hpp"
#include "kernels/lanes.hpp"

namespace mlsdeform::kernels {

template <class L>
struct DeformKernel {
  using T = typename L::T;
  using V = typename L::V;
  static constexpr std::size_t W = L::W;
  static_assert(kLanes % W == 0, "a block holds a whole number of batches");

  /// One vertex per lane: its position, and the frame (R, mu) that moved it (rigid, similarity; affine: r the
  /// fit's matrix L, mu 1, computed only when `linear` is wanted).
  struct Result {
    V out[3];
    V r[9];
    V mu;
  };

  /// What the stages after H need of one batch (rigid, similarity): H, q*, vhat and D, and for on-the-fly
  /// weights the lanes on a handle (snap: its index, else -1) and whether every lane is (nothing to fit).
  struct Pending {
    V h[9], qs[3], vh[3], D;
    V snap;
    bool all_snapped;
  };

  /// Precomputed weights, rigid or similarity: H, q*, vhat, D of the W vertices from lane g of block b.
  MLSDEFORM_KERNEL_INLINE static void table(const DeformFrame<T>& fr, std::size_t b, std::size_t g, Pending& p) {
    const std::size_t v0 = b * kLanes + g, J = fr.k + 2 * fr.s;
    // The sums in locals, copied to p at the end: summed in p's arrays, they went through memory on every
    // pseudo-handle (the compiler cannot tell them from the table it reads).
    V qs[3] = {V(T(0)), V(T(0)), V(T(0))}, h[9];
    for (V& e : h) e = V(T(0));
    for_each_target(fr, [&](std::size_t j, const Target<T>& t) {
      const T* co = fr.table + table_offset(b, j, J, fr.transform) + g;
      const V a[3] = {L::load(co + kLanes), L::load(co + 2 * kLanes), L::load(co + 3 * kLanes)};
      weighted_centroid(qs, L::load(co), {V(t.q[0]), V(t.q[1]), V(t.q[2])});
      correlation_matrix(h, {V(t.qc[0]), V(t.qc[1]), V(t.qc[2])}, a);
    });
    for (int i = 0; i < 3; ++i) p.qs[i] = qs[i];
    for (int i = 0; i < 9; ++i) p.h[i] = h[i];
    p.vh[0] = L::load(fr.vhat + v0), p.vh[1] = L::load(fr.vhat + fr.padded + v0);
    p.vh[2] = L::load(fr.vhat + 2 * fr.padded + v0);
    p.D = fr.transform == Transform::similarity ? L::load(fr.D + v0) : V(T(0));
    p.snap = V(T(-1));
    p.all_snapped = false;
  }

  /// The stages after the fit R (rigid, similarity): mu (similarity_scale, else 1) and apply; for on-the-fly
  /// weights the lanes on a handle take its target, and the identity frame.
  static void finish(const DeformFrame<T>& fr, const Pending& p, const V (&r)[9], Result& res) {
    if (p.all_snapped) {
      for (V& x : res.out) x = V(T(0));
      identity_frame(res);
      return snap_to_handles(fr, p.snap, res.out);
    }
    for (int i = 0; i < 9; ++i) res.r[i] = r[i];
    res.mu = fr.transform == Transform::similarity ? similarity_scale(res.r, p.h, p.D, V(T(1))) : V(T(1));
    apply(p.qs, res.mu, res.r, p.vh, res.out);
    if (fr.weights == WeightSource::table) return;
    const auto snapped = p.snap >= V(T(0));
    if (any(snapped)) {
      snap_to_handles(fr, p.snap, res.out);
      // The frame of a vertex on a handle: the identity, not the infinite weights' NaN (the session then writes
      // the fit's limit there, apart from the kernels: core/src/deformer/near_handles.hpp).
      for (int i = 0; i < 9; ++i) res.r[i] = select(snapped, V(T(i % 4 == 0 ? 1 : 0)), res.r[i]);
      res.mu = select(snapped, V(T(1)), res.mu);
    }
  }

  /// Affine: v' = sum_j alpha_j q_j for the W vertices from lane g of block b; where `linear` is wanted also
  /// the fit's matrix L = H G^-1 = sum_j (q_j - c) B_j^T (correlation_matrix with B_j = G^-1 A_j in A_j's
  /// place, data.hpp) into res.r, with res.mu = 1 so that store_frames writes mu R = L; where it is not, the
  /// identity, so that res is whole on every path (run stores frames on a condition that the compiler cannot
  /// tie to fr.linear). The position's sum is the same whether or not L is wanted.
  MLSDEFORM_KERNEL_INLINE static void affine(const DeformFrame<T>& fr, std::size_t b, std::size_t g, Result& res) {
    const std::size_t J = fr.k + 2 * fr.s;
    for (V& x : res.out) x = V(T(0));
    for_each_target(fr, [&](std::size_t j, const Target<T>& t) {
      weighted_centroid(res.out, L::load(fr.table + table_offset(b, j, J, fr.transform) + g),
                        {V(t.q[0]), V(t.q[1]), V(t.q[2])});
    });
    if (!fr.linear) return identity_frame(res);
    for (V& e : res.r) e = V(T(0));
    for_each_target(fr, [&](std::size_t j, const Target<T>& t) {
      const T* bj = fr.linear_table + linear_table_offset(b, j, J) + g;
      correlation_matrix(res.r, {V(t.qc[0]), V(t.qc[1]), V(t.qc[2])},
                         {L::load(bj), L::load(bj + kLanes), L::load(bj + 2 * kLanes)});
    });
    res.mu = V(T(1));
  }

  /// The lanes of `snap` that sit on a handle (snap = its index, else -1) take its target exactly (Sec. 3:
  /// f(p_i) = q_i), in the local frame.
  static void snap_to_handles(const DeformFrame<T>& fr, V snap, V (&out)[3]) {
    alignas(64) T buf[3][W], sb[W];
    for (int c = 0; c < 3; ++c) L::store(out[c], buf[c]);
    L::store(snap, sb);
    for (std::size_t l = 0; l < W; ++l)
      if (sb[l] >= T(0)) {
        const auto j = static_cast<std::size_t>(sb[l]);
        for (std::size_t c = 0; c < 3; ++c) buf[c][l] = fr.points[c * fr.k + j] * fr.local_scale;
      }
    for (int c = 0; c < 3; ++c) out[c] = L::load(buf[c]);
  }

  /// On-the-fly weights (WeightStorage::on_the_fly; rigid and similarity, point handles): the W vertices
  /// from v0, recomputing w_j = (dref^2 / d_j^2)^(u/2) from the rest distances every frame (weights relative
  /// to the nearest handle, as in the precomputation: all in (0, 1]). Coordinates are taken relative to the
  /// vertex (p_j - v), so that near a handle, where p* ~ p_n and vhat is small, nothing cancels against the
  /// scene's size; and, as in the precomputation, the common rounding of p* is projected out of the A_j
  /// (H -= (q* - c) (sum_j A_j)^T). Two passes over the handles:
  ///   pass 1  S = sum w_j, p* - v = sum w_j (p_j - v) / S, q* = sum w_j q_j / S                      (eq. 2)
  ///   pass 2  phat_j = (p_j - v) - (p* - v), A_j = w_j phat_j / S, H = sum (q_j - c) A_j^T,
  ///           D = sum A_j . phat_j (similarity only: the rigid fit never reads it)         (eq. 6, Sec. 6.1)
  /// into p, for the fit and `finish` (vhat = v - p*), as `table` does. Lanes on a handle, whose weights are
  /// infinite, take its target in `finish`; where every lane does, nothing else is computed.
  template <bool kSimilarity>
  static void on_the_fly(const DeformFrame<T>& fr, std::size_t v0, Pending& p) {
    p.snap = L::load(fr.snap + v0);  // padding lanes have snap = -1
    p.all_snapped = all(p.snap >= V(T(0)));
    if (p.all_snapped) {
      for (V& e : p.h) e = V(T(0));  // fitted (to the identity) with the tile, then not used
      return;
    }
    const V vx = L::load(fr.v_local + v0), vy = L::load(fr.v_local + fr.padded + v0),
            vz = L::load(fr.v_local + 2 * fr.padded + v0), dref2 = L::load(fr.dref2 + v0);
    const T *px = fr.p_local, *py = px + fr.k, *pz = px + 2 * fr.k;
    V S(T(0)), ps[3] = {V(T(0)), V(T(0)), V(T(0))}, qs[3] = {V(T(0)), V(T(0)), V(T(0))};  // locals: see `table`
    const auto first = [&](std::size_t j, const Target<T>& t) __attribute__((always_inline)) {
      const V dx = V(px[j]) - vx, dy = V(py[j]) - vy, dz = V(pz[j]) - vz;
      const V w = L::relative_weight(dref2 / (dx * dx + dy * dy + dz * dz), fr.half_u);
      S = S + w;
      ps[0] = ps[0] + w * dx, ps[1] = ps[1] + w * dy, ps[2] = ps[2] + w * dz;
      weighted_centroid(qs, w, {V(t.q[0]), V(t.q[1]), V(t.q[2])});
    };
    for_each_point_target(fr, first);
    const V inv_S = V(T(1)) / S;
    for (V& x : ps) x = x * inv_S;  // p* - v
    for (V& x : qs) x = x * inv_S;  // q*
    V h[9], sum_a[3] = {V(T(0)), V(T(0)), V(T(0))}, D(T(0));
    for (V& e : h) e = V(T(0));
    const auto second = [&](std::size_t j, const Target<T>& t) __attribute__((always_inline)) {
      const V dx = V(px[j]) - vx, dy = V(py[j]) - vy, dz = V(pz[j]) - vz;
      const V w = L::relative_weight(dref2 / (dx * dx + dy * dy + dz * dz), fr.half_u) * inv_S;
      const V ph[3] = {dx - ps[0], dy - ps[1], dz - ps[2]};
      const V a[3] = {w * ph[0], w * ph[1], w * ph[2]};
      correlation_matrix(h, {V(t.qc[0]), V(t.qc[1]), V(t.qc[2])}, a);
      for (int r = 0; r < 3; ++r) sum_a[r] = sum_a[r] + a[r];
      if constexpr (kSimilarity) D = D + (a[0] * ph[0] + a[1] * ph[1] + a[2] * ph[2]);
    };
    for_each_point_target(fr, second);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) h[3 * r + c] = h[3 * r + c] - (qs[r] - V(fr.centre[r])) * sum_a[c];
    for (int i = 0; i < 9; ++i) p.h[i] = h[i];
    for (int c = 0; c < 3; ++c) p.qs[c] = qs[c], p.vh[c] = -ps[c];
    p.D = D;
  }

  /// Precomputed weights only (WeightStorage::precomputed_weights; rigid and similarity, point handles): the W
  /// vertices from lane g of block b, in one pass over the handles with the stored w_j / S and p* - v: the
  /// quantities of on_the_fly's second pass (coordinates relative to the vertex; the common rounding of p*
  /// projected out of the A_j), H summed in another form (the b_j below), so the two round differently:
  ///   phat_j = (p_j - v) - (p* - v), A_j = (w_j / S) phat_j, q* = c + sum_j (w_j / S)(q_j - c),
  ///   H = sum_j ((w_j / S)(q_j - c)) phat_j^T - (q* - c)(sum_j A_j)^T, D = sum_j A_j . phat_j  (eqs. 2, 6, Sec. 6.1)
  /// into p, as `table` does (D for similarity only, as there; sum_j A_j and D, which depend on the rest pose
  /// alone, stored per vertex). Lanes on a handle (stored w = 0) take its target in `finish`.
  template <bool kSimilarity>
  MLSDEFORM_KERNEL_INLINE static void weights_only(const DeformFrame<T>& fr, std::size_t b, std::size_t g, Pending& p) {
    const std::size_t v0 = b * kLanes + g;
    p.snap = L::load(fr.snap + v0);  // padding lanes have snap = -1 (and w = 0)
    p.all_snapped = all(p.snap >= V(T(0)));
    if (p.all_snapped) {
      for (V& e : p.h) e = V(T(0));  // fitted (to the identity) with the tile, then not used
      return;
    }
    const V vx = L::load(fr.v_local + v0), vy = L::load(fr.v_local + fr.padded + v0),
            vz = L::load(fr.v_local + 2 * fr.padded + v0);
    const V ps[3] = {L::load(fr.p_star_local + v0), L::load(fr.p_star_local + fr.padded + v0),
                     L::load(fr.p_star_local + 2 * fr.padded + v0)};
    const T *px = fr.p_local, *py = px + fr.k, *pz = px + 2 * fr.k;
    const T* wb = fr.wn + b * fr.k * kLanes + g;
    V qs[3] = {V(T(0)), V(T(0)), V(T(0))}, h[9];  // see `table`
    for (V& e : h) e = V(T(0));
    // Per handle b_j = (w_j / S)(q_j - c) (the targets centred: a scene far from the origin keeps its detail):
    // q* - c = sum_j b_j, and sum_j b_j phat_j^T by correlation_matrix; then H = that - (q* - c)(sum_j A_j)^T
    // (eq. 6, centred: sum_j (w_j / S)(q_j - q*) phat_j^T, an identity for any weights), with sum_j A_j stored
    // per vertex (DeformFrame::sum_a), summed at set-up from the same A_j. Three products and twelve fused
    // terms per handle and batch, where forming A_j and summing it with q* and H took fifteen: the fused pipes
    // bound this loop (Zen 5, AVX-512: two pipes for the products, two adders for the 9 sums and differences).
    const auto term = [&](std::size_t j, const Target<T>& t) __attribute__((always_inline)) {
      const V w = L::load(wb + j * kLanes);
      const V bj[3] = {w * V(t.qc[0]), w * V(t.qc[1]), w * V(t.qc[2])};
      for (int r = 0; r < 3; ++r) qs[r] = qs[r] + bj[r];
      const V ph[3] = {(V(px[j]) - vx) - ps[0], (V(py[j]) - vy) - ps[1], (V(pz[j]) - vz) - ps[2]};
      correlation_matrix(h, bj, ph);
    };
    for_each_point_target(fr, term);
    const V sum_a[3] = {L::load(fr.sum_a + v0), L::load(fr.sum_a + fr.padded + v0),
                        L::load(fr.sum_a + 2 * fr.padded + v0)};
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) h[3 * r + c] = h[3 * r + c] - qs[r] * sum_a[c];
    for (int i = 0; i < 9; ++i) p.h[i] = h[i];
    for (int c = 0; c < 3; ++c) p.qs[c] = qs[c] + V(fr.centre[c]), p.vh[c] = -ps[c];
    p.D = kSimilarity ? L::load(fr.D + v0) : V(T(0));
  }

  /// R = I, mu = 1.
  static void identity_frame(Result& res) {
    for (int i = 0; i < 9; ++i) res.r[i] = V(T(i % 4 == 0 ? 1 : 0));
    res.mu = V(T(1));
  }

  /// The W vertices' frames from v0 into fr.quaternions, rotations, scales, linear (those wanted; rows below
  /// n): rotation_quaternion in the lanes, then each component's lanes through a buffer into the rows.
  static void store_frames(const DeformFrame<T>& fr, std::size_t v0, const Result& res) {
    const std::size_t count = fr.n - v0 < W ? fr.n - v0 : W;
    alignas(64) T buf[9][W];
    const auto rows = [&](T* dst, std::size_t width, const V* src) {
      for (std::size_t c = 0; c < width; ++c) L::store(src[c], buf[c]);
      for (std::size_t l = 0; l < count; ++l)
        for (std::size_t c = 0; c < width; ++c) dst[(v0 + l) * width + c] = buf[c][l];
    };
    if (fr.quaternions) {
      V q[4];
      rotation_quaternion(res.r, q);
      rows(fr.quaternions, 4, q);
    }
    if (fr.rotations) rows(fr.rotations, 9, res.r);
    if (fr.scales) rows(fr.scales, 1, &res.mu);
    if (fr.linear) {
      V m[9];
      for (int i = 0; i < 9; ++i) m[i] = res.mu * res.r[i];
      rows(fr.linear, 9, m);
    }
  }

  /// The W vertices from v0 to the caller's units and into fr.out (those below n).
  static void store(const DeformFrame<T>& fr, std::size_t v0, V (&out)[3]) {
    for (V& x : out) x = x * V(fr.world_scale);
    const std::size_t count = fr.n - v0 < W ? fr.n - v0 : W;
    if (fr.out_vertex_stride == 1 && count == W) {
      for (int c = 0; c < 3; ++c) L::store(out[c], fr.out + c * fr.out_coord_stride + v0);
      return;
    }
    alignas(64) T buf[3][W];
    for (int c = 0; c < 3; ++c) L::store(out[c], buf[c]);
    for (std::size_t l = 0; l < count; ++l)
      for (std::size_t c = 0; c < 3; ++c) fr.out[c * fr.out_coord_stride + (v0 + l) * fr.out_vertex_stride] = buf[c][l];
  }

  /// The kernel-table entry: blocks [block_begin, block_end), W vertices at a time.
  ///   Lanes:       float, double (one vertex: the scalar table; an xsimd batch: each ISA's)
  ///   Error:       per vertex, first order, the bound of tests/support/mls_reference.hpp (|dv'| from |dq*|,
  ///                |dH|_F <= (J + 16) eps Habs, the fit's |dR|_F <= 2 (|dH|_F + 16 eps |H|_F) / gap, and mu),
  ///                which compare_with_direct holds every deformer test to; for any thread count or block
  ///                schedule the same bits (each vertex's sums run over the pseudo-handles in one order)
  ///   Valid range: a frame the session built (finite targets, validated by the session; a vertex on a
  ///                handle takes its target exactly)
  static void run(const DeformFrame<T>& fr, std::size_t block_begin, std::size_t block_end) {
    // Affine sessions have only `linear` (the session refuses the others).
    const bool frames = fr.quaternions || fr.rotations || fr.scales || fr.linear;
    if (fr.transform == Transform::affine) {  // no fit: one batch at a time
      for (std::size_t b = block_begin; b < block_end; ++b)
        for (std::size_t g = 0; g < kLanes && b * kLanes + g < fr.n; g += W) {
          Result res;
          affine(fr, b, g, res);
          store(fr, b * kLanes + g, res.out);
          if (frames) store_frames(fr, b * kLanes + g, res);
        }
      return;
    }
    // Rigid, similarity: the batches' H gathered kFitTile at a time, fitted side by side (L::fit_tile, each
    // lane bitwise as alone), then finished and stored in the same order.
    constexpr std::size_t B = L::kFitTile;
    Pending p[B];
    V h[B][9], r[B][9];
    std::size_t v0[B], nb = 0;
    const auto flush = [&] {
      for (std::size_t u = 0; u < nb; ++u)
        for (int i = 0; i < 9; ++i) h[u][i] = p[u].h[i];  // the fit normalises its copy; mu needs H
      L::template fit_tile<B>(fr.method, h, r, nb);
      for (std::size_t u = 0; u < nb; ++u) {
        Result res;
        finish(fr, p[u], r[u], res);
        store(fr, v0[u], res.out);
        if (frames) store_frames(fr, v0[u], res);
      }
      nb = 0;
    };
    // Only similarity's scale reads D = sum_j A_j . phat_j: the rigid loops over the handles skip its 6
    // operations in 42 (the stored weights' path; `table` reads a stored D).
    const bool similarity = fr.transform == Transform::similarity;
    for (std::size_t b = block_begin; b < block_end; ++b)
      for (std::size_t g = 0; g < kLanes && b * kLanes + g < fr.n; g += W) {
        v0[nb] = b * kLanes + g;
        if (fr.weights == WeightSource::on_the_fly)
          similarity ? on_the_fly<true>(fr, v0[nb], p[nb]) : on_the_fly<false>(fr, v0[nb], p[nb]);
        else if (fr.weights == WeightSource::weights)
          similarity ? weights_only<true>(fr, b, g, p[nb]) : weights_only<false>(fr, b, g, p[nb]);
        else
          table(fr, b, g, p[nb]);
        if (++nb == B) flush();
      }
    if (nb > 0) flush();
  }
};

}  // namespace mlsdeform::kernels
