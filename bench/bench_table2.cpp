// The paper's Table 2: frames per second for rigid MLS deformation of its six models, float, for
//   naive        a per-vertex loop with Eigen::JacobiSVD, written from the paper (bench/naive_mls.hpp), 1 core
//   scalar       Deformer, Isa::scalar (the project's scalar reference path), 1 thread
//   simd_1t      Deformer, Options::isa unset, 1 thread
//   simd_all     Deformer, Options::isa unset, all cores
// Each carries the paper's figure as the counter paper_fps (Pentium 4 at 3.2 GHz, 2009, including OpenGL
// rendering at 600 x 600), and every variant, the naive loop included, is first checked on every vertex
// against the same reference in double (tests/support/mls_reference.hpp: deform_tolerance), so all variants
// compute the same deformation; the naive loop is also compared with the Deformer directly.
//
// Models (vertices / handles as in the paper). Where a shared mesh is the paper model's natural counterpart
// (../shared/data/meshes/LICENSES.txt, column 'paper analogue') a random subset of its vertices of the
// paper's size is used (MLS cost depends on vertex positions only, not on faces):
//   Dolphin  2,811 / 4    fish.obj: "Blub" by Keenan Crane, remeshed by O. Stein (public domain)
//   Homer    5,103 / 6    human_man.obj: SMPL template mesh, Max Planck Society (CC BY 4.0; Loper et al.,
//                         "SMPL", SIGGRAPH Asia 2015)
//   Dino     14,050 / 5   spot_loop3.ply.gz: "Spot" by Keenan Crane, remeshed by O. Stein, 3 Loop
//                         subdivisions (public domain); spot.obj itself has only 11,533 vertices
//   Plane    1,089 / 132  generated 33 x 33 grid
//   Bar      6,146 / 256  generated 16 x 16 x 88 box surface (the paper's Fig. 3 parallelepiped)
//   Cylinder 1,058 / 322  generated open cylinder, 46 around x 23 rings
// Handles are random mesh vertices (fixed seed); the frame twists them by up to 90 degrees about the
// model's long axis and bends them (tests/support/deform_cases.hpp: twisted_mesh_case).
#include "bench/deform_common.hpp"

#include <mlsdeform/deformer.hpp>
#include <mlsdeform/dispatch.hpp>

#include <exception>
#include <map>
#include <stdexcept>
#include <string>

namespace {

using bench::PointsD;
using T = float;

struct Config {
  const char* name;
  Eigen::Index vertices, handles;
  double paper_fps;
};

constexpr Config kConfigs[] = {
    {"Dolphin", 2811, 4, 40}, {"Homer", 5103, 6, 22}, {"Plane", 1089, 132, 19.5},
    {"Dino", 14050, 5, 6.5},  {"Bar", 6146, 256, 2},  {"Cylinder", 1058, 322, 9.5},
};

PointsD model_vertices(const Config& c) {
  namespace testing = mlsdeform::testing;
  const std::string dir = testing::mesh_dir() + "/";
  const std::string name = c.name;
  if (name == "Dolphin") return testing::random_subset(testing::read_obj_vertices(dir + "fish.obj"), c.vertices, 1);
  if (name == "Homer") return testing::random_subset(testing::read_obj_vertices(dir + "human_man.obj"), c.vertices, 2);
  if (name == "Dino")
    return testing::random_subset(testing::read_ply_vertices(dir + "spot_loop3.ply.gz"), c.vertices, 3);
  if (name == "Plane") return testing::grid(33);
  if (name == "Bar") return testing::box_surface(16, 16, 88);
  return testing::cylinder(46, 23);
}

/// A configuration's scene and reference, built on first use.
struct Prepared {
  bench::DeformCase scene;
  std::vector<Eigen::Index> rows;
  bench::SampledReference ref;
};

const Prepared& prepared(const Config& c) {
  static std::map<std::string, Prepared> cache;
  auto it = cache.find(c.name);
  if (it != cache.end()) return it->second;
  Prepared p;
  PointsD v = model_vertices(c);
  if (v.rows() != c.vertices)
    throw std::runtime_error(std::string(c.name) + ": " + std::to_string(v.rows()) + " vertices, expected " +
                             std::to_string(c.vertices));
  p.scene = mlsdeform::testing::twisted_mesh_case(c.name, std::move(v), c.handles,
                                                  100 + static_cast<std::uint64_t>(c.handles));
  p.rows = bench::check_rows(c.vertices, c.vertices);
  p.ref = bench::scene_reference<T>(p.scene, p.rows);
  return cache.emplace(c.name, std::move(p)).first->second;
}

/// prepared(c), or nullptr after SkipWithError naming what is missing (the shared meshes are not in the repository).
const Prepared* prepared_or_skip(benchmark::State& state, const Config& c) {
  try {
    return &prepared(c);
  } catch (const std::exception& e) {
    state.SkipWithError(
        (std::string(e.what()) + " (shared meshes: ../shared/data/meshes or $MLSDEFORM_MESHES)").c_str());
    return nullptr;
  }
}

void add_common_counters(benchmark::State& state, const Config& c) {
  state.counters["paper_fps"] = c.paper_fps;
  state.counters["vertices"] = static_cast<double>(c.vertices);
  state.counters["handles"] = static_cast<double>(c.handles);
}

void bm_naive(benchmark::State& state, const Config& c) {
  const Prepared* pp = prepared_or_skip(state, c);
  if (!pp) return;
  const Prepared& p = *pp;
  const mlsdeform::Points<T> v = p.scene.vertices.cast<T>(), h = p.scene.rest.points.cast<T>(),
                             q = p.scene.moved.points.cast<T>();
  mlsdeform::Points<T> out;
  bench::naive_mls_deform<T>(v, h, q, out);
  double worst = 0, max_dev = 0;
  if (const std::string err = bench::check_deformation<T>(out, p.ref, p.rows, worst, max_dev); !err.empty()) {
    state.SkipWithError(("naive loop: " + err).c_str());
    return;
  }
  // And directly against the Deformer (scalar reference path): both are within deform_tolerance of the
  // double reference, so they differ by at most twice that.
  double max_dev_vs_deformer = 0;
  {
    mlsdeform::Points<T> lib;
    mlsdeform::Deformer<T>(v, bench::point_handles<T>(p.scene.rest.points),
                           bench::deformer_options(mlsdeform::Isa::scalar, 1))
        .deform(bench::point_handles<T>(p.scene.moved.points), lib);
    for (std::size_t s = 0; s < p.rows.size(); ++s) {
      const double d = (out.row(p.rows[s]) - lib.row(p.rows[s])).template cast<double>().norm();
      max_dev_vs_deformer = std::max(max_dev_vs_deformer, d / p.ref.diameter);
      if (!(d <= 2 * bench::deform_tolerance(p.ref, s, std::numeric_limits<T>::epsilon()))) {
        state.SkipWithError(
            ("naive loop and Deformer differ at vertex " + std::to_string(p.rows[s]) + " by " + std::to_string(d))
                .c_str());
        return;
      }
    }
  }
  bench::time_frames<T>(state, out, [&] { bench::naive_mls_deform<T>(v, h, q, out); });
  state.counters["worst_err_over_tol"] = worst;
  state.counters["max_dev_over_diameter"] = max_dev;
  state.counters["max_dev_vs_deformer_over_diameter"] = max_dev_vs_deformer;
  add_common_counters(state, c);
}

void bm_deformer(benchmark::State& state, const Config& c, std::optional<mlsdeform::Isa> isa, int threads) {
  const Prepared* pp = prepared_or_skip(state, c);
  if (!pp) return;
  const Prepared& p = *pp;
  bench::run_deformer<T>(state, p.scene, p.ref, p.rows, bench::deformer_options(isa, threads));
  add_common_counters(state, c);
}

}  // namespace

int main(int argc, char** argv) {
  // Single-threaded variants are timed by the thread's CPU time (Google Benchmark's default: on this shared
  // 2-core machine it is not inflated when another process takes turns on the core); all-threads by
  // wall-clock time (UseRealTime), since TBB's workers do the work.
  for (const Config& c : kConfigs) {
    const std::string base = std::string("table2/") + c.name + "/";
    benchmark::RegisterBenchmark((base + "naive").c_str(), [&c](benchmark::State& s) {
      bm_naive(s, c);
    })->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark((base + "scalar").c_str(), [&c](benchmark::State& s) {
      bm_deformer(s, c, mlsdeform::Isa::scalar, 1);
    })->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark((base + "simd_1t").c_str(), [&c](benchmark::State& s) {
      bm_deformer(s, c, std::nullopt, 1);
    })->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark((base + "simd_all").c_str(),
                                 [&c](benchmark::State& s) { bm_deformer(s, c, std::nullopt, 0); })
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
  bench::add_context(
      std::string(mlsdeform::to_string(mlsdeform::active_isa())) + " (Deformer, Options::isa unset; float)",
      "naive, scalar, simd_1t: 1; simd_all: " + std::to_string(bench::hardware_threads()));
  benchmark::AddCustomContext("meshes", mlsdeform::testing::mesh_dir());
  return bench::run_benchmarks(argc, argv);
}
