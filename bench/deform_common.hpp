// Shared by the deformation benchmarks (bench_table2, bench_scaling, bench_roofline): the check of a
// deformer's output against the test-support library's reference deformer (tests/support/mls_reference.hpp:
// sampled_reference, deform_tolerance) on all vertices or a sample, and the benchmark body. Scenes and meshes
// come from the same library (deform_cases.hpp, meshes.hpp).
#pragma once

#include "bench/common.hpp"
#include "bench/naive_mls.hpp"
#include "tests/support/deform_cases.hpp"
#include "tests/support/meshes.hpp"
#include "tests/support/mls_reference.hpp"

#include <mlsdeform/deformer.hpp>

#include <algorithm>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace bench {

// From the test-support library (tests/support): meshes, scenes, the reference deformer and its tolerance.
using PointsD = mlsdeform::testing::PointsD;
using DeformCase = mlsdeform::testing::DeformCase<double>;  ///< rest vertices, rest and moved point handles, a name
using mlsdeform::testing::check_rows;
using mlsdeform::testing::deform_tolerance;
using mlsdeform::testing::point_handles;
using mlsdeform::testing::SampledReference;

/// The reference on the rows of a scene as T sees it (inputs rounded to T first, so that the check measures
/// the computation, not the input rounding).
template <class T>
SampledReference scene_reference(const DeformCase& s, const std::vector<Eigen::Index>& rows) {
  return mlsdeform::testing::sampled_reference(s.vertices.cast<T>().template cast<double>(),
                                               s.rest.points.cast<T>().template cast<double>(),
                                               s.moved.points.cast<T>().template cast<double>(), rows);
}

/// Empty when every checked vertex of `out` is within deform_tolerance of the reference; else a message.
/// `worst` gets the largest error/tolerance ratio and `max_dev` the largest deviation over the diameter.
template <class T>
std::string check_deformation(const mlsdeform::Points<T>& out, const SampledReference& ref,
                              const std::vector<Eigen::Index>& rows, double& worst, double& max_dev) {
  constexpr double eps = std::numeric_limits<T>::epsilon();
  worst = 0;
  max_dev = 0;
  std::size_t bad = 0, first = rows.size();
  double first_err = 0, first_tol = 0;
  for (std::size_t s = 0; s < rows.size(); ++s) {
    const double err = (out.row(rows[s]).template cast<double>() - ref.out.row(static_cast<Eigen::Index>(s))).norm();
    const double tol = deform_tolerance(ref, s, eps);
    max_dev = std::max(max_dev, err / ref.diameter);
    worst = std::max(worst, err / tol);
    if (!(err <= tol) && bad++ == 0) first = s, first_err = err, first_tol = tol;
  }
  if (bad == 0) return {};
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "%zu of %zu vertices off the double reference; first: vertex %lld, |error| %.3g > %.3g "
                "(kappa %.3g)",
                bad, rows.size(), static_cast<long long>(rows[first]), first_err, first_tol, ref.kappa[first]);
  return buf;
}

/// Deformer options of a variant.
inline mlsdeform::Options deformer_options(std::optional<mlsdeform::Isa> isa, int threads,
                                           mlsdeform::WeightStorage storage = mlsdeform::WeightStorage::automatic) {
  mlsdeform::Options o;
  o.isa = isa;
  o.threads = threads;
  o.weight_storage = storage;
  return o;
}

/// Times frames, one call of `frame` (which deforms into `out`) per iteration. Counters: items_per_second (one
/// item = one frame), fps and ms_per_frame.
template <class T, class Frame>
void time_frames(benchmark::State& state, const mlsdeform::Points<T>& out, const Frame& frame) {
  for (auto _ : state) {
    frame();
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["fps"] = benchmark::Counter(1, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["ms_per_frame"] =
      benchmark::Counter(1e-3, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

/// Build a Deformer, check one frame against the reference, then time frames. Counters: fps (also as
/// items_per_second: one item = one frame), ms_per_frame, memory of the precomputation, whether the
/// weights are precomputed, and the check's worst error/tolerance and largest deviation.
template <class T>
void run_deformer(benchmark::State& state, const DeformCase& scene, const SampledReference& ref,
                  const std::vector<Eigen::Index>& rows, const mlsdeform::Options& options) {
  std::unique_ptr<mlsdeform::Deformer<T>> deformer;
  try {
    deformer = std::make_unique<mlsdeform::Deformer<T>>(scene.vertices.cast<T>(), point_handles<T>(scene.rest.points),
                                                        options);
  } catch (const std::exception& e) {
    state.SkipWithError((std::string("Deformer: ") + e.what()).c_str());
    return;
  }
  const mlsdeform::Handles<T> moved = point_handles<T>(scene.moved.points);
  mlsdeform::Points<T> out;
  deformer->deform(moved, out);
  double worst = 0, max_dev = 0;
  if (const std::string err = check_deformation<T>(out, ref, rows, worst, max_dev); !err.empty()) {
    state.SkipWithError(err.c_str());
    return;
  }
  time_frames<T>(state, out, [&] { deformer->deform(moved, out); });
  state.counters["memory_bytes"] = static_cast<double>(deformer->memory_bytes());
  state.counters["precomputed"] = deformer->uses_precomputed_weights() ? 1 : 0;
  state.counters["vertices"] = static_cast<double>(scene.vertices.rows());
  state.counters["handles"] = static_cast<double>(scene.rest.points.rows());
  state.counters["worst_err_over_tol"] = worst;
  state.counters["max_dev_over_diameter"] = max_dev;
}

}  // namespace bench
