// bench_ring_correlation: the ARAP local step's one-ring sums (the stage ring_correlation, docs/design.md),
// the scalar reference over the CSR one-rings against each ISA's SIMD twin over the padded blocks, in one run,
// on the bundled human after two 1:4 midpoint subdivisions (about 110,000 vertices, bench_arap_solver's
// mesh) and spot_loop3 (737,986 vertices, from ../shared; skipped where absent), on 1 and 2 threads, driven as
// the local step drives them (chunks of 256 vertices on the TBB driver). Each table's H is first checked to
// be bitwise the scalar reference's (SkipWithError otherwise). With step:1, the whole local step (the sums,
// then the active ISA's fit): the scalar sums there are the local step before the sums had a SIMD twin.
// Counter ns_per_vertex; items are vertices. BM_ring_rhs times the global step's rotated sums (the stage
// ring_rhs) likewise, on random R_i^T and c_i (the stage's cost does not depend on their values), each table's b
// checked bitwise against the scalar reference's.
//
// Usage: bench_ring_correlation [--energy=1] [Google Benchmark options]
#include "bench/common.hpp"

#include "core/src/arap/one_rings.hpp"
#include "core/src/arap/ring_correlation.hpp"
#include "core/src/parallel.hpp"
#include "core/src/threading.hpp"
#include "tests/support/meshes.hpp"

#include "kernels/kernel_table.hpp"

#include <mlsdeform/dispatch.hpp>

#include <algorithm>
#include <cstring>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

namespace {

using PointsD = Eigen::Matrix<double, Eigen::Dynamic, 3>;
using mlsdeform::Triangles;
namespace kernels = mlsdeform::kernels;
namespace detail = mlsdeform::detail;

bool with_energy = false;

/// Each triangle into four, new vertices at the edges' midpoints (bench_arap_solver's subdivision).
void subdivide(PointsD& v, Triangles& f) {
  std::map<std::pair<int, int>, int> mid;
  std::vector<Eigen::RowVector3d> added;
  const auto midpoint = [&](int a, int b) {
    const auto key = std::minmax(a, b);
    const auto [it, fresh] = mid.emplace(key, int(v.rows() + Eigen::Index(added.size())));
    if (fresh) added.push_back(0.5 * (v.row(a) + v.row(b)));
    return it->second;
  };
  Triangles g(4 * f.rows(), 3);
  for (Eigen::Index t = 0; t < f.rows(); ++t) {
    const int a = f(t, 0), b = f(t, 1), c = f(t, 2);
    const int ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    g.row(4 * t) << a, ab, ca;
    g.row(4 * t + 1) << ab, b, bc;
    g.row(4 * t + 2) << ca, bc, c;
    g.row(4 * t + 3) << ab, bc, ca;
  }
  const Eigen::Index n = v.rows();
  v.conservativeResize(n + Eigen::Index(added.size()), 3);
  for (std::size_t k = 0; k < added.size(); ++k) v.row(n + Eigen::Index(k)) = added[k];
  f = std::move(g);
}

/// A mesh's one-rings in both layouts, and positions x: the rest pose bent a little (random offsets of a
/// hundredth of the bounding box), in row-major order as the session holds them.
struct Rings {
  std::size_t n = 0;
  detail::OneRings csr;
  std::vector<double> we, x, ring, c;
  detail::PaddedRings padded;
  double padding = 0;  ///< padded slots per directed edge
};

std::unique_ptr<Rings> make_rings(PointsD v, const Triangles& f) {
  auto r = std::make_unique<Rings>();
  const double scale = v.cwiseAbs().maxCoeff();
  v /= scale;
  r->n = std::size_t(v.rows());
  r->csr = detail::cotangent_one_rings(v, f);
  r->we.assign(3 * r->csr.nbr.size(), 0.0);
  for (std::size_t i = 0; i < r->n; ++i)
    for (Eigen::Index e = r->csr.start[i]; e < r->csr.start[i + 1]; ++e)
      for (int k = 0; k < 3; ++k)
        r->we[3 * std::size_t(e) + std::size_t(k)] =
            r->csr.w[std::size_t(e)] * (v(Eigen::Index(i), k) - v(r->csr.nbr[std::size_t(e)], k));
  r->padded = detail::pad_one_rings(r->csr.start, r->csr.nbr, r->csr.w, r->we);
  r->padding = double(r->padded.slot_x.size()) / double(r->csr.nbr.size());
  std::mt19937_64 g(28);
  std::uniform_real_distribution<double> u(-0.01, 0.01);
  r->x.resize(3 * r->n);
  for (std::size_t i = 0; i < r->n; ++i)
    for (int k = 0; k < 3; ++k) r->x[3 * i + std::size_t(k)] = v(Eigen::Index(i), k) + u(g);
  r->ring.assign(10 * r->n, 0.0);
  r->c.resize(3 * r->n);
  for (double& value : r->c) value = u(g);
  return r;
}

const Rings* mesh(int which) {
  static std::unique_ptr<Rings> human, spot;
  static bool spot_tried = false;
  if (which == 0) {
    if (!human) {
      const std::string path = mlsdeform::testing::bundled_mesh("human_man.obj");
      PointsD v = mlsdeform::testing::read_obj_vertices(path);
      Triangles f = mlsdeform::testing::read_obj_triangles(path);
      subdivide(v, f);
      subdivide(v, f);
      human = make_rings(std::move(v), f);
    }
    return human.get();
  }
  if (!spot_tried) {
    spot_tried = true;
    const std::string path = mlsdeform::testing::mesh_dir() + "/spot_loop3.ply.gz";
    if (std::FILE* file = std::fopen(path.c_str(), "rb")) {
      std::fclose(file);
      Triangles f;
      PointsD v = mlsdeform::testing::read_ply_vertices(path, &f);
      spot = make_rings(std::move(v), f);
    }
  }
  return spot.get();
}

const kernels::KernelTable* table(int isa) {
  const mlsdeform::Isa want = mlsdeform::Isa(isa);
  const std::vector<mlsdeform::Isa> runs = mlsdeform::supported_isas();
  if (std::find(runs.begin(), runs.end(), want) == runs.end()) return nullptr;
  switch (want) {  // the architecture's tables only (kernels/CMakeLists.txt)
    case mlsdeform::Isa::scalar:
      return &kernels::kernel_table_scalar();
#if defined(__x86_64__) || defined(__i386__)
    case mlsdeform::Isa::sse4_2:
      return &kernels::kernel_table_sse4_2();
    case mlsdeform::Isa::avx2:
      return &kernels::kernel_table_avx2();
    case mlsdeform::Isa::avx512:
      return &kernels::kernel_table_avx512();
#endif
#if defined(__aarch64__)
    case mlsdeform::Isa::neon:
      return &kernels::kernel_table_neon();
#endif
    default:
      break;
  }
  return nullptr;
}

template <class T>
kernels::RingCorrelationFn<T> entry(const kernels::KernelTable& t) {
  if constexpr (std::is_same_v<T, float>)
    return t.ring_correlation_f;
  else
    return t.ring_correlation_d;
}

template <class T>
kernels::RingCorrelationFn<T> rhs_entry(const kernels::KernelTable& t) {
  if constexpr (std::is_same_v<T, float>)
    return t.ring_rhs_f;
  else
    return t.ring_rhs_d;
}

template <class T>
kernels::FitRotationsFn<T> fit_entry(const kernels::KernelTable& t) {
  if constexpr (std::is_same_v<T, float>)
    return t.fit_axis_angle_f;
  else
    return t.fit_axis_angle_d;
}

/// Args: mesh (0 human, 1 spot), ISA of the sums (mlsdeform::Isa's value), threads, and step: 0 the sums
/// alone, 1 the whole local step as ArapRefiner runs it (without the energy): per chunk the sums, then the
/// active ISA's batched axis/angle fit and R to double, so that the ISA of the sums is the only difference.
template <class T>
void BM_ring_correlation(benchmark::State& state) {
  const Rings* r = mesh(int(state.range(0)));
  const kernels::KernelTable* t = table(int(state.range(1)));
  const int threads = int(state.range(2));
  const bool step = state.range(3) != 0;
  if (!r || !t) {
    state.SkipWithError(!r ? "spot_loop3 not found" : "ISA not on this CPU");
    return;
  }
  const std::size_t n = r->n, blocks = (n + kernels::kLanes - 1) / kernels::kLanes;
  std::vector<T> H(9 * n), ref(9 * n);
  double* ring = with_energy ? const_cast<double*>(r->ring.data()) : nullptr;
  auto frame = [&](std::vector<T>& out) {
    return detail::ring_frame<T>(n, r->x.data(), r->csr.start, r->csr.nbr, r->csr.w, r->we, r->padded, out.data(),
                                 ring);
  };
  entry<T>(kernels::kernel_table_scalar())(frame(ref), 0, blocks);
  const kernels::RingFrame<T> fr = frame(H);
  const kernels::RingCorrelationFn<T> fn = entry<T>(*t);
  fn(fr, 0, blocks);
  if (std::memcmp(H.data(), ref.data(), H.size() * sizeof(T)) != 0) {
    state.SkipWithError("H differs from the scalar reference's");
    return;
  }
  const std::unique_ptr<tbb::task_arena> arena = detail::make_arena(threads);
  constexpr std::size_t grain = 256 / kernels::kLanes;  // the local step's chunk of 256 vertices
  const kernels::FitRotationsFn<T> fit = fit_entry<T>(*table(int(mlsdeform::active_isa())));
  std::vector<T> R(9 * n);
  std::vector<double> Rd(9 * n);
  for (auto _ : state) {
    detail::parallel_ranges((blocks + grain - 1) / grain, threads, arena.get(), [&](std::size_t c0, std::size_t c1) {
      fn(fr, c0 * grain, std::min(blocks, c1 * grain));
      if (!step) return;
      const std::size_t i0 = c0 * grain * kernels::kLanes, i1 = std::min(n, c1 * grain * kernels::kLanes);
      fit(H.data(), R.data(), n, i0, i1, nullptr);
      for (std::size_t i = i0; i < i1; ++i)
        for (std::size_t k = 0; k < 9; ++k) Rd[9 * i + k] = double(R[k * n + i]);
    });
    benchmark::DoNotOptimize(H.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(std::int64_t(state.iterations()) * std::int64_t(n));
  state.counters["ns_per_vertex"] = bench::ns_per(double(n));
  state.counters["padded_slots_per_edge"] = r->padding;
  state.SetLabel(std::string(t->name) + (step ? " sums, local step" : " sums") + (with_energy ? ", with energy" : ""));
}

/// Args: mesh (0 human, 1 spot), ISA (mlsdeform::Isa's value), threads: ring_rhs over the mesh in the global
/// step's chunks of 256 vertices.
template <class T>
void BM_ring_rhs(benchmark::State& state) {
  const Rings* r = mesh(int(state.range(0)));
  const kernels::KernelTable* t = table(int(state.range(1)));
  const int threads = int(state.range(2));
  if (!r || !t) {
    state.SkipWithError(!r ? "spot_loop3 not found" : "ISA not on this CPU");
    return;
  }
  const std::size_t n = r->n, blocks = (n + kernels::kLanes - 1) / kernels::kLanes;
  std::vector<T> Rt(9 * n + 1);  // + 1: RingFrame::R's padding
  std::mt19937_64 g(29);
  std::uniform_real_distribution<double> u(-1, 1);
  for (T& v : Rt) v = T(u(g));
  std::vector<double> b(3 * n), ref(3 * n);
  auto frame = [&](std::vector<double>& out) {
    return detail::ring_frame<T>(n, r->x.data(), r->csr.start, r->csr.nbr, r->csr.w, r->we, r->padded, nullptr, nullptr,
                                 Rt.data(), r->c.data(), out.data());
  };
  const kernels::RingCorrelationFn<T> fn = rhs_entry<T>(*t);
  rhs_entry<T>(kernels::kernel_table_scalar())(frame(ref), 0, blocks);
  const kernels::RingFrame<T> fr = frame(b);
  fn(fr, 0, blocks);
  if (std::memcmp(b.data(), ref.data(), b.size() * sizeof(double)) != 0) {
    state.SkipWithError("b differs from the scalar reference's");
    return;
  }
  const std::unique_ptr<tbb::task_arena> arena = detail::make_arena(threads);
  constexpr std::size_t grain = 256 / kernels::kLanes;  // the global step's chunk of 256 vertices
  for (auto _ : state) {
    detail::parallel_ranges((blocks + grain - 1) / grain, threads, arena.get(),
                            [&](std::size_t c0, std::size_t c1) { fn(fr, c0 * grain, std::min(blocks, c1 * grain)); });
    benchmark::DoNotOptimize(b.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(std::int64_t(state.iterations()) * std::int64_t(n));
  state.counters["ns_per_vertex"] = bench::ns_per(double(n));
  state.SetLabel(std::string(t->name) + " rotated sums");
}

void args(benchmark::internal::Benchmark* b) {
  for (int m : {0, 1})
    for (const mlsdeform::Isa isa : {mlsdeform::Isa::scalar, mlsdeform::Isa::sse4_2, mlsdeform::Isa::avx2,
                                     mlsdeform::Isa::avx512, mlsdeform::Isa::neon})
      for (int threads : {1, 2})
        for (int step : {0, 1}) b->Args({m, int(isa), threads, step});
  b->ArgNames({"mesh", "isa", "threads", "step"});
}

BENCHMARK_TEMPLATE(BM_ring_correlation, double)->Apply(args)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_ring_correlation, float)->Apply(args)->UseRealTime()->Unit(benchmark::kMillisecond);

void rhs_args(benchmark::internal::Benchmark* b) {
  for (int m : {0, 1})
    for (const mlsdeform::Isa isa : {mlsdeform::Isa::scalar, mlsdeform::Isa::sse4_2, mlsdeform::Isa::avx2,
                                     mlsdeform::Isa::avx512, mlsdeform::Isa::neon})
      for (int threads : {1, 2}) b->Args({m, int(isa), threads});
  b->ArgNames({"mesh", "isa", "threads"});
}
BENCHMARK_TEMPLATE(BM_ring_rhs, float)->Apply(rhs_args)->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> o = bench::take_options(argc, argv, {"energy"});
  with_energy = o[0] == "1";
  bench::add_context(mlsdeform::to_string(mlsdeform::active_isa()), "1, 2");
  return bench::run_benchmarks(argc, argv);
}
