// Scaling laws of rigid MLS deformation (float, Options::isa unset), for the three weight storages
// (WeightStorage::precomputed: stream A_i = w_i phat_i, 16 bytes per vertex and handle; on_the_fly:
// recompute the weights from the distances every frame; precomputed_weights: stream w_i / S, 4 bytes per
// vertex and handle, and form A_i from the handles every frame):
//   scaling/vertices/<storage>/n:<n>       time per frame vs vertex count, 10 handles, all cores;
//                                          n = 10^3 .. 10^6 random points in a 4 x 1 x 1 box
//   scaling/vertices/<storage>/spot_loop3  the 737,986-vertex spot_loop3.ply.gz (Keenan Crane's "Spot",
//                                          remeshed by O. Stein, 3 Loop subdivisions; public domain)
//   scaling/handles/<storage>/k:<k>        time per frame vs handle count, k = 1 .. 1024, 10^4 vertices
//   scaling/vertices/automatic/n:1000000, scaling/handles/automatic/k:256
//                                          WeightStorage::automatic (the default) at the two sizes the
//                                          speed targets name
//   scaling/threads/<storage>/n:<n>/threads:<t>  1 and all threads, 10 handles
//   scaling/centroids/<mls|rbf>/n:<n>      Centroids::mls against Centroids::rbf (the paper's Sec. 7-8),
//                                          precomputed, 10 handles, all cores; rbf checked against
//                                          rbf_centroid_reference (tests/support/mls_reference.hpp)
// Counters: ms_per_frame, fps, memory_bytes (Deformer::memory_bytes(), the precomputation's footprint),
// ns_per_vertex_handle. Each benchmark first checks 2,000 evenly spread vertices (all when fewer) of one
// frame against the reference in double (tests/support/mls_reference.hpp).
#include "bench/deform_common.hpp"

#include <mlsdeform/deformer.hpp>
#include <mlsdeform/dispatch.hpp>

#include <map>
#include <memory>
#include <string>

namespace {

using bench::PointsD;
using T = float;
using mlsdeform::WeightStorage;

constexpr Eigen::Index kCheckedRows = 2000;

struct Prepared {
  bench::DeformCase scene;
  std::vector<Eigen::Index> rows;
  bench::SampledReference ref, rbf_ref;
};

/// Scenes by key, built on first use and kept (the largest holds 10^6 vertices: 24 MB in double).
const Prepared& prepared(const std::string& key, Eigen::Index n, Eigen::Index k) {
  static std::map<std::string, std::unique_ptr<Prepared>> cache;
  auto& slot = cache[key];
  if (!slot) {
    slot = std::make_unique<Prepared>();
    namespace testing = mlsdeform::testing;
    PointsD v = key == "spot_loop3" ? testing::read_ply_vertices(testing::mesh_dir() + "/spot_loop3.ply.gz")
                                    : testing::random_box(n, 7 + static_cast<std::uint64_t>(n));
    slot->scene = testing::twisted_mesh_case(key, std::move(v), k, 11 + static_cast<std::uint64_t>(k));
    slot->rows = bench::check_rows(slot->scene.vertices.rows(), kCheckedRows);
    slot->ref = bench::scene_reference<T>(slot->scene, slot->rows);
    slot->rbf_ref =
        testing::rbf_centroid_reference(slot->ref, slot->scene.vertices.cast<T>().template cast<double>(),
                                        slot->scene.rest.points.cast<T>().template cast<double>(),
                                        slot->scene.moved.points.cast<T>().template cast<double>(), slot->rows);
  }
  return *slot;
}

const char* storage_name(WeightStorage s) {
  switch (s) {
    case WeightStorage::precomputed:
      return "precomputed";
    case WeightStorage::on_the_fly:
      return "on_the_fly";
    case WeightStorage::precomputed_weights:
      return "precomputed_weights";
    default:
      return "automatic";
  }
}

void bm(benchmark::State& state, const std::string& key, Eigen::Index n, Eigen::Index k, WeightStorage storage,
        int threads, mlsdeform::Centroids centroids) {
  const Prepared& p = prepared(key, n, k);
  mlsdeform::Options o = bench::deformer_options(std::nullopt, threads, storage);
  o.centroids = centroids;
  bench::run_deformer<T>(state, p.scene, centroids == mlsdeform::Centroids::rbf ? p.rbf_ref : p.ref, p.rows, o);
  const double pairs = static_cast<double>(p.scene.vertices.rows()) * static_cast<double>(k);
  state.counters["ns_per_vertex_handle"] = bench::ns_per(pairs);
  state.counters["requested_precomputed"] = storage == WeightStorage::precomputed ? 1 : 0;
}

void add(const std::string& name, const std::string& key, Eigen::Index n, Eigen::Index k, WeightStorage storage,
         int threads, mlsdeform::Centroids centroids = mlsdeform::Centroids::mls) {
  // One thread: the thread's CPU time (robust to other processes on a shared machine); more: wall-clock.
  auto* b = benchmark::RegisterBenchmark(name.c_str(), [=](benchmark::State& s) {
              bm(s, key, n, k, storage, threads, centroids);
            })->Unit(benchmark::kMillisecond);
  if (threads != 1) b->UseRealTime();
}

}  // namespace

int main(int argc, char** argv) {
  const Eigen::Index sizes[] = {1000, 3000, 10000, 30000, 100000, 300000, 1000000};
  const Eigen::Index handle_counts[] = {1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024};
  const int all = bench::hardware_threads();
  for (WeightStorage st : {WeightStorage::precomputed, WeightStorage::on_the_fly, WeightStorage::precomputed_weights}) {
    const std::string s = storage_name(st);
    for (Eigen::Index n : sizes)
      add("scaling/vertices/" + s + "/n:" + std::to_string(n), "box" + std::to_string(n), n, 10, st, 0);
    add("scaling/vertices/" + s + "/spot_loop3", "spot_loop3", 0, 10, st, 0);
    for (Eigen::Index k : handle_counts)
      add("scaling/handles/" + s + "/k:" + std::to_string(k), "box10000k" + std::to_string(k), 10000, k, st, 0);
    for (Eigen::Index n : {Eigen::Index(100000), Eigen::Index(1000000)})
      for (int t : {1, all})
        add("scaling/threads/" + s + "/n:" + std::to_string(n) + "/threads:" + std::to_string(t),
            "box" + std::to_string(n), n, 10, st, t);
  }
  // What a user gets by default (WeightStorage::automatic), where the targets are set.
  add("scaling/vertices/automatic/n:1000000", "box1000000", 1000000, 10, WeightStorage::automatic, 0);
  add("scaling/handles/automatic/k:256", "box10000k256", 10000, 256, WeightStorage::automatic, 0);
  for (Eigen::Index n : {Eigen::Index(10000), Eigen::Index(100000), Eigen::Index(1000000)})
    for (auto [c, cn] : {std::pair{mlsdeform::Centroids::mls, "mls"}, std::pair{mlsdeform::Centroids::rbf, "rbf"}})
      add(std::string("scaling/centroids/") + cn + "/n:" + std::to_string(n), "box" + std::to_string(n), n, 10,
          WeightStorage::precomputed, 0, c);
  bench::add_context(
      std::string(mlsdeform::to_string(mlsdeform::active_isa())) + " (Deformer, Options::isa unset; float)",
      "all (" + std::to_string(all) + ") unless the name ends threads:N");
  return bench::run_benchmarks(argc, argv);
}
