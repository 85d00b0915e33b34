#include "core/src/deformer/precompute.hpp"

#include "core/src/deformer/fold.hpp"
#include "core/src/deformer/snap.hpp"
#include "core/src/deformer/validation.hpp"
#include "core/src/deformer/weights.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

namespace mlsdeform::detail {

namespace {

/// WeightStorage (deformer.hpp): on the fly is implemented for rigid and similarity with point handles
/// only. `automatic` picks it (and refuses settings without it) when the precomputed table (16 bytes per
/// vertex and handle in float, 32 in double; affine 4 and 8 for alpha, as much as rigid with Options::affine_frames'
/// B_j, data.hpp) would exceed
/// precompute_budget_bytes (default 32 MiB, about a last-level cache), so that it never allocates more than the budget:
/// beyond the cache the table streams from memory every frame, and recomputing the weights (two passes of a few tens of
/// flops per handle) costs about as much as reading 16-32 bytes per handle (bench/bench_scaling.cpp measures both).
/// WeightStorage::precomputed_weights shares the on-the-fly session data (and adds its weights): true for it too.
template <class T>
bool use_on_the_fly(const Options& o, const RestHandles& rh, std::size_t padded, std::size_t columns) {
  const bool supported = o.transform != Transform::affine && rh.s == 0 && o.centroids == Centroids::mls;
  const char* unsupported = o.transform == Transform::affine ? "the affine transform"
                            : rh.s != 0                      ? "segment handles"
                                                             : "Centroids::rbf";
  if ((o.weight_storage == WeightStorage::on_the_fly || o.weight_storage == WeightStorage::precomputed_weights) &&
      !supported)
    throw std::invalid_argument(std::string("Deformer: WeightStorage::") +
                                (o.weight_storage == WeightStorage::on_the_fly ? "on_the_fly" : "precomputed_weights") +
                                " supports rigid and similarity transforms with point handles and MLS centroids "
                                "only (got " +
                                unsupported + "); use precomputed or automatic");
  if (o.weight_storage != WeightStorage::automatic)
    return o.weight_storage == WeightStorage::on_the_fly || o.weight_storage == WeightStorage::precomputed_weights;
  const double components = o.transform != Transform::affine || o.affine_frames ? 4 : 1;  // affine: alpha (+ B_j)
  const double table = double(padded) * double(columns) * components * sizeof(T);
  if (!(table > double(o.precompute_budget_bytes))) return false;
  if (supported) return true;
  char msg[512];
  std::snprintf(
      msg, sizeof msg,
      "Deformer: the weight table would take %.1f MiB (%zu vertices x %zu pseudo-handles), over "
      "precompute_budget_bytes = %.1f MiB, and on-the-fly weights support only rigid and similarity "
      "transforms with point handles and MLS centroids (got %s); raise Options::precompute_budget_bytes (CLI: "
      "--weight-budget MiB) or set WeightStorage::precomputed to allow it",
      table / 1048576.0, padded, columns, double(o.precompute_budget_bytes) / 1048576.0, unsupported);
  throw std::invalid_argument(msg);
}

/// A segment whose end b would snap onto its end a (snap.hpp: |b - a| <= 64 eps(T) times the distance from a
/// to the nearest other handle; alone, |b - a| = 0) is a point: refused, rather than divided by its length.
/// So is one whose squared length underflows (below 1e-154 of the scene), which segment_geometry divides by.
template <class T>
void check_segment_lengths(const RestHandles& rh) {
  const std::size_t k = rh.k;
  for (std::size_t q = 0; q < rh.s; ++q) {
    const Eigen::Vector3d& a = rh.P[k + 2 * q];
    const double L = (rh.P[k + 2 * q + 1] - a).norm();
    double other = std::numeric_limits<double>::infinity();
    for (std::size_t p = 0; p < k; ++p) other = std::min(other, (rh.P[p] - a).norm());
    for (std::size_t r = 0; r < rh.s; ++r)
      if (r != q && (rh.P[k + 2 * r + 1] - rh.P[k + 2 * r]).squaredNorm() >= std::numeric_limits<double>::min())
        other = std::min(other, segment_geometry(a, rh.P[k + 2 * r], rh.P[k + 2 * r + 1]).d);
    if (snaps<T>(L, other) || !(L * L >= std::numeric_limits<double>::min()))
      throw std::invalid_argument("Deformer: segment handle " + std::to_string(q) +
                                  " has zero length (|b - a| <= 64 eps times its distance to the nearest other "
                                  "handle); use a point handle");
  }
}

}  // namespace

template <class T>
DeformerData<T> precompute(const Points<T>& vertices, const Handles<T>& handles, const Options& o,
                           tbb::task_arena* arena, const CancelCheck& cancel, const FixedHandles<T>& fixed) {
  check_options(o);
  check_points(vertices, "rest vertices", "", std::numeric_limits<T>::max());
  check_handles(handles, "rest handles", std::numeric_limits<T>::max());
  if (handles.points.rows() + handles.segment_a.rows() == 0)
    throw std::invalid_argument("Deformer: no handles (need at least one point or segment handle)");
  const LocalFrame scene = make_local_frame(vertices, handles);
  const RestHandles rh = make_rest_handles(handles, scene);
  check_segment_lengths<T>(rh);
  if (o.transform == Transform::affine) check_affine_rank<T>(rh.P);

  DeformerData<T> data;
  data.transform = o.transform;
  data.n = static_cast<std::size_t>(vertices.rows());
  data.blocks = (data.n + kLanes - 1) / kLanes;
  data.points = rh.k;
  data.segments = rh.s;
  data.scale = std::ldexp(1.0, scene.e);
  data.target_limit = std::ldexp(coordinate_limit<T>(), std::min(scene.e, 0));
  const std::size_t np = data.padded();
  // Fixed handles cost a table column each unless folded (fold.hpp), which only the table can do.
  const std::size_t fold = fixed.count > kFoldedHandles ? fixed.count : 0;
  if (use_on_the_fly<T>(o, rh, np, rh.P.size() - fold + (fold ? kFoldedHandles : 0))) {
    precompute_on_the_fly(data, vertices, scene, rh, o, arena, cancel);  // and precomputed_weights' weights
    return data;
  }
  data.folded = fold;
  if (fold) data.points = rh.k - fold + kFoldedHandles;
  precompute_table(data, vertices, scene, rh, o, arena, cancel, handles, fixed);
  return data;
}

template DeformerData<float> precompute<float>(const Points<float>&, const Handles<float>&, const Options&,
                                               tbb::task_arena*, const CancelCheck&, const FixedHandles<float>&);
template DeformerData<double> precompute<double>(const Points<double>&, const Handles<double>&, const Options&,
                                                 tbb::task_arena*, const CancelCheck&, const FixedHandles<double>&);

}  // namespace mlsdeform::detail
