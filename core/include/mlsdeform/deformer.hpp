// mlsdeform: the MLS deformer (paper Sec. 3-6): every vertex gets the rigid, similarity or affine transform
// that best maps the handles' rest positions to their moved positions under inverse-distance weights.
#pragma once

#include <mlsdeform/arap.hpp>
#include <mlsdeform/cancel.hpp>
#include <mlsdeform/dispatch.hpp>
#include <mlsdeform/frames.hpp>
#include <mlsdeform/rotation.hpp>
#include <mlsdeform/types.hpp>

#include <cstddef>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

namespace mlsdeform {

/// How a segment handle's weight varies along it (Sec. 6.2).
enum class SegmentWeight {
  /// The paper's simplification: constant d^-u (d = distance from the vertex to the segment), so
  /// W = d^-u [[1/3, 1/6], [1/6, 1/3]] and the centroids use the segment midpoints.
  paper_constant,
  /// The exact integral of |p(t) - v|^-u along the segment (adaptive Gauss-Legendre quadrature; beyond
  /// u = 64 in a variable that makes its cost independent of u: docs/api.md, "Segments").
  exact_integral,
};

/// Where the per-vertex, per-handle weights come from each frame.
enum class WeightStorage {
  /// chosen by measurement (core/src/deformer/precompute.cpp, choose_storage): where precomputed_weights is
  /// supported (rigid and similarity with point handles and MLS centroids), `precomputed` while its table stays
  /// in the cache (16 MiB, and within `precompute_budget_bytes`; not when the frames run on AVX-512, where the
  /// weights alone are as fast in the cache too), then `precomputed_weights` while its weights fit the budget,
  /// then `on_the_fly`; otherwise `precomputed` while the table fits the budget, and beyond it a refusal
  /// (std::invalid_argument naming the size and the budget). Never more than the budget.
  automatic,
  /// stream the precomputed omega_i and A_i = w_i phat_i (16 bytes per vertex and handle in float, 32 in
  /// double; affine: 4 / 8 bytes, 16 / 32 with Options::affine_frames)
  precomputed,
  /// recompute the weights from the distances every frame: 24 bytes per vertex in float (rest position,
  /// nearest-handle distance, snap flag) and no per-handle table. Rigid and similarity with point handles
  /// only (std::invalid_argument otherwise). Computed in T relative to the vertex: agrees with the
  /// precomputed path (which works in double) to a few eps(T) kappa in the rotation.
  on_the_fly,
  /// stream only the precomputed normalised weights w_i / S (4 bytes per vertex and handle in float, 8 in
  /// double) and, per vertex, its rest position, p*, sum_i A_i and the snap flag (40 bytes in float; 44 with
  /// similarity's D); each frame forms phat_i and the sums from the handles' rest positions, as on_the_fly does
  /// after its weights (and with its frames: the identity at a vertex on a handle). A quarter of `precomputed`'s
  /// bytes per handle, for a few more flops. Rigid and similarity with point handles and MLS centroids only
  /// (std::invalid_argument otherwise). Weights and p* in double, rounded once: agrees with the precomputed path
  /// to a few eps(T) kappa in the rotation.
  precomputed_weights,
};

/// How the translation part of each vertex's transform is found (q*, the image of the rest centroid p*).
enum class Centroids {
  /// The paper's eq. (2): q* = the weighted centroid of the targets, a convex combination of them.
  mls,
  /// The paper's Sec. 7-8 (Fig. 8): q* = g(p*), g the radial-basis interpolant of the handles (biharmonic
  /// phi(r) = r with a linear polynomial, g(p_i) = q_i): smoother under large displacements. Precomputed weights
  /// only (no WeightStorage::on_the_fly); the per-frame cost is that of `mls` (docs/api.md).
  rbf,
};

/// Point handles (k x 3) and segment handles given by their end points (s x 3 each). Either kind may be
/// empty, not both.
template <class T>
struct Handles {
  Points<T> points;
  Points<T> segment_a, segment_b;

  Eigen::Index point_count() const { return points.rows(); }
  Eigen::Index segment_count() const { return segment_a.rows(); }
};

struct Options {
  Transform transform = Transform::rigid;
  /// The paper's u in w_i = |p_i - v|^-u (Fig. 5 uses 2, 3 and 4); any finite real >= 1.
  double weight_exponent = 2.0;
  RotationMethod method = RotationMethod::axis_angle;
  SegmentWeight segment_weight = SegmentWeight::paper_constant;
  /// The instruction set of deform()'s MLS pass: unset (default), the active one (active_isa(), chosen per
  /// frame); Isa::scalar, the scalar reference, one vertex at a time; another, that one for this session only
  /// (std::invalid_argument if this CPU cannot run it). Rotation methods without a SIMD kernel (horn_matrix,
  /// kanatani, svd) run the scalar reference whatever is set.
  std::optional<Isa> isa;
  /// Worker threads for deform(); 0 means all cores.
  int threads = 0;
  WeightStorage weight_storage = WeightStorage::automatic;
  /// WeightStorage::automatic allocates a weight table of at most this many bytes (see WeightStorage). 64 MiB
  /// holds the weights of 10^6 vertices and 10 handles in float (40 MB), which stream faster than on-the-fly
  /// weights (core/src/deformer/precompute.cpp, choose_storage).
  std::size_t precompute_budget_bytes = std::size_t(64) << 20;
  /// Surface-ARAP iterations after MLS (arap.hpp), for sessions built with the mesh's triangles; 0 (default)
  /// is the paper's MLS. Each point handle constrains its nearest rest vertex, each segment handle the
  /// nearest vertices of its two ends, held where MLS put them; the iterations then make the one-rings
  /// locally rigid (docs/api.md, "ARAP refinement"). Any count: each iteration costs the same, and a
  /// CancelCheck given to deform() stops a frame between iterations (cancel.hpp).
  int arap_iterations = 0;
  /// How the ARAP iterations are driven (ArapAcceleration, arap.hpp): anderson reaches a lower energy in the
  /// same iterations (docs/api.md, "ARAP refinement").
  ArapAcceleration arap_acceleration = ArapAcceleration::none;
  /// For interactive sessions (targets moving a little per frame): start the ARAP iterations from the
  /// previous deform()'s result instead of from MLS's, unless a handle's constrained vertex moved by more
  /// than arap_warm_start_limit times the rest model's bounding-box diagonal since that frame (a jump: then
  /// MLS, as on the first frame). A frame's result then depends on the frames before it (docs/api.md, "ARAP
  /// refinement").
  bool arap_warm_start = false;
  double arap_warm_start_limit = 0.05;
  Centroids centroids = Centroids::mls;
  /// A region of interest: the vertices (0-based, any order, each once) that may move; every other vertex
  /// keeps its rest position bitwise, and only the region's vertices cost time per frame. Empty (default):
  /// the whole model. The outside vertices next to the region (sharing a triangle with a region vertex, or
  /// without triangles among the 8 nearest vertices of one) are held as fixed point handles at their rest
  /// positions, so that the result is continuous across the region's border (with precomputed weights they
  /// cost four table columns however many they are: docs/api.md); targets() and the handle counts stay the
  /// caller's. Not with arap_iterations > 0 (std::invalid_argument). docs/api.md, "Region of
  /// interest".
  std::vector<Eigen::Index> region;
  /// Transform::affine only: also precompute the affine fit's matrix B_j = G^-1 A_j beside alpha (3 values per
  /// vertex and pseudo-handle: the table becomes 4 times alpha's, counted in memory_bytes() and in
  /// precompute_budget_bytes), so that deform() can write FramesOut::linear. Off (default), an affine session
  /// keeps alpha alone and refuses FramesOut::linear (std::invalid_argument naming this option); positions are
  /// bitwise the same either way. Ignored by rigid and similarity, whose table always holds their frames.
  bool affine_frames = false;
};

/// A deformation session (Sec. 5): the constructor precomputes everything that depends only on the rest
/// pose; deform() does only what depends on the moved handles. Thread-compatible: deform() is const and
/// may run concurrently on distinct outputs. A moved-from session holds nothing: every member function but
/// destruction and assignment throws std::logic_error.
template <class T>
class Deformer {
 public:
  /// Throws std::invalid_argument (message naming the problem) on: no handles, non-finite coordinates,
  /// mismatched segment end-point counts, weight_exponent < 1 or non-finite, a zero-length segment, or an
  /// affine transform whose handles do not span 3D (fewer than four non-coplanar points), a region index out
  /// of range or repeated. `cancel` (cancel.hpp) may stop the precomputation: Cancelled is thrown.
  Deformer(const Points<T>& rest_vertices, const Handles<T>& rest_handles, const Options& options = {},
           const CancelCheck& cancel = {});
  /// The same over a triangle mesh, so that options.arap_iterations > 0 can refine MLS's result (without
  /// triangles that option throws std::invalid_argument). Also throws on a triangle index out of range.
  Deformer(const Points<T>& rest_vertices, const Triangles& triangles, const Handles<T>& rest_handles,
           const Options& options = {}, const CancelCheck& cancel = {});
  ~Deformer();
  Deformer(Deformer&&) noexcept;
  Deformer& operator=(Deformer&&) noexcept;
  Deformer(const Deformer&) = delete;
  Deformer& operator=(const Deformer&) = delete;

  /// Deform with the given moved handles (same counts as the rest handles; point handles that share a rest
  /// position must share their target too, since a vertex there cannot follow both). Writes `out` (resized
  /// only if its size is wrong); allocates nothing once `out` has its size. On invalid input throws
  /// std::invalid_argument and leaves `out` untouched. A deformed position that T cannot hold (handles whose
  /// targets map a vertex beyond T's range) is never returned: std::invalid_argument names the vertex, and
  /// `out` is then unspecified (untouched with arap_iterations > 0). With arap_iterations > 0 or a region,
  /// concurrent calls on one session take turns (the refinement's or the region's scratch belongs to the
  /// session). `cancel` (cancel.hpp) is checked before every 64 blocks (1,024 vertices) of the MLS pass and
  /// before each ARAP iteration, and throws Cancelled. With arap_iterations > 0 `out` is then untouched;
  /// without, the MLS pass writes `out` directly (no scratch, no allocation), so a pass stopped part-way leaves
  /// `out` partly written: give a scratch output where that matters (the Python binding does).
  void deform(const Handles<T>& moved_handles, Points<T>& out, const CancelCheck& cancel = {}) const;
  /// The same, writing interleaved xyz (e.g. a mapped vertex buffer of vertex_count() * 3 values).
  void deform(const Handles<T>& moved_handles, InterleavedView<T> out, const CancelCheck& cancel = {}) const;
  /// The same, and each vertex's frame into the wanted outputs of `frames` (frames.hpp), computed in the
  /// lanes that compute the positions: the positions are bitwise those of deform() without frames. Throws
  /// std::invalid_argument, writing nothing, on an output of the wrong size or one the transform lacks
  /// (affine: all but linear, and linear too without Options::affine_frames). Allocates nothing; cancellation and
  /// errors leave the frames as they leave `out`.
  void deform(const Handles<T>& moved_handles, Points<T>& out, const FramesOut<T>& frames,
              const CancelCheck& cancel = {}) const;
  void deform(const Handles<T>& moved_handles, InterleavedView<T> out, const FramesOut<T>& frames,
              const CancelCheck& cancel = {}) const;

  /// Stateful targets for interactive use: the session keeps the current moved handles (initially the rest
  /// handles); move some of them and deform() with no handle argument.
  void set_point_target(Eigen::Index i, const Vector3<T>& target);
  void set_segment_target(Eigen::Index i, const Vector3<T>& a, const Vector3<T>& b);
  /// Moves a group of handles as one rigid body: the targets of the point handles `point_indices` and the
  /// segment handles `segment_indices` (an index may repeat) become their REST positions under
  /// x -> R (x - pivot) + pivot + t; other targets are kept. Computed in T, coordinate i of the image as
  /// (((R_i0 d_0 + R_i1 d_1) + R_i2 d_2) + pivot_i) + t_i with d = x - pivot, on the coordinates scaled by an
  /// exact power of two 2^-g (g the exponent of the largest coordinate of t, pivot and the group's rest
  /// positions) and scaled back: so the images of a scene scaled by 2^k are the images times 2^k, rounded
  /// once, and in the normal range (no subnormal intermediate) a group of one handle sets bitwise what
  /// set_point_target / set_segment_target would set from that expression in the caller's units. Throws, changing
  /// nothing: std::out_of_range for an index out of range; std::invalid_argument if R has a non-finite entry,
  /// is not orthonormal to 64 eps(T) (largest entry of |R^T R - I|, computed in T; fit_rotation's own bound)
  /// or is a reflection, if t or pivot is not finite, or if an image has a non-finite coordinate or one
  /// beyond max(T)/64.
  void transform_handles(std::span<const Eigen::Index> point_indices, std::span<const Eigen::Index> segment_indices,
                         const Matrix3<T>& R, const Vector3<T>& t, const Vector3<T>& pivot);
  const Handles<T>& targets() const;
  void deform(Points<T>& out, const CancelCheck& cancel = {}) const;
  /// The same, writing interleaved xyz (vertex_count() rows; std::invalid_argument otherwise).
  void deform(InterleavedView<T> out, const CancelCheck& cancel = {}) const;
  /// The stateful targets' frame with frames (as above).
  void deform(Points<T>& out, const FramesOut<T>& frames, const CancelCheck& cancel = {}) const;
  void deform(InterleavedView<T> out, const FramesOut<T>& frames, const CancelCheck& cancel = {}) const;

  /// A new rest pose (vertices and/or handles): redoes the precomputation; targets reset to the rest handles.
  /// On any exception (Cancelled included) the session is unchanged.
  void reset_rest_pose(const Points<T>& rest_vertices, const Handles<T>& rest_handles, const CancelCheck& cancel = {});

  Eigen::Index vertex_count() const;
  const Options& options() const;
  /// Bytes held by the precomputation (weights and per-vertex data).
  std::size_t memory_bytes() const;
  /// Whether the weights are streamed from a precomputed table (true) or recomputed per frame (false).
  bool uses_precomputed_weights() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  /// *impl_, or std::logic_error for a moved-from session.
  Impl& impl();
  const Impl& impl() const;
};

extern template class Deformer<float>;
extern template class Deformer<double>;

}  // namespace mlsdeform
