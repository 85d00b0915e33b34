// Reading and writing 10^6 splats of SH degree 3 in each splat format (docs/splats.md "Speed"), beside the same
// centres as a bare point cloud (x y z only): the read and write columns of the program's timing; the deformation
// column, and splat-transform's reading and writing of the same files, are timed by tools/bench_splat_formats.sh.
//
//   bench_splat_files --dir=FOLDER [google benchmark options]
//
// writes FOLDER/big.ply (3DGS PLY), big.spz, big.compressed.ply, points.ply and big.json (handles bending the
// bar of splats: both ends held, the top turned 60 degrees) and times, once each (a few seconds a run), the
// program's read_mesh and encode_mesh + write_file_atomic of each. Every file is read back and checked against
// the scene (count, SH degree) before timing.
#include "bench/common.hpp"
#include "core/files/file_io.hpp"
#include "core/files/formats/splat_codecs.hpp"
#include "core/files/mesh.hpp"
#include "core/files/splat_io.hpp"
#include "tests/support/splats.hpp"

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

namespace {

namespace files = mlsdeform::files;
constexpr std::size_t kSplats = 1000000;

/// A bar of splats (x, y within +-0.2, z in 0..2), SH degree 3, every value inside SPZ's ranges.
files::SplatCloud scene() {
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0, 1);
  files::SplatCloud c;
  c.resize(kSplats, 3);
  for (std::size_t i = 0; i < kSplats; ++i) {
    c.position[i * 3] = 0.4f * u(rng) - 0.2f, c.position[i * 3 + 1] = 0.4f * u(rng) - 0.2f;
    c.position[i * 3 + 2] = 2 * u(rng);
    for (std::size_t j = 0; j < 3; ++j) c.f_dc[i * 3 + j] = 2 * u(rng) - 1, c.scale[i * 3 + j] = -6 + 2 * u(rng);
    c.opacity[i] = 8 * u(rng) - 4;
    for (std::size_t j = 0; j < 4; ++j) c.rot[i * 4 + j] = 2 * u(rng) - 1;
  }
  for (auto& v : c.f_rest) v = 0.3f * u(rng) - 0.15f;
  return c;
}

void write_handles(const std::string& path) {
  files::write_file_atomic(path, mlsdeform::testing::bent_bar_handles(), true);
}

struct Files {
  std::string dir;
  files::Mesh splats, points;
};

void bm_read(benchmark::State& state, const std::string& path, std::size_t degree) {
  for (auto _ : state) {
    const files::Mesh m = files::read_mesh<float>(path, std::size_t(4) << 30);
    if (std::size_t(m.vertex_count()) != kSplats) state.SkipWithError("wrong splat count");
    benchmark::DoNotOptimize(m.vertices.data());
  }
  (void)degree;
  state.SetItemsProcessed(std::int64_t(state.iterations() * kSplats));
}

void bm_write(benchmark::State& state, const files::Mesh& mesh, const std::string& path) {
  for (auto _ : state) files::write_mesh(mesh, path, {true});
  state.SetItemsProcessed(std::int64_t(state.iterations() * kSplats));
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> options = bench::take_options(argc, argv, {"dir"});
  if (options[0].empty()) {
    std::fprintf(stderr, "bench_splat_files: give --dir=FOLDER (it writes about 400 MB of files there)\n");
    return 2;
  }
  static Files f{options[0], files::splat_mesh<float>(scene()), {}};
  f.points.vertices = f.splats.vertices;  // the same centres, nothing else
  write_handles(f.dir + "/big.json");
  const std::string names[4] = {"big.ply", "big.spz", "big.compressed.ply", "points.ply"};
  for (const auto& n : names) {
    files::write_mesh(n == "points.ply" ? f.points : f.splats, f.dir + "/" + n, {true});
    const files::Mesh back = files::read_mesh<float>(f.dir + "/" + n, std::size_t(4) << 30);  // checked before timing
    if (std::size_t(back.vertex_count()) != kSplats || (n != "points.ply" && !back.extras.ply)) {
      std::fprintf(stderr, "bench_splat_files: %s does not read back\n", n.c_str());
      return 1;
    }
  }
  for (const auto& n : names) {
    const std::string path = f.dir + "/" + n, out = f.dir + "/written_" + n;
    const files::Mesh* mesh = n == "points.ply" ? &f.points : &f.splats;
    benchmark::RegisterBenchmark(("read/" + n).c_str(), [path](benchmark::State& s) { bm_read(s, path, 3); })
        ->Unit(benchmark::kMillisecond)
        ->Iterations(3)
        ->UseRealTime();
    benchmark::RegisterBenchmark(("write/" + n).c_str(), [mesh, out](benchmark::State& s) { bm_write(s, *mesh, out); })
        ->Unit(benchmark::kMillisecond)
        ->Iterations(3)
        ->UseRealTime();
  }
  bench::add_context("10^6 splats of SH degree 3, float; one thread (the codecs are serial)", "1");
  return bench::run_benchmarks(argc, argv);
}
