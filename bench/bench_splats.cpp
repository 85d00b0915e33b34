// What carrying 3DGS splats through a deformation costs beside moving their centres (float, 10^6 splats):
//   splats/positions/n:<n>/threads:<t>          the deformer's frame alone (rigid, 10 handles, precomputed
//                                               weights; bench_scaling's box scene): the bare point cloud's cost
//   splats/rotate/sh:<d>/n:<n>/threads:<t>      rotate_splats: quaternions composed, SH bands 1..d rotated
//   splats/similarity/sh:3/n:<n>/threads:<t>    the same with scales (log-scale offsets)
//   splats/affine/sh:3/n:<n>/threads:<t>        transform_splats_affine (eigensolver, SVD per splat)
// With --write-ply=PATH it writes those splats as a 3DGS PLY file and a handles file instead (for the program).
// Counters: ns_per_splat. Every transform is a random rotation (or 0.9..1.1 s R, or I + 0.1 N for affine), so
// no splat takes the identity's shortcut. Before timing, the rotated quaternions of 1,000 splats are checked
// against their Hamilton products in long double (SkipWithError on a mismatch). Ratios against
// splats/positions at the same n and threads are what docs/splats.md publishes.
#include "bench/deform_common.hpp"
#include "tests/support/random.hpp"
#include "tests/support/splats.hpp"

#include <mlsdeform/splats.hpp>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

namespace {

using T = float;
constexpr std::size_t kSplats = 1000000;

struct Transforms {
  std::vector<T> quaternions, scales, linear;
};

const Transforms& transforms() {
  static const Transforms t = [] {
    mlsdeform::testing::Rng rng(5);
    Transforms r;
    r.quaternions.resize(4 * kSplats);
    r.scales.resize(kSplats);
    r.linear.resize(9 * kSplats);
    for (std::size_t i = 0; i < kSplats; ++i) {
      const Eigen::Matrix3d R = rng.rotation<double>();
      const Eigen::Quaterniond q(R);
      const double parts[4] = {q.w(), q.x(), q.y(), q.z()};
      const double n = std::sqrt(parts[0] * parts[0] + parts[1] * parts[1] + parts[2] * parts[2] + parts[3] * parts[3]);
      for (std::size_t j = 0; j < 4; ++j) r.quaternions[4 * i + j] = T(parts[j] / n);
      r.scales[i] = T(rng.uniform<double>(0.9, 1.1));
      for (std::size_t j = 0; j < 9; ++j) r.linear[9 * i + j] = T((j % 4 == 0 ? 1 : 0) + 0.1 * rng.gaussian<double>());
    }
    return r;
  }();
  return t;
}

const mlsdeform::testing::SplatCloud& cloud() {
  static const mlsdeform::testing::SplatCloud c = mlsdeform::testing::random_splat_cloud(kSplats, 3);
  return c;
}

/// Empty when the first 1,000 rotated quaternions are the normalised Hamilton products q_R q to float's rounding
/// (4 eps: four components each rounded once, the product in double); else a message.
std::string check_rotations(const std::vector<T>& out) {
  const Transforms& t = transforms();
  for (std::size_t i = 0; i < 1000; ++i) {
    using Q = Eigen::Quaternion<long double>;
    const T* a = t.quaternions.data() + 4 * i;
    const T* b = cloud().rotations.data() + 4 * i;
    Q p = Q(a[0], a[1], a[2], a[3]) * Q(b[0], b[1], b[2], b[3]);
    p.normalize();
    const long double e[4] = {p.w(), p.x(), p.y(), p.z()};
    for (std::size_t j = 0; j < 4; ++j)
      if (std::abs(e[j] - out[4 * i + j]) > 4 * std::numeric_limits<T>::epsilon())
        return "splat " + std::to_string(i) + ": rotation off the long-double product";
  }
  return {};
}

enum class Motion { rotate, similarity, affine };

void bm_splats(benchmark::State& state, Motion motion, int degree, int threads) {
  const mlsdeform::testing::SplatCloud& c = cloud();
  const Transforms& t = transforms();
  const int k = mlsdeform::splat_sh_rest_count(degree);
  std::vector<T> rot = c.rotations, ls = c.log_scales, sh(std::size_t(k) * kSplats);
  for (std::size_t i = 0; i < kSplats; ++i)
    std::copy_n(c.f_rest.begin() + std::ptrdiff_t(45 * i), k, sh.begin() + std::ptrdiff_t(std::size_t(k) * i));
  const mlsdeform::SplatArrays<T> a{rot.data(), ls.data(), k ? sh.data() : nullptr, degree};
  auto once = [&] {
    if (motion == Motion::affine)
      mlsdeform::transform_splats_affine<T>(a, kSplats, t.linear.data(), threads);
    else
      mlsdeform::rotate_splats<T>(a, kSplats, t.quaternions.data(),
                                  motion == Motion::similarity ? t.scales.data() : nullptr, threads);
  };
  once();
  if (motion != Motion::affine)
    if (const std::string err = check_rotations(rot); !err.empty()) {
      state.SkipWithError(err.c_str());
      return;
    }
  for (auto _ : state) {
    // each iteration turns the splats again: the work per splat does not depend on where they point
    once();
    benchmark::ClobberMemory();
  }
  state.counters["ns_per_splat"] = bench::ns_per(double(kSplats));
}

void bm_positions(benchmark::State& state, int threads) {
  namespace testing = mlsdeform::testing;
  static const bench::DeformCase scene =
      testing::twisted_mesh_case("box", testing::random_box(Eigen::Index(kSplats), 7 + kSplats), 10, 21);
  static const std::vector<Eigen::Index> rows = bench::check_rows(scene.vertices.rows(), 2000);
  static const bench::SampledReference ref = bench::scene_reference<T>(scene, rows);
  bench::run_deformer<T>(state, scene, ref, rows,
                         bench::deformer_options(std::nullopt, threads, mlsdeform::WeightStorage::precomputed));
  state.counters["ns_per_splat"] = bench::ns_per(double(kSplats));
}

void add(const std::string& name, int threads, std::function<void(benchmark::State&)> f) {
  auto* b = benchmark::RegisterBenchmark(name.c_str(), f)->Unit(benchmark::kMillisecond);
  if (threads != 1) b->UseRealTime();
}

/// The splat file and a handles file bending its bar: both ends held by two layers of four handles, the top
/// ones turned 60 degrees about x around (0, 0, 1.5).
int write_ply(const std::string& path) {
  mlsdeform::testing::write_splat_ply(path, cloud());
  const std::string json = mlsdeform::testing::bent_bar_handles();
  std::FILE* f = std::fopen((path + ".json").c_str(), "w");
  if (!f) return 1;
  std::fputs(json.c_str(), f);
  std::fclose(f);
  std::printf("%s (%zu splats), %s.json\n", path.c_str(), kSplats, path.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // --write-ply=PATH: instead, write the benchmark's 10^6 splats as a 3DGS PLY file (the program's timing in
  // docs/splats.md deforms it) with a handles file PATH.json bending the bar.
  const std::vector<std::string> options = bench::take_options(argc, argv, {"write-ply"});
  if (!options[0].empty()) return write_ply(options[0]);
  const int all = bench::hardware_threads();
  const std::string n = "/n:" + std::to_string(kSplats);
  for (int t : {1, all}) {
    const std::string th = "/threads:" + std::to_string(t);
    add("splats/positions" + n + th, t, [t](benchmark::State& s) { bm_positions(s, t); });
    for (int d : {0, 1, 3})
      add("splats/rotate/sh:" + std::to_string(d) + n + th, t,
          [t, d](benchmark::State& s) { bm_splats(s, Motion::rotate, d, t); });
    add("splats/similarity/sh:3" + n + th, t, [t](benchmark::State& s) { bm_splats(s, Motion::similarity, 3, t); });
    add("splats/affine/sh:3" + n + th, t, [t](benchmark::State& s) { bm_splats(s, Motion::affine, 3, t); });
  }
  bench::add_context(std::string(mlsdeform::to_string(mlsdeform::active_isa())) +
                         " (float; the splat functions "
                         "are scalar code)",
                     "1 or all (" + std::to_string(all) + "): the name ends threads:N");
  return bench::run_benchmarks(argc, argv);
}
