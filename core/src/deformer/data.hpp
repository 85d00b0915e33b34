// The MLS deformer's precomputed session data (paper Sec. 5: "all values of vhat, p*, w and phat_i are
// precomputed"), laid out for structure-of-arrays kernels. Written by precompute*.cpp; the session hands it
// to the kernels (the scalar reference reference.hpp and the SIMD kernels alike) as a DeformFrame, whose
// layout constants and table indexing are kernels/contract.hpp.
//
// Pseudo-handles. Every handle is reduced to pseudo-handles j = 0 .. J-1, each with a rest position p_j and
// a target q_j: point handle i is pseudo-handle i (p = points(i), q = moved points(i)); segment handle s
// gives pseudo-handles k + 2s (its end a -> target c) and k + 2s + 1 (end b -> target d), k the number of
// point handles. Per vertex v and pseudo-handle j the precomputation stores
//   omega_j   the centroid weight, sum_j omega_j = 1:  q* = sum_j omega_j q_j                    (eq. 2)
//   A_j       a 3-vector with sum_j A_j = 0:             H = sum_j q_j A_j^T = sum_j qhat_j A_j^T   (eq. 6)
// Points: omega_i = w_i / S, A_i = omega_i phat_i. Segments (Sec. 6.2, moments I0, I1, I2 of weights.hpp):
//   omega_c = (I0 + I1) / S, omega_d = (I1 + I2) / S, A_c = (I0 ahat + I1 bhat) / S, A_d = (I1 ahat + I2 bhat) / S,
// S the total weight (point weights plus segment integrals), so that H = sum_i int w qhat(t) phat(t)^T dt / S
// exactly as in Sec. 6.2 (the paper's W_i split into the two end points).
//
// Per-frame evaluation of vertex v (rigid and similarity; Algorithm 1 steps 2-10), in the local frame (Units):
//   q*  = sum_j omega_j q_j                                 (exact at snapped vertices)
//   H   = sum_j (q_j - c) A_j^T                             (c: any per-frame point, e.g. the mean target;
//                                                            equal to sum_j q_j A_j^T since sum_j A_j = 0, but
//                                                            without cancellation when the scene is far from
//                                                            the origin)
//   R   = fit_rotation(H, method)
//   mu  = 1 (rigid), trace(R^T H) / D (similarity, Sec. 6.1; 1 where D = 0)
//   v'  = q* + mu R vhat
// Units. Everything, the rest pose and every frame, is computed in the local frame (local_frame.hpp): the
// caller's coordinates times 2^-e (`scale` = 2^e, an exact power of two close to the scene size; rest
// positions are also moved to the handles' centre, local_frame.hpp). The kernels read a target q as q 2^-e and write a
// result x as x 2^e (DeformFrame's local_scale and world_scale): products with powers of two, exact in the normal
// range, so that a scene scaled by 2^k runs on the same bits, and its output is the unscaled output times
// 2^k, rounded once where it is subnormal. Targets may be at most coordinate_limit 2^e from the origin
// (`target_limit`), so that they and their sums stay finite in the local frame. vhat is stored in the local
// frame; H matters only up to a positive factor (fit_rotation is scale-invariant, and mu = trace(R^T H) / D
// when D carries the same factor), so each vertex's A_j and D are stored multiplied by a power of two: the
// stored A_j are the local-frame A_j times 2^s_v, with s_v chosen per vertex so that sum_j |A_j|_1 is in
// [1, 2); D is stored as (local-frame D) * 2^s_v. So |H_rs| <= 2 max_j |q_j - c| never overflows, and near a
// handle, where every A_j is about (d_min / d)^u (below the float range for u = 8 a few 1e-5 of the scene
// away), nothing underflows either. trace(R^T H) / D is still the paper's mu_s.
//
// Affine (Schaefer et al. 2006 normal equations, with G = sum_j A_j phat_j^T = sum_i int w phat phat^T / S):
//   v' = q* + H G^-1 vhat = sum_j alpha_j q_j,   alpha_j = omega_j + A_j . (G^-1 vhat)   (precomputed)
// and the fit's matrix, the frames' linear part (FramesOut::linear, x -> L x; Schaefer et al.'s M transposed):
//   L = H G^-1 = sum_j (q_j - c) B_j^T,          B_j = G^-1 A_j                          (precomputed)
// B_j does not depend on the per-vertex power of two (A and G both carry it), sums to 0 over j as A_j does
// (projected likewise), and is stored beside alpha in its own table (linear_table), 3 values per vertex and
// pseudo-handle, only with Options::affine_frames: then a session's table is 4 times the alpha table alone, the
// same size as a rigid one (most affine sessions want positions alone, and keep alpha's quarter).
//
// Snapped vertices (closer to a handle than 64 eps(T) times their distance to the second-nearest handle;
// snap.hpp derives the rule) take the map's limit at that handle (precompute_table.cpp). At a point handle, or a
// segment with exact_integral weights: omega = 1 on that point handle (or 1 - t, t on the ends of that segment, t the
// closest point), A = 0, D = 0 and vhat = 0, so v' = q* exactly. At a segment with paper_constant weights: the
// coefficients of that segment alone with constant weight (omega = 1/2 at each end), as if every other handle's
// weight had vanished. Their frames are not the table's: every storage takes them apart, as the fit's limit at the
// handle, in double (near_handles.hpp, `near` below).
//
// Layout. Vertices are grouped in blocks of kLanes = 16 (padded; padding lanes carry omega = 0, A = 0,
// vhat = 0, D = 0, alpha = 0). All arrays are 64-byte aligned.
//   table (rigid, similarity): table[((b * J + j) * 4 + c) * 16 + lane], c = 0 omega, 1 Ax, 2 Ay, 3 Az
//   table (affine):            table[(b * J + j) * 16 + lane] = alpha_j
//   linear_table (affine_frames): linear_table[((b * J + j) * 3 + c) * 16 + lane] = B_j component c
//   p_star, vhat (rigid, similarity): [c * padded + v] for coordinate c (SoA), padded = 16 * blocks
//   D (similarity only):       [v]
#pragma once

#include "core/src/deformer/near_handles.hpp"
#include "kernels/contract.hpp"

#include <mlsdeform/deformer.hpp>

#include <cstddef>
#include <cstdlib>
#include <new>
#include <vector>

namespace mlsdeform::detail {

using kernels::kAlignment;
using kernels::kLanes;

template <class T>
struct AlignedAllocator {
  using value_type = T;
  AlignedAllocator() = default;
  template <class U>
  AlignedAllocator(const AlignedAllocator<U>&) noexcept {}
  T* allocate(std::size_t n) {
    if (n > (std::size_t(-1) - kAlignment) / sizeof(T)) throw std::bad_alloc();
    const std::size_t bytes = (n * sizeof(T) + kAlignment - 1) / kAlignment * kAlignment;
    void* p = std::aligned_alloc(kAlignment, bytes == 0 ? kAlignment : bytes);
    if (!p) throw std::bad_alloc();
    return static_cast<T*>(p);
  }
  void deallocate(T* p, std::size_t) noexcept { std::free(p); }
  template <class U>
  bool operator==(const AlignedAllocator<U>&) const noexcept {
    return true;
  }
};

template <class T>
using AlignedVector = std::vector<T, AlignedAllocator<T>>;

template <class T>
struct DeformerData {
  Transform transform = Transform::rigid;
  std::size_t n = 0;         ///< vertices
  std::size_t blocks = 0;    ///< ceil(n / kLanes)
  std::size_t points = 0;    ///< point handles k
  std::size_t segments = 0;  ///< segment handles s
  /// Fixed point handles (a region's ring) folded into kFoldedHandles pseudo-handles (fold.hpp), 0 if none:
  /// then `points` counts the four in their place.
  std::size_t folded = 0;
  double scale = 1;               ///< the local frame's power of two 2^e (see Units above)
  T target_limit = 0;             ///< the largest magnitude of a target coordinate (see Units above)
  AlignedVector<T> table;         ///< omega, A (rigid, similarity) or alpha (affine), blocked as above
  AlignedVector<T> linear_table;  ///< affine_frames: B_j = G^-1 A_j, blocked as above (frames' linear)
  AlignedVector<T> p_star;        ///< rigid, similarity: weighted centroid of the rest handles, SoA, padded
  AlignedVector<T> vhat;          ///< rigid, similarity: v - p*, local frame, SoA, padded
  AlignedVector<T> D;             ///< similarity: sum_j A_j . phat_j (= sum_i w_i |phat_i|^2 / S), local, padded

  // WeightStorage::on_the_fly (rigid and similarity with point handles only): no table; per frame the
  // weights are recomputed from the distances (kernels/deformer/deform_kernel.hpp, on_the_fly). Local frame:
  // x_local = (x - centre) / scale.
  bool on_the_fly = false;
  AlignedVector<T> v_local;  ///< rest vertices, local frame, SoA, padded
  AlignedVector<T> dref2;    ///< squared distance to the nearest handle, local (padding lanes: 1)
  AlignedVector<T> snap;     ///< index of the handle a vertex sits on (snap.hpp), else -1
  AlignedVector<T> p_local;  ///< point handles, local frame, SoA: x[k], y[k], z[k]
  T half_u = 1;              ///< u / 2: w = (dref2 / d2)^(u/2)

  // WeightStorage::precomputed_weights (as on_the_fly: rigid and similarity with point handles only): the
  // on-the-fly data above (v_local, snap, p_local; dref2 unused) and the weights themselves. Per frame A_j =
  // w_j ((p_j - v) - (p* - v)) (kernels/deformer/deform_kernel.hpp, weights_only).
  bool weights_only = false;
  AlignedVector<T> weights;       ///< w_j / S, the 16 lanes of block b, handle j at (b k + j) 16 (snapped: 0)
  AlignedVector<T> p_star_local;  ///< p* - v, local frame, SoA, padded (snapped: 0)
  /// sum_j A_j as the per-frame pass forms the A_j, in T (precompute_on_the_fly.cpp), SoA, padded (snapped: 0);
  /// similarity's D = sum_j A_j . phat_j likewise, in D above.
  AlignedVector<T> sum_a;

  /// Vertices on a handle, and (table storage) beside a dominant segment: their frames, and beside a segment their
  /// positions, computed apart after the kernels' blocks, in every storage (near_handles.hpp).
  NearHandles near;

  std::size_t pseudo_handles() const { return points + 2 * segments; }
  std::size_t padded() const { return blocks * kLanes; }
  /// Values per block and pseudo-handle: 4 (omega, Ax, Ay, Az) or 1 (alpha).
  std::size_t components() const { return kernels::table_components(transform); }
  /// The 16-lane arrays of block b, pseudo-handle j: omega at [0], Ax at [16], Ay at [32], Az at [48]
  /// (rigid, similarity) or alpha at [0] (affine).
  const T* coefficients(std::size_t b, std::size_t j) const {
    return table.data() + kernels::table_offset(b, j, pseudo_handles(), transform);
  }
  T* coefficients(std::size_t b, std::size_t j) {
    return table.data() + kernels::table_offset(b, j, pseudo_handles(), transform);
  }

  std::size_t bytes() const {
    return (table.capacity() + linear_table.capacity() + p_star.capacity() + vhat.capacity() + D.capacity() +
            v_local.capacity() + dref2.capacity() + snap.capacity() + p_local.capacity() + weights.capacity() +
            p_star_local.capacity() + sum_a.capacity()) *
               sizeof(T) +
           near.bytes();
  }
};

}  // namespace mlsdeform::detail
