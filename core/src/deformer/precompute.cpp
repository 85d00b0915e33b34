#include "core/src/deformer/precompute.hpp"

#include "core/src/deformer/fold.hpp"
#include "core/src/deformer/snap.hpp"
#include "core/src/deformer/validation.hpp"
#include "core/src/deformer/weights.hpp"

#include <mlsdeform/dispatch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

namespace mlsdeform::detail {

namespace {

/// What a session streams each frame (WeightStorage, deformer.hpp).
enum class Storage { table, on_the_fly, weights };

/// WeightStorage::automatic, where the weights alone are supported (rigid and similarity with point handles and MLS
/// centroids) and the frames run on AVX-512: the precomputed weights (4 bytes per vertex and handle in float, 8
/// in double) while they fit precompute_budget_bytes, then the weights on the fly. Elsewhere where they are
/// supported: the precomputed table (16 bytes per vertex and handle in float, 32 in double) while it stays in the
/// cache, kTableCacheBytes, then the weights alone while they fit the budget, then on the fly. Otherwise (affine:
/// 4 and 8 bytes for alpha, as much as rigid with Options::affine_frames' B_j, data.hpp; segments; RBF centroids)
/// the table while it fits the budget.
/// Measured on Zen 5 (random scenes, the best of back-to-back frames, us per frame on 1 thread / both cores,
/// 2026-11-28, with the fused sums and the b_j form of weights_only (deform_kernel.hpp); a scratch program over the
/// public API, bench_scaling times the storages side by side at its own sizes), table -> weights:
///   AVX-512, float:  1,058 x 322 (table 5.2 MiB) 60.5 / 35.9 -> 27.6 / 23.6;  1,089 x 132 28.0 / 16.8 -> 16.3 /
///     12.1;  2,811 x 4 12.5 / 8.2 -> 11.9 / 8.1;  5,103 x 6 24.4 / 14.9 -> 23.4 / 13.9;  14,050 x 5 66.5 / 35.1
///     -> 61.5 / 33.1;  6,146 x 256 (24 MiB) 489 / 152 -> 162 / 89;  10^5 x 10 582 / 284 -> 498 / 254
///   AVX-512, double (before the b_j form): the same scenes, the weights as fast or faster (2,811 x 4: 26.7 / 13.9
///     -> 25.8 / 13.9; 1,058 x 322: 139 / 84 -> 69 / 50)
///   AVX2, float: the table faster in the cache (1,058 x 322: 91.5 / 50.9 -> 101 / 70.5; 2,811 x 4: 29.0 / 14.9 ->
///     30.1 / 17.5), about even from memory (6,146 x 256, 24 MiB: 640 / 235 -> 622 / 323, and in an earlier run
///     718 / 332 -> 675 / 359); SSE4.2 likewise (no FMA: 1,058 x 322 197 / 102 -> 219 / 155, before the b_j form)
/// With 32 registers of 16 lanes and a fused product and sum, forming A_j = (w_j / S) phat_j from the weights costs
/// less than reading it from the table, even from L2; with 16 registers of 8 lanes (AVX2) it does not. The two
/// paths round differently (each path has its own bits). From memory the 4 bytes win on AVX-512 (before the fused
/// sums too: 6,146 x 256 table 476 / 216, weights 283 / 146, on the fly 605 / 311; 10,000 x 256 (41 MiB)
/// 1040 / 541, 455 / 233, 980 / 499; 10^6 x 10 (table 160 MiB, weights 40 MiB), both cores: 5.2, 4.05, 4.55 ms).
/// A region whose ring's fixed handles are folded into four (fold.hpp, `folded`) keeps the table while it fits
/// the budget, as settings without on-the-fly weights do: the weights and on the fly pay for every ring handle.
/// Those are on the fly beyond the budget; settings without on-the-fly weights are refused beyond it
/// (std::invalid_argument naming the size and the budget): automatic never allocates more than the budget.
inline constexpr double kTableCacheBytes = 16 << 20;

/// The storage for o.weight_storage; `columns` are the table's pseudo-handles, `folded` whether fixed handles
/// were folded into them (fold.hpp).
template <class T>
Storage choose_storage(const Options& o, const RestHandles& rh, std::size_t padded, std::size_t columns, bool folded) {
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
  switch (o.weight_storage) {
    case WeightStorage::precomputed:
      return Storage::table;
    case WeightStorage::on_the_fly:
      return Storage::on_the_fly;
    case WeightStorage::precomputed_weights:
      return Storage::weights;
    case WeightStorage::automatic:
      break;
  }
  const double budget = double(o.precompute_budget_bytes);
  const double components = o.transform != Transform::affine || o.affine_frames ? 4 : 1;  // affine: alpha (+ B_j)
  const double table = double(padded) * double(columns) * components * sizeof(T);
  if (supported && !folded) {
    const double weights = double(padded) * double(rh.k) * sizeof(T);
    // The frames' ISA: Options::isa, else the active one; a rotation method without lanes runs the scalar
    // reference (deformer.cpp, Impl::table).
    const bool in_lanes = o.method == RotationMethod::axis_angle || o.method == RotationMethod::horn_quaternion;
    const bool avx512 = in_lanes && o.isa.value_or(active_isa()) == Isa::avx512;
    if (!avx512 && table <= std::min(budget, kTableCacheBytes)) return Storage::table;
    return weights <= budget ? Storage::weights : Storage::on_the_fly;
  }
  if (table <= budget) return Storage::table;
  if (supported) return Storage::on_the_fly;
  char msg[512];
  std::snprintf(
      msg, sizeof msg,
      "Deformer: the weight table would take %.1f MiB (%zu vertices x %zu pseudo-handles), over "
      "precompute_budget_bytes = %.1f MiB, and on-the-fly weights support only rigid and similarity "
      "transforms with point handles and MLS centroids (got %s); raise Options::precompute_budget_bytes (CLI: "
      "--weight-budget MiB) or set WeightStorage::precomputed to allow it",
      table / 1048576.0, padded, columns, budget / 1048576.0, unsupported);
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
  const Storage storage = choose_storage<T>(o, rh, np, rh.P.size() - fold + (fold ? kFoldedHandles : 0), fold != 0);
  if (storage != Storage::table) {
    precompute_on_the_fly(data, vertices, scene, rh, o, storage == Storage::weights, arena, cancel);
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
