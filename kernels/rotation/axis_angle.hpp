// The batched axis/angle rotation fit (Algorithm 1 steps 3-7), one matrix per SIMD lane, twin of
// detail::fit_rotation_axis_angle in core/src/rotation/axis_angle.hpp, stage by stage:
// normalise -> invariants (6) -> maximum_root (13) -> rotation_axis (14) -> sin_cos (15)/(5) for every lane,
// and for the lanes this fast path cannot settle a careful path: K's top eigenvector by Jacobi (jacobi.hpp).
#pragma once

#include "kernels/contract.hpp"
#include "kernels/kernel_table.hpp"
#include "kernels/rotation/invariants.hpp"
#include "kernels/rotation/jacobi.hpp"
#include "kernels/rotation/maximum_root.hpp"
#include "kernels/rotation/rotation_axis.hpp"
#include "kernels/rotation/sin_cos.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>

namespace mlsdeform::kernels {

/// h <- 2^-e h with max |h_ij| in [1, 2) per lane (the scalar fit_rotation's exact normalisation); returns
/// the lanes with H = 0 (left at zero).
///
/// For a subnormal m, 2^-e is not a number of T (2^149 at m = denorm_min): pow2_inverse_exponent clamps it
/// to 2^126 (double: 2^1022), which leaves max |h| in [2^-23, 1) (double: [2^-52, 1)), and m >= 2^127
/// (2^1023) in [2, 4). The fit forms powers of h up to the sixth (n3 = ||h||^6, dk^2 against it; the
/// quartic's coefficients, the fourth). In float (2^-23)^6 = 2^-138 is below the normal range (H = 1e-44 I
/// gave NaN), so float takes a second power of two, as the scalar code multiplies by two factors: 1 in the
/// other lanes, branch-free (cheaper than a branch to the rare lanes: bench_rotation_fit). For a subnormal m
/// both products are exact: the first only shifts exponents (a subnormal entry gains leading bits), the
/// second leaves every nonzero entry at >= 2^-23 max |h|, a normal number. In double (2^-52)^6 = 2^-312 is
/// far inside the range, and every stage is exact under a power-of-two scaling that neither underflows nor
/// overflows, so one factor gives bitwise the result of max |h| in [1, 2) (test_batch_accuracy checks both
/// precisions at every subnormal scale).
///   Lanes:       float, double (an xsimd batch, or a Pair of them)
///   Error:       none (products with powers of two)
///   Valid range: every finite h, subnormal entries included; returns the lanes with H = 0
template <class V>
MLSDEFORM_KERNEL_INLINE mask_of<V> normalise(V (&h)[9]) {
  using T = scalar_of<V>;
  V m = abs(h[0]);
  for (int i = 1; i < 9; ++i) m = max(m, abs(h[i]));
  const mask_of<V> zero = m == V(T(0));
  const V m1 = select(zero, V(T(1)), m);
  const V scale = pow2_inverse_exponent(m1);
  if constexpr (sizeof(T) == 4) {
    const V rescale = pow2_inverse_exponent(m1 * scale);  // if (m subnormal or >= 2^127) h *= 2^-ilogb(m 2^-e)
    for (int i = 0; i < 9; ++i) h[i] = (h[i] * scale) * rescale;
  } else {
    for (int i = 0; i < 9; ++i) h[i] = h[i] * scale;
  }
  return zero;
}

/// The identity in the lanes `zero` (H = 0), r elsewhere.
template <class V>
MLSDEFORM_KERNEL_INLINE void identity_where(const mask_of<V>& zero, V (&r)[9]) {
  using T = scalar_of<V>;
  for (int i = 0; i < 9; ++i) r[i] = select(zero, V(i % 4 == 0 ? T(1) : T(0)), r[i]);
}

/// The number of true lanes of m.
template <class V>
std::size_t count_lanes(const mask_of<V>& m) {
  using T = scalar_of<V>;
  alignas(64) T tmp[V::size];
  select(m, V(T(1)), V(T(0))).store_aligned(tmp);
  std::size_t c = 0;
  for (std::size_t i = 0; i < V::size; ++i) c += tmp[i] != T(0);
  return c;
}

/// The careful path of rotation_from_root: q <- the top eigenvector of K (top_eigenvector) in the lanes
/// `slow`, which are added to `careful`. Out of line: it is rare, and inlined into each batch of a tile its
/// Jacobi sweeps crowded the fast path's registers (more spills, slower fits where it never ran).
template <class V>
[[gnu::noinline]] void careful_path(const Mat4<V>& K, V norm2, mask_of<V> slow, Vec4<V>& q, std::size_t& careful) {
  using T = scalar_of<V>;
  // ||K||_F = 2 ||H||_F (Davenport's K: |E|^2 + 2 |z|^2 + ||H + H^T - E I||^2 = 4 ||H||^2).
  const Vec4<V> q1 = top_eigenvector(K, sqrt(V(T(4)) * norm2));
  for (int i = 0; i < 4; ++i) q.v[i] = select(slow, q1.v[i], q.v[i]);
  careful += count_lanes<V>(slow);
}

/// The fast path of Algorithm 1 steps 5-6: Davenport's K and the unnormalised axis q (14) from the root y of
/// maximum_root; returns the lanes it cannot settle (`slow`: a root not converged, or the adjugate's largest
/// diagonal entry below kCarefulTau ||H||^3), where q means nothing and the careful path must replace it.
template <class V>
MLSDEFORM_KERNEL_INLINE mask_of<V> fast_rotation_axis(const V (&h)[9], const Invariants<V>& inv, V y,
                                                      mask_of<V> converged, Mat4<V>& K, Vec4<V>& q) {
  using T = scalar_of<V>;
  using M = mask_of<V>;
  const M zero = inv.norm2 == V(T(0));  // normalised: ||H||^2 >= 1 unless H = 0
  K = davenport(h, inv);
  V dk;
  q = rotation_axis(K, y, dk);
  const V n3 = inv.norm2 * inv.norm2 * inv.norm2;
  constexpr T tau2 = kCarefulTau<T> * kCarefulTau<T>;
  return ~zero & (~converged | ~(dk * dk > V(tau2) * n3));
}

/// Algorithm 1 steps 5-7 of fit_rotation_axis_angle, from the root y of maximum_root (and its lanes
/// `converged`) on: the axis (14) and the rotation (15), the careful path where the fast one cannot settle a
/// lane.
///   Lanes, Error, Valid range: as fit_rotation_axis_angle
template <class V>
MLSDEFORM_KERNEL_INLINE void rotation_from_root(const V (&h)[9], const Invariants<V>& inv, V y, mask_of<V> converged,
                                                V (&r)[9], std::size_t& careful) {
  Mat4<V> K;
  Vec4<V> q;
  const mask_of<V> slow = fast_rotation_axis(h, inv, y, converged, K, q);
  if (any(slow)) careful_path(K, inv.norm2, slow, q, careful);
  sin_cos(q, r);
}

/// Lanes whose fast path could not settle them (fast_rotation_axis's `slow`), queued by fit_range_axis_angle
/// with their normalised H and their place in the output, and fitted W at a time by the careful path
/// (flush). A lane's careful result does not depend on its batch companions: top_eigenvector's Jacobi sweeps
/// leave a lane whose off-diagonal entries are all below its threshold unchanged (each rotation is skipped,
/// c = 1 and s = 0 exactly), so a lane swept longer for its companions' sake keeps its bits; and K and ||H||^2
/// are recomputed from the same h by the same operations. On point-set H 0.12% of float lanes take this path
/// (bench_rotation_fit's lanes_careful): alone in its batch, each cost a whole batch's Jacobi sweeps, a tenth
/// of the batched fit's time.
template <class V>
struct CarefulQueue {
  using T = scalar_of<V>;
  static constexpr std::size_t W = V::size;
  alignas(64) T h[9][W];
  std::size_t at[W];  // the matrix's index in the output
  std::size_t count = 0;

  /// Queues the lanes `slow` of the batch h (normalised) whose lane i is output matrix first + i; flushes to
  /// R (row stride `stride`) whenever W are queued.
  MLSDEFORM_KERNEL_INLINE void push(const V (&hb)[9], const mask_of<V>& slow, std::size_t first, T* R,
                                    std::size_t stride, std::size_t& careful) {
    alignas(64) T lane_h[9][W], flag[W];
    select(slow, V(T(1)), V(T(0))).store_aligned(flag);
    for (std::size_t e = 0; e < 9; ++e) hb[e].store_aligned(lane_h[e]);
    for (std::size_t i = 0; i < W; ++i) {
      if (flag[i] == T(0)) continue;
      for (std::size_t e = 0; e < 9; ++e) h[e][count] = lane_h[e][i];
      at[count++] = first + i;
      if (count == W) flush(R, stride, careful);
    }
  }

  /// The careful path (careful_path's top eigenvector, then sin_cos) of the queued lanes, written to R; the
  /// unused lanes hold H = 0, for which the sweeps skip every rotation.
  [[gnu::noinline]] void flush(T* R, std::size_t stride, std::size_t& careful) {
    if (count == 0) return;
    V hv[9], r[9];
    for (std::size_t e = 0; e < 9; ++e) {
      for (std::size_t i = count; i < W; ++i) h[e][i] = T(0);
      hv[e] = V::load_aligned(h[e]);
    }
    const Invariants<V> inv = invariants(hv);
    const Vec4<V> q = top_eigenvector(davenport(hv, inv), sqrt(V(T(4)) * inv.norm2));
    sin_cos(q, r);
    alignas(64) T out[9][W];
    for (std::size_t e = 0; e < 9; ++e) r[e].store_aligned(out[e]);
    for (std::size_t i = 0; i < count; ++i)
      for (std::size_t e = 0; e < 9; ++e) R[e * stride + at[i]] = out[e][i];
    careful += count;
    count = 0;
  }
};

/// The whole fit (Algorithm 1, steps 3-7) on a normalised H (h: 9 lanes of its row-major entries, each lane
/// max |h_ij| in [1, 2) or H = 0), as the scalar twin; r: the rotations. Every lane takes the fast path
/// (maximum_root, rotation_axis); the lanes it cannot settle (a multiple or unconverged root, or a gap below
/// cbrt(eps)) take the careful path, the top eigenvector of K by Jacobi (run only when some lane needs it),
/// and are added to `careful`. Lanes with H = 0, which the scalar fit_rotation never passes here, are left
/// out of the careful path (fit_rotation below gives them the identity).
/// Error (tests/support/accuracy_bounds.hpp, c_b = 16, c_o = 64): the exact optimum of some H + dH with
/// ||dH||_F <= 16 eps ||H||_F, so trace(R^T H) within (2 sqrt(3) 16 + 96) eps ||H||_F of the optimum, and
/// where the optimum is unique an angle to it <= 2 sqrt(3) 16 eps kappa + 96 eps (kappa = s1 / (s2 + d s3));
/// |(R^T R - I)_ij| <= 64 eps.
///   Lanes:       float, double (an xsimd batch, or a Pair of them)
///   Error:       as above (tests/test_batch_accuracy.cpp holds every lane to it)
///   Valid range: every finite normalised H
template <class V>
MLSDEFORM_KERNEL_INLINE void fit_rotation_axis_angle(const V (&h)[9], V (&r)[9], std::size_t& careful) {
  const Invariants<V> inv = invariants(h);
  mask_of<V> converged;
  const V y = maximum_root(inv, converged);
  rotation_from_root(h, inv, y, converged, r, careful);
}

/// Twin of the public fit_rotation (core/src/rotation/fit_rotation.cpp) for a fit `Fit::fit(h, r, careful)`
/// on a normalised H: h normalised exactly in place (normalise), the fit, and the identity where H = 0.
///   Lanes:       float, double (an xsimd batch, or a Pair of them)
///   Error:       the fit's (normalise is exact); the identity exactly where H = 0
///   Valid range: every finite H (the callers check: fit_rotations and the deformer's frames)
template <class Fit, class V>
MLSDEFORM_KERNEL_INLINE void fit_rotation(V (&h)[9], V (&r)[9], std::size_t& careful) {
  const mask_of<V> zero = normalise(h);
  Fit::fit(h, r, careful);
  identity_where(zero, r);
}

/// The kernel-table entry (FitRotationsFn) for a fit `Fit::fit(h, r, careful)` on vectors V: matrices
/// [begin, end) of a 3 x 3 x n layout, batch by batch (a partial last batch through a zero-padded copy).
///   Lanes:       float, double (an xsimd batch, or a Pair of them)
///   Error:       each matrix as fit_rotation<Fit> (the padding lanes hold H = 0 and are not written)
///   Valid range: finite H (fit_rotations checks); adds the careful lanes to stats->careful_lanes
template <class V, class Fit>
void fit_range(const scalar_of<V>* H, scalar_of<V>* R, std::size_t stride, std::size_t begin, std::size_t end,
               BatchStats* stats) {
  using T = scalar_of<V>;
  std::size_t careful = 0;
  SimdCommon<T, V::size>::for_each_batch(H, R, stride, begin, end,
                                         [&](const T* src, T* dst, std::size_t st, std::size_t off) {
                                           V h[9], r[9];
                                           for (std::size_t i = 0; i < 9; ++i)
                                             h[i] = V::load_unaligned(src + i * st + off);
                                           fit_rotation<Fit>(h, r, careful);
                                           for (std::size_t i = 0; i < 9; ++i) r[i].store_unaligned(dst + i * st + off);
                                         });
  if (stats) stats->careful_lanes += careful;
}

/// Batches of the axis/angle fit that fit_range_axis_angle keeps in flight together.
template <class V>
inline constexpr std::size_t kFitTileBatches = 4;

/// fit_rotation<AxisAngleFit> on nb <= B batches side by side (h normalised in place, as fit_rotation does),
/// stage by stage across the batches: normalise and invariants for each, the Newton steps of all nb batches
/// interleaved (maximum_root_tile: one batch's steps are a chain of dependent operations that leaves the core
/// mostly idle), then rotation_from_root for each, whose operations are independent enough that the core
/// overlaps consecutive batches by itself. Each lane computes exactly what fit_rotation<AxisAngleFit>
/// computes, so the rotations are bitwise the same (test_batch_fit).
///   Lanes:       float, double (an xsimd batch)
///   Error:       as fit_rotation_axis_angle
///   Valid range: every finite H
/// With `deferred` given, the lanes the fast path cannot settle are not fitted here: deferred[b] returns
/// them (their r means nothing; the caller queues them in a CarefulQueue, which counts them).
template <std::size_t B, class V>
MLSDEFORM_KERNEL_INLINE void fit_rotation_tile(V (&h)[B][9], V (&r)[B][9], std::size_t nb, std::size_t& careful,
                                               mask_of<V> (*deferred)[B] = nullptr) {
  Invariants<V> inv[B];
  mask_of<V> zero[B], converged[B];
  V y[B];
  for (std::size_t b = 0; b < nb; ++b) {
    zero[b] = normalise(h[b]);
    inv[b] = invariants(h[b]);
  }
  maximum_root_tile(inv, nb, y, converged);
  for (std::size_t b = 0; b < nb; ++b) {
    if (deferred) {
      Mat4<V> K;
      Vec4<V> q;
      (*deferred)[b] = fast_rotation_axis(h[b], inv[b], y[b], converged[b], K, q);
      sin_cos(q, r[b]);
    } else {
      rotation_from_root(h[b], inv[b], y[b], converged[b], r[b], careful);
    }
    identity_where(zero[b], r[b]);
  }
}

/// fit_rotation_tile on nb <= B batches of W = V::size matrices each, from offset off of a 3 x 3 x n layout
/// (row stride st). With a queue, the lanes for the careful path are queued (CarefulQueue: their rotations
/// are written when it flushes) rather than fitted in their batch. kStream: the rotations by store_streaming
/// (dst + off and st aligned to the vector's width).
template <std::size_t B, class V, bool kStream = false>
MLSDEFORM_KERNEL_INLINE void fit_tile_axis_angle(const scalar_of<V>* src, scalar_of<V>* dst, std::size_t st,
                                                 std::size_t off, std::size_t nb, std::size_t& careful,
                                                 CarefulQueue<V>* queue = nullptr) {
  constexpr std::size_t W = V::size;
  V h[B][9], r[B][9];
  mask_of<V> slow[B];
  for (std::size_t b = 0; b < nb; ++b)
    for (std::size_t i = 0; i < 9; ++i) h[b][i] = V::load_unaligned(src + i * st + off + b * W);
  fit_rotation_tile<B>(h, r, nb, careful, queue ? &slow : nullptr);
  for (std::size_t b = 0; b < nb; ++b)
    for (std::size_t i = 0; i < 9; ++i)
      if constexpr (kStream)
        store_streaming(dst + i * st + off + b * W, r[b][i]);
      else
        r[b][i].store_unaligned(dst + i * st + off + b * W);
  if (queue)
    for (std::size_t b = 0; b < nb; ++b)
      if (any(slow[b])) queue->push(h[b], slow[b], off + b * W, dst, st, careful);
}

/// The kernel-table entry (FitRotationsFn) of the axis/angle fit on vectors V: matrices [begin, end) of a
/// 3 x 3 x n layout, kFitTileBatches batches at a time (fit_tile_axis_angle), the batches left over as one
/// shorter tile, and a partial last batch through a zero-padded copy; the lanes for the careful path of the
/// whole range queued and fitted W at a time (CarefulQueue).
///   Lanes:       float, double (an xsimd batch)
///   Error:       each matrix as fit_rotation<AxisAngleFit>, bitwise (the padding lanes hold H = 0 and are
///                not written)
///   Valid range: finite H (fit_rotations checks); adds the careful lanes to stats->careful_lanes
/// kStream (the entry fit_axis_angle_stream, for a batch larger than the caches): the rotations written by
/// non-temporal stores (store_streaming) where the ISA has them and the layout allows (the row stride a multiple of
/// W, R aligned to a value): the matrices up to the first whose rows start on a vector boundary as kStream =
/// false, the rest streamed, and a store_fence before the queue's and the last batch's plain stores and the
/// return. The same bits either way.
template <class V, bool kStream = false>
void fit_range_axis_angle(const scalar_of<V>* H, scalar_of<V>* R, std::size_t stride, std::size_t begin,
                          std::size_t end, BatchStats* stats) {
  using T = scalar_of<V>;
  using A = typename V::arch_type;
  constexpr std::size_t W = V::size, B = kFitTileBatches<V>;
  if constexpr (kStream) {
    constexpr std::size_t bytes = W * sizeof(T);
    const auto at = reinterpret_cast<std::uintptr_t>(R + begin);
    if (!kStreamingStores<A> || stride % W != 0 || at % sizeof(T) != 0)
      return fit_range_axis_angle<V, false>(H, R, stride, begin, end, stats);
    const std::size_t head = std::min(end - begin, (bytes - at % bytes) % bytes / sizeof(T));
    if (head > 0) fit_range_axis_angle<V, false>(H, R, stride, begin, begin + head, stats);
    begin += head;
  }
  std::size_t careful = 0, i = begin;
  CarefulQueue<V> queue;
  // Streamed from memory, the 9 rows of H and R of the tile two tiles ahead are prefetched (B W values each):
  // the hardware prefetcher alone left the core waiting on them. Same process, AVX-512 (Zen 5), ns per fit,
  // streamed / in cache: float 8.77 -> 8.23 / 6.81, double 16.6 -> 15.5 / 12.1; AVX2 float 15.7 -> 11.1 / 10.4.
  // (Four tiles ahead measured no better.) On data in cache they cost an issue slot each. R is not prefetched
  // where it is streamed: its lines are written whole, never read (with the prefetch, 5.7 -> 6.9 ns, float).
  constexpr std::size_t kPrefetchTiles = 2, line = 64 / sizeof(T), tile = B * W;
  for (; i + tile <= end; i += tile) {
    if (const std::size_t ahead = i + kPrefetchTiles * tile; ahead + tile <= end)
      for (std::size_t e = 0; e < 9; ++e)
        for (std::size_t k = 0; k < tile; k += line) {
          __builtin_prefetch(H + e * stride + ahead + k);
          if constexpr (!kStream) __builtin_prefetch(R + e * stride + ahead + k, 1);
        }
    fit_tile_axis_angle<B, V, kStream>(H, R, stride, i, B, careful, &queue);
  }
  if (const std::size_t nb = (end - i) / W; nb > 0) {
    fit_tile_axis_angle<B, V, kStream>(H, R, stride, i, nb, careful, &queue);
    i += nb * W;
  }
  if constexpr (kStream) store_fence<A>();
  queue.flush(R, stride, careful);
  if (i < end) {
    alignas(64) T hb[9 * W] = {}, rb[9 * W];
    const std::size_t rem = end - i;
    for (std::size_t e = 0; e < 9; ++e)
      for (std::size_t j = 0; j < rem; ++j) hb[e * W + j] = H[e * stride + i + j];
    fit_tile_axis_angle<B, V>(hb, rb, W, 0, 1, careful);
    for (std::size_t e = 0; e < 9; ++e)
      for (std::size_t j = 0; j < rem; ++j) R[e * stride + i + j] = rb[e * W + j];
  }
  if (stats) stats->careful_lanes += careful;
}

struct AxisAngleFit {
  template <class V>
  MLSDEFORM_KERNEL_INLINE static void fit(const V (&h)[9], V (&r)[9], std::size_t& careful) {
    fit_rotation_axis_angle(h, r, careful);
  }
};

}  // namespace mlsdeform::kernels
