// Roofline: this machine's peaks, measured here, and what the main kernels achieve.
//
// Peaks (measured, not from a data sheet; the VM hides the clock and has no PMU):
//   peak/fma/<type>/<isa>/threads:N  FMA throughput: 12 (AVX2) or 24 (AVX-512) independent accumulators,
//                                    acc = acc * a + b, enough to cover the FMA latency on every pipe
//                                    (latency 4 x 2 pipes on Zen); 2 flops per lane per FMA. Every thread
//                                    runs its own loop (Google Benchmark ->Threads), rates summed.
//   peak/triad/threads:N             STREAM's triad a[i] = b[i] + s c[i] over 3 x 2^24 doubles (384 MB, far
//                                    beyond the 32 MB L3), counted as STREAM does: 24 bytes per element
//                                    (the write-allocate read of a[] is not counted); static partition over
//                                    N threads, arrays first touched by the thread that uses them.
// Kernels (GFLOPs and GBs counters beside the peaks; the report draws the roofline):
//   kernel/fit/float/axis_angle/<isa>/<hot|stream>  the batched fit (mlsdeform::fit_rotations), one thread.
//        flops per fit: counted by running the scalar reference (core/src/rotation/axis_angle.hpp) on an instrumented
//        scalar type over the same matrices (bench/flop_count.hpp); the SIMD lanes run the same stages, so
//        this is the useful work (masked lanes and selects are not counted). Bytes: 36 in + 36 out per fit.
//   kernel/deform/<scene>/<storage>   one frame of the Deformer (Options::isa unset, all cores). Flops: nominal
//        counts of the algorithm, per vertex and handle 24 when precomputed (H += A_i q_i^T: 9 FMA;
//        q* += w_i q_i: 3 FMA) and 40 on the fly (d = v - p_i, |d|^2, w = 1/|d|^2, then sums of w, w p_i,
//        w q_i and w q_i p_i^T), plus per vertex the fit's counted flops and 21 to apply R (v - p*) + q*.
//        Bytes: Deformer::memory_bytes() (everything the frame reads from the precomputation) + 12 per
//        vertex written.
#include "bench/cases.hpp"
#include "bench/common.hpp"
#include "bench/deform_common.hpp"
#include "bench/flop_count.hpp"
#include "bench/reference.hpp"

#include "core/src/rotation/axis_angle.hpp"  // the scalar reference, instantiated on bench::Counted for the count

#include <mlsdeform/deformer.hpp>
#include <mlsdeform/fit_rotations.hpp>

#include <immintrin.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace {

// ---------------------------------------------------------------------------------------------------------
// Peak FMA throughput. Each function runs `iters` rounds of one FMA per accumulator and returns a sum of
// the accumulators (so nothing is optimised away). acc -> acc * a + b converges to b / (1 - a): no overflow,
// no subnormals. The inner loop is unrolled by pragma so that the accumulators live in registers (without
// it GCC 12 interchanged the loops and kept them in memory, halving the AVX-512 figure).
// ---------------------------------------------------------------------------------------------------------

constexpr int kAcc256 = 12, kAcc512 = 24;

__attribute__((target("avx2,fma"))) double fma_avx2_float(std::int64_t iters) {
  __m256 acc[kAcc256];
  for (int j = 0; j < kAcc256; ++j) acc[j] = _mm256_set1_ps(float(j));
  const __m256 a = _mm256_set1_ps(0.5f), b = _mm256_set1_ps(1.0f);
  for (std::int64_t i = 0; i < iters; ++i)
#pragma GCC unroll 32
    for (int j = 0; j < kAcc256; ++j) acc[j] = _mm256_fmadd_ps(acc[j], a, b);
  __m256 s = acc[0];
  for (int j = 1; j < kAcc256; ++j) s = _mm256_add_ps(s, acc[j]);
  float out[8];
  _mm256_storeu_ps(out, s);
  return out[0];
}

__attribute__((target("avx2,fma"))) double fma_avx2_double(std::int64_t iters) {
  __m256d acc[kAcc256];
  for (int j = 0; j < kAcc256; ++j) acc[j] = _mm256_set1_pd(double(j));
  const __m256d a = _mm256_set1_pd(0.5), b = _mm256_set1_pd(1.0);
  for (std::int64_t i = 0; i < iters; ++i)
#pragma GCC unroll 32
    for (int j = 0; j < kAcc256; ++j) acc[j] = _mm256_fmadd_pd(acc[j], a, b);
  __m256d s = acc[0];
  for (int j = 1; j < kAcc256; ++j) s = _mm256_add_pd(s, acc[j]);
  double out[4];
  _mm256_storeu_pd(out, s);
  return out[0];
}

__attribute__((target("avx512f"))) double fma_avx512_float(std::int64_t iters) {
  __m512 acc[kAcc512];
  for (int j = 0; j < kAcc512; ++j) acc[j] = _mm512_set1_ps(float(j));
  const __m512 a = _mm512_set1_ps(0.5f), b = _mm512_set1_ps(1.0f);
  for (std::int64_t i = 0; i < iters; ++i)
#pragma GCC unroll 32
    for (int j = 0; j < kAcc512; ++j) acc[j] = _mm512_fmadd_ps(acc[j], a, b);
  __m512 s = acc[0];
  for (int j = 1; j < kAcc512; ++j) s = _mm512_add_ps(s, acc[j]);
  float out[16];
  _mm512_storeu_ps(out, s);
  return out[0];
}

__attribute__((target("avx512f"))) double fma_avx512_double(std::int64_t iters) {
  __m512d acc[kAcc512];
  for (int j = 0; j < kAcc512; ++j) acc[j] = _mm512_set1_pd(double(j));
  const __m512d a = _mm512_set1_pd(0.5), b = _mm512_set1_pd(1.0);
  for (std::int64_t i = 0; i < iters; ++i)
#pragma GCC unroll 32
    for (int j = 0; j < kAcc512; ++j) acc[j] = _mm512_fmadd_pd(acc[j], a, b);
  __m512d s = acc[0];
  for (int j = 1; j < kAcc512; ++j) s = _mm512_add_pd(s, acc[j]);
  double out[8];
  _mm512_storeu_pd(out, s);
  return out[0];
}

void bm_fma(benchmark::State& state, double (*loop)(std::int64_t), int accumulators, int lanes) {
  constexpr std::int64_t kIters = 1 << 20;
  // Check: after many rounds every accumulator is at the fixed point b / (1 - a) = 2.
  if (const double x = loop(64) / accumulators; std::abs(x - 2.0) > 1e-6) {
    state.SkipWithError(("FMA loop converged to " + std::to_string(x) + ", expected 2").c_str());
    return;
  }
  for (auto _ : state) benchmark::DoNotOptimize(loop(kIters));
  const double flops = 2.0 * lanes * accumulators * static_cast<double>(kIters);
  // With ->Threads(N), Google Benchmark sums this counter over the N threads and also multiplies by the
  // iterations of all N threads: kAvgThreads removes the double count, leaving the sum of the threads' rates.
  state.counters["GFLOPs"] =
      benchmark::Counter(flops * 1e-9, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kAvgThreads);
}

// ---------------------------------------------------------------------------------------------------------
// STREAM triad
// ---------------------------------------------------------------------------------------------------------

constexpr std::size_t kTriadN = std::size_t(1) << 24;

struct TriadArrays {
  std::unique_ptr<double[]> a, b, c;
};

void bm_triad(benchmark::State& state, int threads) {
  TriadArrays t{std::unique_ptr<double[]>(new double[kTriadN]), std::unique_ptr<double[]>(new double[kTriadN]),
                std::unique_ptr<double[]>(new double[kTriadN])};
  tbb::task_arena arena(threads);
  const double s = 3.0;
  auto parallel = [&](auto body) {
    arena.execute([&] {
      tbb::parallel_for(
          tbb::blocked_range<std::size_t>(0, kTriadN, kTriadN / static_cast<std::size_t>(threads)),
          [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); }, tbb::static_partitioner());
    });
  };
  parallel([&](std::size_t lo, std::size_t hi) {  // first touch by the using thread
    for (std::size_t i = lo; i < hi; ++i) t.a[i] = 0, t.b[i] = double(i % 1000), t.c[i] = 1.0;
  });
  parallel([&](std::size_t lo, std::size_t hi) {
    for (std::size_t i = lo; i < hi; ++i) t.a[i] = t.b[i] + s * t.c[i];
  });
  for (std::size_t i = 0; i < kTriadN; i += 4099)
    if (t.a[i] != double(i % 1000) + 3.0) {
      state.SkipWithError("triad result wrong");
      return;
    }
  for (auto _ : state) {
    parallel([&](std::size_t lo, std::size_t hi) {
      double* __restrict a = t.a.get();
      const double* __restrict b = t.b.get();
      const double* __restrict c = t.c.get();
      for (std::size_t i = lo; i < hi; ++i) a[i] = b[i] + s * c[i];
    });
    benchmark::ClobberMemory();
  }
  state.counters["GBs"] = benchmark::Counter(24.0 * kTriadN * 1e-9, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["GFLOPs"] = benchmark::Counter(2.0 * kTriadN * 1e-9, benchmark::Counter::kIsIterationInvariantRate);
}

// ---------------------------------------------------------------------------------------------------------
// Flops per fit, counted on the scalar reference (mean over the first kCountCases benchmark matrices).
// ---------------------------------------------------------------------------------------------------------

constexpr std::size_t kFitCases = 4096;  // hot working set, as in bench_rotation_fit's fit_hot
constexpr std::size_t kStreamCases = 1'000'000;

struct FitCount {
  double flops = 0, div = 0, sqrt = 0, transcendental = 0;
};

const FitCount& fit_count() {
  static const FitCount c = [] {
    using C = bench::Counted<float>;
    FitCount r;
    constexpr std::size_t n = 20000;
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Matrix3f H = bench::make_case(bench::kCaseSeed, i).cast<float>();
      const float m = H.cwiseAbs().maxCoeff();
      const Eigen::Matrix3f Hn = H * std::ldexp(1.0f, -std::ilogb(m));  // as fit_rotation normalises
      bench::flop_tally = {};
      mlsdeform::detail::fit_rotation_axis_angle<C>(Hn.cast<C>());
      r.flops += double(bench::flop_tally.flops());
      r.div += double(bench::flop_tally.div);
      r.sqrt += double(bench::flop_tally.sqrt);
      r.transcendental += double(bench::flop_tally.transcendental);
    }
    r.flops /= n, r.div /= n, r.sqrt /= n, r.transcendental /= n;
    return r;
  }();
  return c;
}

std::vector<float> soa_cases(std::size_t n) {
  std::vector<float> H(9 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Matrix3f Hi = bench::make_case(bench::kCaseSeed, i).cast<float>();
    for (std::size_t e = 0; e < 9; ++e) H[e * n + i] = Hi(e / 3, e % 3);
  }
  return H;
}

void bm_fit(benchmark::State& state, mlsdeform::Isa isa, std::size_t n, int threads) {
  static std::map<std::size_t, std::vector<float>> sets;
  auto& H = sets[n];
  if (H.empty()) H = soa_cases(n);
  const mlsdeform::Isa saved = mlsdeform::active_isa();
  mlsdeform::set_isa(isa);
  std::vector<float> R(9 * n);
  mlsdeform::fit_rotations<float>(H.data(), R.data(), n, mlsdeform::RotationMethod::axis_angle, threads);
  // Check a spread of results against the long-double SVD reference (bench_rotation_fit checks them all).
  for (std::size_t i = 0; i < n; i += std::max<std::size_t>(1, n / 4096)) {
    Eigen::Matrix3f Hi, Ri;
    for (std::size_t e = 0; e < 9; ++e) Hi(e / 3, e % 3) = H[e * n + i], Ri(e / 3, e % 3) = R[e * n + i];
    const bench::Verdict v =
        bench::judge(Ri, Hi, bench::reference(Hi), bench::Judge::method(mlsdeform::RotationMethod::axis_angle));
    if (!v.ok) {
      mlsdeform::set_isa(saved);
      state.SkipWithError(("fit " + std::to_string(i) + " off the reference: " + v.describe()).c_str());
      return;
    }
  }
  for (auto _ : state) {
    mlsdeform::fit_rotations<float>(H.data(), R.data(), n, mlsdeform::RotationMethod::axis_angle, threads);
    benchmark::DoNotOptimize(R.data());
    benchmark::ClobberMemory();
  }
  mlsdeform::set_isa(saved);
  const FitCount& fc = fit_count();
  const double fits = static_cast<double>(n);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
  state.counters["ns_per_fit"] = bench::ns_per(fits);
  state.counters["GFLOPs"] = benchmark::Counter(fc.flops * fits * 1e-9, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["GBs"] = benchmark::Counter(72.0 * fits * 1e-9, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["flops_per_fit"] = fc.flops;
  state.counters["div_per_fit"] = fc.div;
  state.counters["sqrt_per_fit"] = fc.sqrt;
  state.counters["transcendental_per_fit"] = fc.transcendental;
}

// ---------------------------------------------------------------------------------------------------------
// Deformation frames
// ---------------------------------------------------------------------------------------------------------

struct Prepared {
  bench::DeformCase scene;
  std::vector<Eigen::Index> rows;
  bench::SampledReference ref;
};

const Prepared& scene(const std::string& name) {
  static std::map<std::string, std::unique_ptr<Prepared>> cache;
  auto& slot = cache[name];
  if (!slot) {
    slot = std::make_unique<Prepared>();
    namespace testing = mlsdeform::testing;
    if (name == "Bar") {
      slot->scene = testing::twisted_mesh_case(name, testing::box_surface(16, 16, 88), 256, 356);
    } else {  // box1M: 10^6 random points in a 4 x 1 x 1 box (bench_scaling's n:1000000), 10 handles
      slot->scene = testing::twisted_mesh_case(name, testing::random_box(1000000, 7 + 1000000), 10, 21);
    }
    slot->rows = bench::check_rows(slot->scene.vertices.rows(), 2000);
    slot->ref = bench::scene_reference<float>(slot->scene, slot->rows);
  }
  return *slot;
}

void bm_deform(benchmark::State& state, const std::string& name, mlsdeform::WeightStorage storage) {
  const Prepared& p = scene(name);
  bench::run_deformer<float>(state, p.scene, p.ref, p.rows, bench::deformer_options(std::nullopt, 0, storage));
  if (state.error_occurred()) return;
  const double n = static_cast<double>(p.scene.vertices.rows()), k = static_cast<double>(p.scene.rest.points.rows());
  const bool pre = storage == mlsdeform::WeightStorage::precomputed;
  const double flops = n * k * (pre ? 24.0 : 40.0) + n * (fit_count().flops + 21.0);
  const double bytes = state.counters["memory_bytes"].value + 12.0 * n;
  state.counters["GFLOPs"] = benchmark::Counter(flops * 1e-9, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["GBs"] = benchmark::Counter(bytes * 1e-9, benchmark::Counter::kIsIterationInvariantRate);
}

}  // namespace

int main(int argc, char** argv) {
  const int all = bench::hardware_threads();
  const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  const bool avx512 = __builtin_cpu_supports("avx512f");
  struct Loop {
    const char* name;
    double (*fn)(std::int64_t);
    int acc, lanes;
    bool ok;
  };
  const Loop loops[] = {{"float/avx2", fma_avx2_float, kAcc256, 8, avx2},
                        {"double/avx2", fma_avx2_double, kAcc256, 4, avx2},
                        {"float/avx512", fma_avx512_float, kAcc512, 16, avx512},
                        {"double/avx512", fma_avx512_double, kAcc512, 8, avx512}};
  // One thread: CPU time (robust to other processes on the shared machine); all threads: wall-clock.
  for (const Loop& l : loops)
    if (l.ok) {
      const std::string name = std::string("peak/fma/") + l.name;
      benchmark::RegisterBenchmark(name.c_str(), [l](benchmark::State& s) {
        bm_fma(s, l.fn, l.acc, l.lanes);
      })->Threads(1);
      benchmark::RegisterBenchmark(name.c_str(), [l](benchmark::State& s) { bm_fma(s, l.fn, l.acc, l.lanes); })
          ->Threads(all)
          ->UseRealTime();
    }
  for (int t : {1, all}) {
    auto* b =
        benchmark::RegisterBenchmark(("peak/triad/threads:" + std::to_string(t)).c_str(), [t](benchmark::State& s) {
          bm_triad(s, t);
        })->Unit(benchmark::kMillisecond);
    if (t != 1) b->UseRealTime();
  }
  const mlsdeform::Isa best = mlsdeform::supported_isas().back();
  for (mlsdeform::Isa isa : mlsdeform::supported_isas()) {
    if (isa == mlsdeform::Isa::scalar) continue;
    const std::string base = "kernel/fit/float/axis_angle/" + std::string(mlsdeform::to_string(isa));
    benchmark::RegisterBenchmark((base + "/hot").c_str(), [isa](benchmark::State& s) { bm_fit(s, isa, kFitCases, 1); });
    benchmark::RegisterBenchmark((base + "/stream").c_str(), [isa](benchmark::State& s) {
      bm_fit(s, isa, kStreamCases, 1);
    })->Unit(benchmark::kMillisecond);
  }
  const std::string best_base = "kernel/fit/float/axis_angle/" + std::string(mlsdeform::to_string(best));
  benchmark::RegisterBenchmark((best_base + "/hot/threads:" + std::to_string(all)).c_str(), [best](
                                                                                                benchmark::State& s) {
    bm_fit(s, best, kFitCases * 16, 0);
  })->UseRealTime();
  for (const char* name : {"Bar", "box1M"})
    for (mlsdeform::WeightStorage st : {mlsdeform::WeightStorage::precomputed, mlsdeform::WeightStorage::on_the_fly})
      benchmark::RegisterBenchmark((std::string("kernel/deform/") + name + "/" +
                                    (st == mlsdeform::WeightStorage::precomputed ? "precomputed" : "on_the_fly"))
                                       .c_str(),
                                   [name, st](benchmark::State& s) { bm_deform(s, name, st); })
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
  bench::add_context(std::string(mlsdeform::to_string(mlsdeform::active_isa())) + " (library default)",
                     "1 unless the name ends threads:N; kernel/deform: all");
  const FitCount& fc = fit_count();
  benchmark::AddCustomContext("fit_flops_counted", std::to_string(fc.flops));
  return bench::run_benchmarks(argc, argv);
}
