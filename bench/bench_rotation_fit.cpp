// Rotation fit: ns per fit and fits per second for every RotationMethod, in float and double, plus QCP
// (bench/qcp.hpp) as an extra baseline, all on the same 10^6 random correlation matrices (bench/cases.hpp:
// random rotations of weighted noisy point sets, a fifth of them mirrored so that det H < 0), generated once;
// and the paper's method, the SVD, QCP and the batched fits again on 10^6 Gaussian H (entries iid N(0, 1),
// names gauss/... and gauss_hot/...), where a fit that slows down on hard inputs shows it.
//
// Every benchmark first runs its method over the whole set and checks each result against the long-double
// SVD reference with the project's accuracy bounds (bench/reference.hpp: tests/support's reference and
// bounds, the ones the accuracy suite applies, plus a derived bound for QCP); a single mismatch skips the
// benchmark with an error naming the case. Timing then repeats the whole pass; one
// iteration = 10^6 fits, streamed from memory (72 bytes of H per fit in double, 36 in float), one core.
//
// The sets and that check are in bench/rotation_fit_sets.hpp, the error sweep in bench/rotation_error_sweep.hpp.
//
// Names: fit/<float|double>/<method>/<path>, path = "scalar" for fit_rotation (the library's scalar
// reference, baseline flags) and for QCP, or batch:<isa> for the batched fit_rotations forced to that ISA
// (see the batched section below; fit_hot/... repeats a cache-resident subset).
//
// Extra options (before the Google Benchmark ones):
//   --cases=N           size of the set (default 1000000)
//   --error_sweep=FILE  also write the error-versus-distance-from-half-turn data (CSV) for the report's plot
#include "bench/common.hpp"
#include "bench/qcp.hpp"
#include "bench/reference.hpp"
#include "bench/rotation_error_sweep.hpp"
#include "bench/rotation_fit_sets.hpp"

#include <mlsdeform/fit_rotations.hpp>
#include <mlsdeform/rotation.hpp>

#include <algorithm>
#include <string>
#include <vector>

namespace {

using namespace bench::rotation_fit;

/// The common body: validate, then time whole passes over the set.
template <class T, class Fit>
void run_fit(benchmark::State& state, Set set, const bench::Judge& how, const Fit& fit) {
  const Data& d = data(set);
  const auto& H = d.template H<T>();
  const auto& ref = d.template ref<T>();
  const std::size_t n = H.size();
  std::vector<Matrix3<T>> out(n);
  double worst = 0;
  const auto verdict = [&](std::size_t i) {
    out[i] = fit(H[i]);
    return bench::judge(out[i], H[i], ref[i], how);
  };
  if (const std::string err = check_all(n, verdict, "fits", worst); !err.empty()) {
    state.SkipWithError(err.c_str());
    return;
  }
  for (auto _ : state) {
    for (std::size_t i = 0; i < n; ++i) out[i] = fit(H[i]);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
  state.counters["ns_per_fit"] = bench::ns_per(static_cast<double>(n));
  state.counters["worst_err_over_tol"] = worst;
}

template <class T>
void register_scalar(Set set) {
  for (RotationMethod m : mlsdeform::all_rotation_methods) {
    // On the Gaussian set: the paper's method and the SVD (Kabsch with Eigen::JacobiSVD) only.
    if (set == Set::gaussian && m != RotationMethod::axis_angle && m != RotationMethod::svd) continue;
    const std::string name =
        prefix(set, false) + type_name<T>() + "/" + std::string(mlsdeform::to_string(m)) + "/scalar";
    benchmark::RegisterBenchmark(name.c_str(), [set, m](benchmark::State& s) {
      run_fit<T>(s, set, bench::Judge::method(m),
                 [m](const Matrix3<T>& H) { return mlsdeform::fit_rotation<T>(H, m); });
    })->Unit(benchmark::kMillisecond);
  }
  const std::string name = prefix(set, false) + type_name<T>() + "/qcp/scalar";
  benchmark::RegisterBenchmark(name.c_str(), [set](benchmark::State& s) {
    run_fit<T>(s, set, bench::Judge::qcp(), [](const Matrix3<T>& H) { return bench::fit_rotation_qcp<T>(H); });
    // Mean Newton steps, for the record (counted outside the timed loop).
    const auto& Hs = data(set).template H<T>();
    double steps = 0;
    for (const auto& H : Hs) {
      bench::QcpInfo info;
      bench::fit_rotation_qcp<T>(H, &info);
      steps += info.newton;
    }
    s.counters["newton_steps"] = steps / static_cast<double>(Hs.size());
  })->Unit(benchmark::kMillisecond);
}

// ---------------------------------------------------------------------------------------------------------
// Batched: mlsdeform::fit_rotations over the same set in the 3 x 3 x n structure-of-arrays layout
// (<mlsdeform/fit_rotations.hpp>), for each ISA this CPU runs (forced with set_isa) and each method the kernels put
// in SIMD lanes. "fit" streams the 10^6 matrices from memory (72 bytes in and out per fit in float, 144 in
// double); "fit_hot" repeats the first 4096 (a 295 KB / 590 KB working set, in L2), which is what the
// deformer sees, since it builds each H in registers.
// ---------------------------------------------------------------------------------------------------------

constexpr RotationMethod kBatchedMethods[] = {RotationMethod::axis_angle, RotationMethod::horn_quaternion};
constexpr std::size_t kHotCount = 4096;

/// The set in SoA layout: entry (r, c) of matrix i at [(3 r + c) n + i].
template <class T>
std::vector<T> to_soa(Set set) {
  const auto& H = data(set).template H<T>();
  const std::size_t n = H.size();
  std::vector<T> out(9 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t e = 0; e < 9; ++e) out[e * n + i] = H[i](e / 3, e % 3);
  return out;
}

template <class T>
const std::vector<T>& soa(Set set) {
  if (set == Set::points) {
    static const std::vector<T> points = to_soa<T>(Set::points);
    return points;
  }
  static const std::vector<T> gaussian = to_soa<T>(Set::gaussian);
  return gaussian;
}

template <class T>
std::vector<T> soa_prefix(Set set, std::size_t m) {
  const auto& full = soa<T>(set);
  const std::size_t n = full.size() / 9;
  std::vector<T> out(9 * m);
  for (std::size_t e = 0; e < 9; ++e)
    std::copy(full.begin() + static_cast<std::ptrdiff_t>(e * n), full.begin() + static_cast<std::ptrdiff_t>(e * n + m),
              out.begin() + static_cast<std::ptrdiff_t>(e * m));
  return out;
}

/// The batched result R (n = all cases, SoA) against the references.
template <class T>
std::string validate_soa(Set set, const std::vector<T>& R, RotationMethod method, double& worst) {
  const Data& d = data(set);
  const auto& H = d.template H<T>();
  const auto& ref = d.template ref<T>();
  const std::size_t n = H.size();
  const auto verdict = [&](std::size_t i) {
    Matrix3<T> Ri;
    for (std::size_t e = 0; e < 9; ++e) Ri(e / 3, e % 3) = R[e * n + i];
    return bench::judge(Ri, H[i], ref[i], bench::Judge::method(method));
  };
  return check_all(n, verdict, "batched fits", worst);
}

/// Restores the library's default ISA choice when a batched benchmark ends.
struct IsaGuard {
  mlsdeform::Isa saved = mlsdeform::active_isa();
  ~IsaGuard() { mlsdeform::set_isa(saved); }
};

template <class T>
void run_batched(benchmark::State& state, Set set, mlsdeform::Isa isa, RotationMethod method, bool hot, int threads) {
  IsaGuard guard;
  mlsdeform::set_isa(isa);
  const auto& H = soa<T>(set);
  const std::size_t n = H.size() / 9;
  // Validate the whole set (on all cores: untimed), and count the lanes that left the regular path.
  std::vector<T> R(9 * n);
  mlsdeform::BatchStats stats;
  mlsdeform::fit_rotations<T>(H.data(), R.data(), n, method, 0, &stats);
  double worst = 0;
  if (const std::string err = validate_soa<T>(set, R, method, worst); !err.empty()) {
    state.SkipWithError(err.c_str());
    return;
  }
  const std::vector<T> H_hot = hot ? soa_prefix<T>(set, kHotCount) : std::vector<T>();
  const T* in = hot ? H_hot.data() : H.data();
  const std::size_t m = hot ? kHotCount : n;
  for (auto _ : state) {
    mlsdeform::fit_rotations<T>(in, R.data(), m, method, threads);
    benchmark::DoNotOptimize(R.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * m));
  state.counters["ns_per_fit"] = bench::ns_per(static_cast<double>(m));
  state.counters["worst_err_over_tol"] = worst;
  state.counters["lanes_careful"] = static_cast<double>(stats.careful_lanes);
  state.counters["lanes"] = static_cast<double>(mlsdeform::simd_lanes<T>());
}

template <class T>
void register_batched(Set set) {
  const std::vector<mlsdeform::Isa> isas = mlsdeform::supported_isas();
  for (mlsdeform::Isa isa : isas)
    for (RotationMethod m : kBatchedMethods)
      for (bool hot : {false, true}) {
        const std::string name = prefix(set, hot) + type_name<T>() + "/" + std::string(mlsdeform::to_string(m)) +
                                 "/batch:" + std::string(mlsdeform::to_string(isa));
        benchmark::RegisterBenchmark(name.c_str(), [=](benchmark::State& s) {
          run_batched<T>(s, set, isa, m, hot, 1);
        })->Unit(benchmark::kMillisecond);
      }
  // Both cores, best ISA, the paper's method (UseRealTime: TBB workers do the work).
  const mlsdeform::Isa best = isas.back();
  for (bool hot : {false, true}) {
    const std::string name = prefix(set, hot) + type_name<T>() +
                             "/axis_angle/batch:" + std::string(mlsdeform::to_string(best)) +
                             "/threads:" + std::to_string(bench::hardware_threads());
    benchmark::RegisterBenchmark(
        name.c_str(), [=](benchmark::State& s) { run_batched<T>(s, set, best, RotationMethod::axis_angle, hot, 0); })
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
}

}  // namespace

int main(int argc, char** argv) {
  const auto opt = bench::take_options(argc, argv, {"cases", "error_sweep"});
  if (!opt[0].empty()) case_count = std::stoul(opt[0]);
  if (!opt[1].empty()) write_error_sweep(opt[1]);

  for (Set set : kSets) {
    register_scalar<float>(set);
    register_scalar<double>(set);
    register_batched<float>(set);
    register_batched<double>(set);
  }

  const Data& d = data(Set::points);
  std::string isas;
  for (mlsdeform::Isa isa : mlsdeform::supported_isas()) isas += std::string(mlsdeform::to_string(isa)) + " ";
  bench::add_context(
      "fit/*/scalar: fit_rotation (baseline x86-64 flags); fit/*/batch:<isa>: fit_rotations "
      "forced to <isa>; library default: " +
          std::string(mlsdeform::to_string(mlsdeform::active_isa())) + " (supported: " + isas + ")",
      "1 (except names ending threads:N)");
  benchmark::AddCustomContext("cases", std::to_string(d.H_double.size()));
  benchmark::AddCustomContext("cases_det_negative", std::to_string(d.det_negative));
  benchmark::AddCustomContext("case_seed", std::to_string(bench::kCaseSeed));
  return bench::run_benchmarks(argc, argv);
}
