// The Deformer session (deformer.hpp): construction (precompute.hpp), the per-frame driver that hands a
// DeformFrame (kernels/contract.hpp) to the kernel table over blocks of kLanes vertices, and the ARAP
// refinement after it (arap_stage.hpp); the moved handles are targets.hpp's, the output's check output_check.hpp's.
#include "core/src/deformer/arap_stage.hpp"
#include "core/src/deformer/output_check.hpp"
#include "core/src/deformer/precompute.hpp"
#include "core/src/deformer/region.hpp"
#include "core/src/deformer/targets.hpp"
#include "core/src/deformer/validation.hpp"
#include "core/src/dispatch.hpp"
#include "core/src/frames.hpp"
#include "core/src/parallel.hpp"

#include <mlsdeform/deformer.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>

namespace mlsdeform {

template <class T>
struct Deformer<T>::Impl {
  Options options;
  Handles<T> rest, targets;
  detail::CoincidentPairs coincident;  ///< point handles at one rest position
  detail::DeformerData<T> data;
  std::unique_ptr<tbb::task_arena> arena;
  Triangles triangles;                         ///< the rest mesh, when given
  std::unique_ptr<detail::ArapStage<T>> arap;  ///< when options.arap_iterations > 0
  /// When options.region is not empty: `data` then covers the region's vertices only, and its pseudo-handles
  /// are the caller's followed by the ring's fixed points.
  std::unique_ptr<detail::RegionStage<T>> region;

  /// The session data and the region stage for a rest pose (nothing of *this is changed).
  static std::pair<detail::DeformerData<T>, std::unique_ptr<detail::RegionStage<T>>> build(
      const Points<T>& rest_vertices, const Triangles& triangles, const Handles<T>& rest_handles, const Options& o,
      tbb::task_arena* arena, const CancelCheck& cancel) {
    if (o.region.empty()) {
      detail::DeformerData<T> data = detail::precompute(rest_vertices, rest_handles, o, arena, cancel);
      detail::check_triangles(triangles, rest_vertices.rows());
      return {std::move(data), nullptr};
    }
    detail::check_options(o);
    detail::check_triangles(triangles, rest_vertices.rows());
    auto region = detail::RegionStage<T>::make(rest_vertices, triangles, rest_handles, o, cancel);
    detail::DeformerData<T> data =
        detail::precompute(region->rest_inside, region->rest_handles, o, arena, cancel, region->fixed());
    region->set_folded(data.folded > 0);
    return {std::move(data), std::move(region)};
  }

  /// The whole model's vertex count.
  std::size_t vertices() const { return region ? std::size_t(region->n) : data.n; }

  /// One frame into `out` (vertex v, coordinate c at out[c * cstride + v * vstride]) and `frames`: over the
  /// whole model, or over the region, scattered, with the other vertices at rest (frames: the identity). The
  /// region's frames go to the first rows of the caller's outputs and are then moved to their vertices' rows
  /// in place (frames.hpp): no scratch.
  /// Returns run's finiteness check, as a vertex of the model.
  std::size_t frame(const Handles<T>& moved, T* out, std::size_t vstride, std::size_t cstride,
                    const FramesOut<T>& frames, const CancelCheck& cancel) const {
    if (!region) return run(moved, out, vstride, cstride, false, frames, cancel);
    const std::lock_guard<std::mutex> lock(region->mutex);
    region->set_targets(moved);
    const std::size_t bad = run(region->moved, region->compact.data(), 1, data.n, false, frames, cancel);
    region->scatter(out, vstride, cstride);
    detail::scatter_frames(frames, region->inside);
    // The vertices outside the region are at rest (finite); inside is ascending, so this is the smallest.
    return bad == detail::kAllFinite ? bad : std::size_t(region->inside[bad]);
  }

  /// One frame for validated `moved` into `out` (vertices() rows; `interleaved` xyz, or by coordinate), with
  /// the ARAP refinement when the session has one, and the check that every coordinate is finite.
  /// The wanted `frames` (checked by the caller) likewise: MLS's, or the refinement's rotations.
  void deform(const Handles<T>& moved, T* out, bool interleaved, const FramesOut<T>& frames,
              const CancelCheck& cancel) const {
    const std::size_t n = vertices(), vstride = interleaved ? 3 : 1, cstride = interleaved ? 1 : n;
    if (!arap) {
      const std::size_t bad = frame(moved, out, vstride, cstride, frames, cancel);
      if (bad != detail::kAllFinite) throw detail::overflow_error<T>(bad);
      return;
    }
    const std::lock_guard<std::mutex> lock(arap->mutex);
    // MLS's result in the local frame, handed to the refinement as it is (no rounding to the caller's units in
    // between: the two stages together scale with the scene to the bit). out untouched on a throw.
    if (const std::size_t bad = run(moved, arap->mls.data(), 1, n, true, {}, cancel); bad != detail::kAllFinite)
      throw detail::overflow_error<T>(bad);
    arap->run(arap->mls, options.arap_iterations, std::ilogb(data.scale), cancel);
    if (frames.any()) detail::write_rotations(frames, arap->refiner, arap->rotations);
    for (std::size_t v = 0; v < n; ++v)
      for (std::size_t c = 0; c < 3; ++c) out[c * cstride + v * vstride] = arap->mls(Eigen::Index(v), Eigen::Index(c));
  }

  /// The kernel table for this session's settings: options.isa's or else the active ISA's, and the scalar
  /// reference's for a rotation method without a SIMD kernel (kanatani, horn_matrix, svd).
  const kernels::KernelTable& table() const {
    const bool in_lanes = data.transform == Transform::affine || options.method == RotationMethod::axis_angle ||
                          options.method == RotationMethod::horn_quaternion;
    return !in_lanes     ? kernels::kernel_table_scalar()
           : options.isa ? detail::kernels_for(*options.isa)
                         : detail::active_kernels();
  }
  /// Its deformation kernel.
  kernels::DeformBlocksFn<T> kernel() const {
    const kernels::KernelTable& k = table();
    if constexpr (std::is_same_v<T, float>)
      return k.deform_f;
    else
      return k.deform_d;
  }

  /// One frame for validated `moved`: vertex v, coordinate c goes to out[c * cstride + v * vstride], in the
  /// caller's units or, with `local`, the local frame's (times 2^-e: data.hpp, Units). Nothing is allocated
  /// here; scratch lives on the stack of each block. `cancel` is checked before every kCancelBlocks blocks.
  /// Returns the smallest vertex with a non-finite coordinate, or kAllFinite. Each thread checks the blocks it
  /// has just written, while they are in its cache: a check over the whole output on the calling thread after
  /// the parallel part cost 2-thread frames up to 40% (it pulled the other core's lines over, and the next
  /// frame's writes then had to take them back).
  std::size_t run(const Handles<T>& moved, T* out, std::size_t vstride, std::size_t cstride, bool local = false,
                  const FramesOut<T>& frames = {}, const CancelCheck& cancel = {}) const {
    kernels::DeformFrame<T> fr{};
    fr.transform = data.transform;
    fr.method = options.method;
    fr.weights = data.weights_only ? kernels::WeightSource::weights
                 : data.on_the_fly ? kernels::WeightSource::on_the_fly
                                   : kernels::WeightSource::table;
    fr.n = data.n;
    fr.padded = data.padded();
    fr.table = data.table.empty() ? nullptr : data.table.data();
    fr.vhat = data.vhat.empty() ? nullptr : data.vhat.data();
    fr.D = data.D.empty() ? nullptr : data.D.data();
    fr.linear_table = data.linear_table.empty() ? nullptr : data.linear_table.data();
    if (data.on_the_fly) {
      fr.v_local = data.v_local.data();
      fr.dref2 = data.dref2.data();
      fr.snap = data.snap.data();
      fr.p_local = data.p_local.data();
      fr.half_u = data.half_u;
      fr.wn = data.weights.empty() ? nullptr : data.weights.data();
      fr.p_star_local = data.p_star_local.empty() ? nullptr : data.p_star_local.data();
      fr.sum_a = data.sum_a.empty() ? nullptr : data.sum_a.data();
    }
    fr.local_scale = T(1 / data.scale);  // 2^-e and 2^e: both numbers of T (local_frame.hpp)
    fr.world_scale = local ? T(1) : T(data.scale);
    fr.points = moved.points.data();
    fr.k = static_cast<std::size_t>(moved.points.rows());
    fr.seg_a = moved.segment_a.data();
    fr.seg_b = moved.segment_b.data();
    fr.s = static_cast<std::size_t>(moved.segment_a.rows());
    const Vector3<T> c = detail::local_target_centre(moved, fr.local_scale, data.target_limit);
    for (int i = 0; i < 3; ++i) fr.centre[i] = c[i];
    // The targets in the local frame, once per frame rather than in every batch (kernels/contract.hpp):
    // 6 scalar operations and 6 broadcasts per handle and batch otherwise, beside the 24 vector ones of the sums.
    alignas(64) T frame_targets[6 * kernels::kCachedTargets];
    if (fr.k + 2 * fr.s <= kernels::kCachedTargets) {
      kernels::fill_targets(fr, frame_targets);
      fr.targets = frame_targets;
    }
    fr.out = out;
    fr.out_vertex_stride = vstride;
    fr.out_coord_stride = cstride;
    const auto wanted = [](std::span<T> s) { return s.empty() ? nullptr : s.data(); };
    fr.quaternions = wanted(frames.quaternions);
    fr.rotations = wanted(frames.rotations);
    fr.scales = wanted(frames.scales);
    fr.linear = wanted(frames.linear);
    const kernels::DeformBlocksFn<T> deform_blocks = kernel();
    const kernels::KernelTable& k = table();
    std::atomic<std::size_t> first_bad{detail::kAllFinite};
    const auto blocks = [&](std::size_t b0, std::size_t b1) {
      deform_blocks(fr, b0, b1);
      const std::size_t v0 = b0 * kernels::kLanes, v1 = std::min(data.n, b1 * kernels::kLanes);
      const std::size_t bad = detail::first_non_finite(out, v0, v1, vstride, cstride, k);
      for (std::size_t seen = first_bad.load(); bad < seen && !first_bad.compare_exchange_weak(seen, bad);) {
      }
    };
    // The same even cut on every frame (Split::fixed): each thread finds its blocks' data in its own cache.
    if (!cancel) {
      detail::parallel_ranges(data.blocks, options.threads, arena.get(), blocks, detail::Split::fixed);
      return near_handles(fr, first_bad.load());
    }
    // 64 blocks (1,024 vertices) between checks: with on-the-fly weights and thousands of handles that is a
    // few milliseconds, and each block's result does not depend on the cut (bitwise as without a check).
    constexpr std::size_t kCancelBlocks = 64;
    detail::parallel_ranges(data.blocks, options.threads, arena.get(), [&](std::size_t b0, std::size_t b1) {
      for (std::size_t b = b0; b < b1; b += kCancelBlocks) {
        detail::throw_if_cancelled(cancel);
        blocks(b, std::min(b1, b + kCancelBlocks));
      }
    });
    return near_handles(fr, first_bad.load());
  }

  /// After the blocks: the vertices on handles (their frames, when wanted) and beside a dominant segment (their
  /// positions, and frames), apart from the kernels (near_handles.hpp). Returns the smaller of `bad` and the
  /// first of those vertices whose result is not finite.
  std::size_t near_handles(const kernels::DeformFrame<T>& fr, std::size_t bad) const {
    const bool frames = fr.quaternions || fr.rotations || fr.scales || fr.linear;
    if (frames ? data.near.records.empty() : data.near.positions.empty()) return bad;
    return std::min(bad, detail::apply_near_handles(data.near, fr, options.method, options.threads, arena.get()));
  }
};

template <class T>
Deformer<T>::Deformer(const Points<T>& rest_vertices, const Handles<T>& rest_handles, const Options& options,
                      const CancelCheck& cancel)
    : Deformer(rest_vertices, Triangles(), rest_handles, options, cancel) {}

template <class T>
Deformer<T>::Deformer(const Points<T>& rest_vertices, const Triangles& triangles, const Handles<T>& rest_handles,
                      const Options& options, const CancelCheck& cancel)
    : impl_(std::make_unique<Impl>()) {
  detail::check_options(options);
  impl_->options = options;
  impl_->arena = detail::make_arena(options.threads);
  std::tie(impl_->data, impl_->region) =
      Impl::build(rest_vertices, triangles, rest_handles, options, impl_->arena.get(), cancel);
  if (options.arap_iterations > 0)
    impl_->arap = detail::ArapStage<T>::make(rest_vertices, triangles, rest_handles, options);
  impl_->triangles = triangles;
  impl_->rest = rest_handles;
  impl_->targets = rest_handles;
  impl_->coincident = detail::coincident_points(rest_handles.points);
}

template <class T>
typename Deformer<T>::Impl& Deformer<T>::impl() {
  if (!impl_) throw std::logic_error("Deformer: this session was moved from; assign a new one before use");
  return *impl_;
}

template <class T>
const typename Deformer<T>::Impl& Deformer<T>::impl() const {
  if (!impl_) throw std::logic_error("Deformer: this session was moved from; assign a new one before use");
  return *impl_;
}

template <class T>
Deformer<T>::~Deformer() = default;
template <class T>
Deformer<T>::Deformer(Deformer&&) noexcept = default;
template <class T>
Deformer<T>& Deformer<T>::operator=(Deformer&&) noexcept = default;

template <class T>
void Deformer<T>::deform(const Handles<T>& moved_handles, Points<T>& out, const CancelCheck& cancel) const {
  deform(moved_handles, out, FramesOut<T>{}, cancel);
}

template <class T>
void Deformer<T>::deform(const Handles<T>& moved_handles, InterleavedView<T> out, const CancelCheck& cancel) const {
  deform(moved_handles, out, FramesOut<T>{}, cancel);
}

template <class T>
void Deformer<T>::deform(const Handles<T>& moved_handles, Points<T>& out, const FramesOut<T>& frames,
                         const CancelCheck& cancel) const {
  detail::check_moved(moved_handles, impl().rest);
  detail::check_coincident(moved_handles, impl().coincident);
  detail::check_frames(frames, impl().vertices(), impl().data.transform, impl().options.affine_frames);
  const auto n = static_cast<Eigen::Index>(impl().vertices());
  if (out.rows() != n) out.resize(n, 3);
  impl().deform(moved_handles, out.data(), false, frames, cancel);
}

template <class T>
void Deformer<T>::deform(const Handles<T>& moved_handles, InterleavedView<T> out, const FramesOut<T>& frames,
                         const CancelCheck& cancel) const {
  detail::check_moved(moved_handles, impl().rest);
  detail::check_coincident(moved_handles, impl().coincident);
  if (out.rows() != static_cast<Eigen::Index>(impl().vertices()))
    throw std::invalid_argument("Deformer: the interleaved output has " + std::to_string(out.rows()) +
                                " rows but the model has " + std::to_string(impl().vertices()) + " vertices");
  detail::check_frames(frames, impl().vertices(), impl().data.transform, impl().options.affine_frames);
  impl().deform(moved_handles, out.data(), true, frames, cancel);
}

template <class T>
void Deformer<T>::set_point_target(Eigen::Index i, const Vector3<T>& target) {
  detail::set_point_target(impl().targets, i, target);
}

template <class T>
void Deformer<T>::set_segment_target(Eigen::Index i, const Vector3<T>& a, const Vector3<T>& b) {
  detail::set_segment_target(impl().targets, i, a, b);
}

template <class T>
void Deformer<T>::transform_handles(std::span<const Eigen::Index> point_indices,
                                    std::span<const Eigen::Index> segment_indices, const Matrix3<T>& R,
                                    const Vector3<T>& t, const Vector3<T>& pivot) {
  detail::transform_targets(impl().targets, impl().rest, point_indices, segment_indices, R, t, pivot);
}

template <class T>
const Handles<T>& Deformer<T>::targets() const {
  return impl().targets;
}

template <class T>
void Deformer<T>::deform(Points<T>& out, const CancelCheck& cancel) const {
  deform(impl().targets, out, cancel);
}

template <class T>
void Deformer<T>::deform(InterleavedView<T> out, const CancelCheck& cancel) const {
  deform(impl().targets, out, cancel);
}

template <class T>
void Deformer<T>::deform(Points<T>& out, const FramesOut<T>& frames, const CancelCheck& cancel) const {
  deform(impl().targets, out, frames, cancel);
}

template <class T>
void Deformer<T>::deform(InterleavedView<T> out, const FramesOut<T>& frames, const CancelCheck& cancel) const {
  deform(impl().targets, out, frames, cancel);
}

template <class T>
void Deformer<T>::reset_rest_pose(const Points<T>& rest_vertices, const Handles<T>& rest_handles,
                                  const CancelCheck& cancel) {
  // Strong guarantee: build everything first, then commit with non-throwing moves.
  auto [data, region] =
      Impl::build(rest_vertices, impl().triangles, rest_handles, impl().options, impl().arena.get(), cancel);
  std::unique_ptr<detail::ArapStage<T>> arap;
  if (impl().options.arap_iterations > 0)
    arap = detail::ArapStage<T>::make(rest_vertices, impl().triangles, rest_handles, impl().options);
  Handles<T> rest = rest_handles, targets = rest_handles;
  auto coincident = detail::coincident_points(rest_handles.points);
  impl().data = std::move(data);
  impl().arap = std::move(arap);
  impl().region = std::move(region);
  impl().rest = std::move(rest);
  impl().targets = std::move(targets);
  impl().coincident = std::move(coincident);
}

template <class T>
Eigen::Index Deformer<T>::vertex_count() const {
  return static_cast<Eigen::Index>(impl().vertices());
}

template <class T>
const Options& Deformer<T>::options() const {
  return impl().options;
}

template <class T>
std::size_t Deformer<T>::memory_bytes() const {
  // Everything the session holds on the heap: the table and per-vertex arrays, and the rest and target
  // handles (3 coordinates each).
  const auto handle_values = [](const Handles<T>& h) {
    return static_cast<std::size_t>(h.points.size() + h.segment_a.size() + h.segment_b.size());
  };
  return impl().data.bytes() + (handle_values(impl().rest) + handle_values(impl().targets)) * sizeof(T) +
         (impl().arap ? impl().arap->refiner.memory_bytes() : 0) + (impl().region ? impl().region->bytes() : 0);
}

template <class T>
bool Deformer<T>::uses_precomputed_weights() const {
  return !impl().data.on_the_fly || impl().data.weights_only;
}

template class Deformer<float>;
template class Deformer<double>;

}  // namespace mlsdeform
