// The typed contract between core/ (baseline flags: the scalar reference, the session, the drivers) and the
// per-ISA kernels: the lane block and the table layout, the numeric parameters both paths share, and the
// frame a deformation kernel reads. Included by both sides, so that neither copies a constant or an index
// formula from the other.
//
// Nothing here may become an out-of-line symbol shared by a baseline and an ISA object (an inline function
// becomes a weak symbol, and the linker keeps one copy, possibly AVX-512, for every caller): functions and
// constants are `static` (internal linkage, a private copy in each object), types have no member functions.
#pragma once

#include <mlsdeform/enums.hpp>

#include <cstddef>
#include <cstdint>

namespace mlsdeform::kernels {

// ---------------------------------------------------------------------------------------------------------
// Layout of the deformer's session data (core/src/deformer/data.hpp documents the algebra)
// ---------------------------------------------------------------------------------------------------------

/// Vertices per block (the widest SIMD register holds 16 floats); every kernel's width divides it.
static constexpr std::size_t kLanes = 16;
/// Alignment of every precomputed array, in bytes (one cache line; the widest vector register).
static constexpr std::size_t kAlignment = 64;

/// Values per block and pseudo-handle in the coefficient table: omega, Ax, Ay, Az (rigid, similarity) or
/// alpha (affine).
static constexpr std::size_t table_components(Transform transform) { return transform == Transform::affine ? 1 : 4; }

/// Offset of the 16-lane arrays of block b, pseudo-handle j (of J) in the table: component c of lane l is at
/// offset + c * kLanes + l.
static constexpr std::size_t table_offset(std::size_t b, std::size_t j, std::size_t J, Transform transform) {
  return (b * J + j) * table_components(transform) * kLanes;
}

/// Affine sessions' second table, the frames' linear part (data.hpp): per block and pseudo-handle the three
/// components of B_j = G^-1 A_j, component c of lane l at offset + c * kLanes + l. Apart from the alpha table,
/// so that the position pass reads what it read before.
static constexpr std::size_t linear_table_offset(std::size_t b, std::size_t j, std::size_t J) {
  return (b * J + j) * 3 * kLanes;
}

// ---------------------------------------------------------------------------------------------------------
// Parameters of the axis/angle fit, the same in core/src/rotation/ and kernels/rotation/
// ---------------------------------------------------------------------------------------------------------

/// maximum_root (13): Newton steps allowed on the fast path; lanes still moving take the careful path.
static constexpr int kMaxNewton = 16;
/// The careful path's Jacobi sweeps at most (convergence is checked from the third sweep on).
static constexpr int kMaxSweeps = 12;
/// The careful path's trigger, |adj_kk|^2 <= tau^2 ||H||^6 with tau = cbrt(eps) / 2 (derived at
/// detail::rotation_axis in core/src/rotation/rotation_axis.hpp); cbrt(2^-23) = 2^-7.67, cbrt(2^-52) =
/// 2^-17.33, as literals: no std::cbrt may be emitted in an ISA object.
template <class T>
static constexpr T kCarefulTau = sizeof(T) == 4 ? T(0.5 * 4.92156660e-3) : T(0.5 * 6.0554544523933395e-6);

// ---------------------------------------------------------------------------------------------------------
// The ARAP local step's one-ring sums (core/src/arap/ring_correlation.hpp, kernels/arap/ring_correlation.hpp)
// ---------------------------------------------------------------------------------------------------------

/// One local step's sums over an ARAP session's one-rings (core/src/arap/arap_refiner.cpp), in the session's
/// units, in both layouts: CSR, which the scalar reference reads (the neighbours of i are nbr[start[i] ..
/// start[i + 1]), with w_ij in w and w_ij (p_i - p_j) in we, 3 per edge), and padded into blocks of kLanes
/// vertices, which the SIMD twin reads: block b has the slots [slot_begin[b], slot_begin[b + 1]), as many as
/// its largest valence; slot s gives lane l (vertex kLanes b + l) its neighbour's row offset 3 j at
/// slot_x[s kLanes + l], w_ij (p_i - p_j) at slot_a[(3 s + c) kLanes + l] and w_ij at slot_w[s kLanes + l],
/// the CSR's neighbours in order, then padding slots of the lane's own row with weight 0. self[b kLanes + l]
/// is 3 i, or for a lane past n the block's first vertex's (its results are not stored).
template <class T>
struct RingFrame {
  std::size_t n;    ///< vertices
  const double* x;  ///< positions, row-major n x 3
  const std::ptrdiff_t* start;
  const std::ptrdiff_t* nbr;
  const double* w;
  const double* we;
  const std::size_t* slot_begin;
  const std::int64_t* self;
  const std::int64_t* slot_x;
  const double* slot_a;
  const double* slot_w;
  /// Output: S_i scaled by a power of two to max |S_i| in [1, 2) and rounded to T, entry (r, c) at
  /// H[(3 r + c) n + i] (the batched fit's layout, FitRotationsFn).
  T* H;
  /// nullptr, or the energy's record per vertex (core/src/arap/ring_energy.hpp): S_i unscaled (9 values,
  /// row-major) and sum_j w_ij |x_i - x_j|^2, at ring[10 i].
  double* ring;
  /// The global step's rotated sums (ring_rhs, core/src/arap/ring_correlation.hpp), where not null: the local
  /// step's rotations as R_i^T row-major (R_i's three columns side by side, 9 values per vertex, at R[9 i], and
  /// one more value after the last: the SIMD twin's padding) and c_i = sum_j w_ij (p_i - p_j) (at c[3 i]) in;
  /// b_i = (R_i c_i + sum_j R_j w_ij (p_i - p_j)) / 2 out, at b[3 i].
  const T* R;
  const double* c;
  double* b;
};

// ---------------------------------------------------------------------------------------------------------
// The frame of one deformation
// ---------------------------------------------------------------------------------------------------------

/// Where a frame's per-vertex weights come from (WeightStorage in deformer.hpp).
enum class WeightSource { table, on_the_fly, weights };

/// One frame of the MLS deformation over the session data of core/src/deformer/data.hpp. Filled by the
/// session (core/src/deformer/deformer.cpp) and read by every entry of the kernel table, the scalar reference
/// included. Targets come straight from the caller's handles: point j at (points[j], points[k + j],
/// points[2k + j]) (column-major k x 3), then for each segment i its ends seg_a and seg_b (column-major s x 3).
/// The kernels work in the session's local frame (data.hpp, Units): a target q enters as q * local_scale, and
/// a result leaves as (local result) * world_scale, both exact powers of two, so that no intermediate
/// overflows or underflows and the frame is the same, to the bit, at every scale of the scene.
template <class T>
struct DeformFrame {
  Transform transform;    ///< rigid, similarity or affine
  RotationMethod method;  ///< the SIMD tables run axis_angle and horn_quaternion; the scalar one, all
  WeightSource weights;

  // Session data (rest pose).
  std::size_t n;          ///< vertices (the last block may be partial)
  std::size_t padded;     ///< kLanes * blocks
  const T* table;         ///< WeightSource::table: the coefficient table (table_offset)
  const T* vhat;          ///< rigid, similarity: vhat[c * padded + v]
  const T* D;             ///< similarity: D[v]; else nullptr
  const T* linear_table;  ///< affine: B_j = G^-1 A_j (linear_table_offset), read when `linear` is wanted
  // WeightSource::on_the_fly: weights from the rest distances, recomputed per frame.
  const T* v_local;  ///< rest vertices, local frame, SoA [c * padded + v]
  const T* dref2;    ///< squared nearest-handle distance [v]
  const T* snap;     ///< handle index a vertex sits on, or -1 [v]
  const T* p_local;  ///< point handles, local frame, SoA [c * k + j]
  T half_u;          ///< u / 2
  // WeightSource::weights: v_local, snap and p_local as above, and
  const T* wn;            ///< w_j / S, lane l of block b, handle j at (b k + j) kLanes + l
  const T* p_star_local;  ///< p* - v, local frame, SoA [c * padded + v]
  const T* sum_a;         ///< sum_j A_j, SoA [c * padded + v] (similarity's D in D)
  T local_scale;          ///< 2^-e: the caller's units to the local frame's
  T world_scale;          ///< 2^e: the local frame's units to the caller's

  // Targets.
  const T* points;  ///< k x 3 column-major
  std::size_t k;
  const T* seg_a;  ///< s x 3 column-major
  const T* seg_b;
  std::size_t s;
  T centre[3];  ///< c, local frame: H = sum_j (q_j local_scale - c) A_j^T
  /// When not null, the J = k + 2 s pseudo-handles' targets as the kernels read them, computed once per frame
  /// (fill_targets): six values per pseudo-handle, q_j local_scale at [6 j + c], q_j local_scale - c at
  /// [6 j + 3 + c] (one base address per handle: the loops broadcast each straight from memory). Else each batch
  /// computes them again from points, seg_a and seg_b (the same operations: the same bits).
  const T* targets;

  // Output: vertex v, coordinate c at out[c * out_coord_stride + v * out_vertex_stride].
  T* out;
  std::size_t out_vertex_stride, out_coord_stride;

  // Frames (FramesOut, mlsdeform/frames.hpp), each row-major per vertex or nullptr: not wanted (affine: only
  // `linear`, the fit's matrix H G^-1). Vertex v's unit quaternion (w, x, y, z) at quaternions[4 v], R at rotations[9
  // v], the similarity scale at scales[v], the linear part mu R at linear[9 v]. Unitless: no world_scale.
  T* quaternions;
  T* rotations;
  T* scales;
  T* linear;
};

/// A pseudo-handle's target in the local frame, q = q_j local_scale, and qc = q - c (the centred target of
/// correlation_matrix).
template <class T>
struct Target {
  T q[3], qc[3];
};

/// The target of pseudo-handle j at (x, y, z) times local_scale, or of the J pseudo-handles' `targets`.
template <class T>
static inline __attribute__((always_inline)) Target<T> make_target(const DeformFrame<T>& fr, T x, T y, T z) {
  const T ls = fr.local_scale;
  Target<T> t{{x * ls, y * ls, z * ls}, {}};
  for (int c = 0; c < 3; ++c) t.qc[c] = t.q[c] - fr.centre[c];
  return t;
}
template <class T>
static inline __attribute__((always_inline)) Target<T> cached_target(const T* targets, std::size_t j) {
  const T* t = targets + 6 * j;
  return {{t[0], t[1], t[2]}, {t[3], t[4], t[5]}};
}

/// The target of point handle j.
template <class T>
static inline __attribute__((always_inline)) Target<T> point_target(const DeformFrame<T>& fr, std::size_t j) {
  if (fr.targets) return cached_target(fr.targets, j);
  return make_target(fr, fr.points[j], fr.points[fr.k + j], fr.points[2 * fr.k + j]);
}

/// Calls f(j, t) for the target t of every pseudo-handle j = 0, 1, ..., J-1 in order (the point targets,
/// then each segment's two ends), in the local frame: the one order in which every deformation kernel, the
/// scalar reference included, visits the pseudo-handles, so that a vertex's sums see the same terms in the
/// same order whatever the width, thread or block schedule.
template <class T, class F>
static inline __attribute__((always_inline)) void for_each_target(const DeformFrame<T>& fr, F&& f) {
  const std::size_t J = fr.k + 2 * fr.s;
  if (fr.targets) {
    for (std::size_t j = 0; j < J; ++j) f(j, cached_target(fr.targets, j));
    return;
  }
  std::size_t j = 0;
  for (std::size_t i = 0; i < fr.k; ++i, ++j) f(j, point_target(fr, i));
  for (std::size_t i = 0; i < fr.s; ++i) {
    f(j++, make_target(fr, fr.seg_a[i], fr.seg_a[fr.s + i], fr.seg_a[2 * fr.s + i]));
    f(j++, make_target(fr, fr.seg_b[i], fr.seg_b[fr.s + i], fr.seg_b[2 * fr.s + i]));
  }
}

/// Calls f(j, t) for the target t of every point handle j = 0, 1, ..., k-1 in order: for_each_target where a
/// session has no segments. Two loops, so that the cached targets' is compiled alone: there each target is
/// broadcast straight from memory (with one loop over point_target, the compiler loaded the six values and
/// broadcast them from registers, six more operations per handle on the arithmetic ports).
template <class T, class F>
static inline __attribute__((always_inline)) void for_each_point_target(const DeformFrame<T>& fr, F&& f) {
  if (fr.targets)
    for (std::size_t j = 0; j < fr.k; ++j) f(j, cached_target(fr.targets, j));
  else
    for (std::size_t j = 0; j < fr.k; ++j) f(j, point_target(fr, j));
}

/// Pseudo-handles whose targets a frame computes once (DeformFrame::targets) on its caller's stack:
/// 6 kCachedTargets values, 12 KiB in float. Frames with more compute them in every batch.
inline constexpr std::size_t kCachedTargets = 512;

/// The frame's DeformFrame::targets (6 J values) into out.
template <class T>
static void fill_targets(const DeformFrame<T>& fr, T* out) {
  DeformFrame<T> f = fr;
  f.targets = nullptr;
  for_each_target(f, [&](std::size_t j, const Target<T>& t) {
    for (std::size_t c = 0; c < 3; ++c) out[6 * j + c] = t.q[c], out[6 * j + 3 + c] = t.qc[c];
  });
}

}  // namespace mlsdeform::kernels
