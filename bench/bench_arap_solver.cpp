// bench_arap_solver: the ARAP global step's factorisations side by side, in one run, on the two large meshes
// of issue "converged ARAP at interactive rates": spot_loop3 (737,986 vertices, from ../shared; skipped where
// absent) and the bundled human after two 1:4 midpoint subdivisions (Loop's connectivity, its positions not
// smoothed: about 110,000 vertices). The 1% lowest vertices are held, the highest moved along x by a tenth of
// the height.
//
// Per mesh, the reduced cotangent Laplacian of the free vertices (as ArapRefiner builds it) is factorised by
// each method the build has, and per method the program prints: the ordering and factorisation time s
// (SubtreeLdlt::compute, the substitution's schedule included), entries of L (millions), the factor's bytes
// (MiB), the peak RSS during ArapRefiner's set-up (GiB, /proc/self/status's VmHWM reset just before; it
// includes the mesh and this program's copy of the matrix), the substitution for three right-hand sides (ms:
// SubtreeLdlt::solve, the median of 7; again on one thread in its CPU time, which other load disturbs less),
// and with ArapRefiner: the whole set-up s and the ms per iteration (median of 3
// refine calls of 10 iterations, divided by 10). MUMPS (Debian's libmumps-seq-dev, CeCILL-C; where CMake found it)
// factorises the same matrix, with its own ordering choice, and solves the same three right-hand sides: it is measured
// here only, never linked into the library.
//
// Usage: bench_arap_solver [--threads N] [--mesh spot|human] [--supernodal-only] (the last skips the simplicial
// factorisation and MUMPS, the slow ones)
#include "core/src/arap/one_rings.hpp"
#include "core/src/arap/subtree_ldlt.hpp"
#include "tests/support/meshes.hpp"

#include <mlsdeform/arap.hpp>

#ifdef MLSDEFORM_HAVE_MUMPS
#include <dmumps_c.h>
#endif

#include <tbb/info.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace {

using PointsD = Eigen::Matrix<double, Eigen::Dynamic, 3>;
using Clock = std::chrono::steady_clock;
using mlsdeform::Triangles;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
double thread_cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

// /proc/self/status's field `key` (kB) in GiB; 0 where unreadable.
double status_gib(const std::string& key) {
  std::ifstream f("/proc/self/status");
  for (std::string line; std::getline(f, line);)
    if (line.rfind(key + ":", 0) == 0) return std::atof(line.c_str() + key.size() + 1) / (1024.0 * 1024.0);
  return 0;
}
void reset_peak() { std::ofstream("/proc/self/clear_refs") << "5"; }

/// Each triangle into four, new vertices at the edges' midpoints (shared between the two triangles).
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

struct Scene {
  std::string name;
  PointsD v;
  Triangles f;
  std::vector<Eigen::Index> held;  ///< the last one is moved
  PointsD targets;
};

Scene make_scene(std::string name, PointsD v, Triangles f) {
  Scene s{std::move(name), std::move(v), std::move(f), {}, {}};
  std::vector<Eigen::Index> by_height(std::size_t(s.v.rows()));
  for (Eigen::Index i = 0; i < s.v.rows(); ++i) by_height[std::size_t(i)] = i;
  // Ties broken by index: std::stable_sort's order, without its temporary buffer (std::get_temporary_buffer,
  // deprecated: clang warns inside Debian 12's libstdc++).
  std::sort(by_height.begin(), by_height.end(),
            [&](Eigen::Index a, Eigen::Index b) { return std::pair(s.v(a, 1), a) < std::pair(s.v(b, 1), b); });
  s.held.assign(by_height.begin(), by_height.begin() + s.v.rows() / 100);
  s.held.push_back(by_height.back());
  s.targets.resize(Eigen::Index(s.held.size()), 3);
  for (std::size_t k = 0; k < s.held.size(); ++k) s.targets.row(Eigen::Index(k)) = s.v.row(s.held[k]);
  s.targets(s.targets.rows() - 1, 0) += 0.1 * (s.v(by_height.back(), 1) - s.v(by_height.front(), 1));
  return s;
}

/// The reduced Laplacian of the free vertices (every vertex not held; the meshes are connected) and their
/// points, as ArapRefiner builds them.
void reduced_laplacian(const Scene& s, Eigen::SparseMatrix<double>& L, PointsD& points) {
  const mlsdeform::detail::OneRings r = mlsdeform::detail::cotangent_one_rings(s.v, s.f);
  std::vector<Eigen::Index> row(std::size_t(s.v.rows()), 0);
  for (const Eigen::Index h : s.held) row[std::size_t(h)] = -1;
  Eigen::Index nf = 0;
  for (Eigen::Index& x : row) x = x < 0 ? -1 : nf++;
  std::vector<Eigen::Triplet<double>> t;
  points.resize(nf, 3);
  for (std::size_t i = 0; i < row.size(); ++i) {
    if (row[i] < 0) continue;
    points.row(row[i]) = s.v.row(Eigen::Index(i));
    double diag = 0;
    for (Eigen::Index e = r.start[i]; e < r.start[i + 1]; ++e) {
      diag += r.w[std::size_t(e)];
      const Eigen::Index j = row[std::size_t(r.nbr[std::size_t(e)])];
      if (j >= 0) t.emplace_back(row[i], j, -r.w[std::size_t(e)]);
    }
    t.emplace_back(row[i], row[i], diag);
  }
  L.resize(nf, nf);
  L.setFromTriplets(t.begin(), t.end());
  L.makeCompressed();
}

double median(std::vector<double> x) {
  std::sort(x.begin(), x.end());
  return x[x.size() / 2];
}

#ifdef MLSDEFORM_HAVE_MUMPS
void run_mumps(const Eigen::SparseMatrix<double>& L, const Eigen::MatrixX3d& b) {
  DMUMPS_STRUC_C id{};
  id.comm_fortran = -987654;  // MUMPS's USE_COMM_WORLD (the sequential library ignores it)
  id.par = 1, id.sym = 1;     // symmetric positive definite
  id.job = -1;
  dmumps_c(&id);
  id.icntl[0] = id.icntl[1] = id.icntl[2] = id.icntl[3] = 0;  // quiet
  std::vector<MUMPS_INT> irn, jcn;
  std::vector<double> a;
  for (Eigen::Index c = 0; c < L.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, c); it; ++it)
      if (it.row() >= c)
        irn.push_back(MUMPS_INT(it.row() + 1)), jcn.push_back(MUMPS_INT(c + 1)), a.push_back(it.value());
  id.n = MUMPS_INT(L.rows());
  id.nnz = MUMPS_INT8(a.size());
  id.irn = irn.data(), id.jcn = jcn.data(), id.a = a.data();
  reset_peak();  // MUMPS's peak RSS: the factorisation's
  auto t0 = Clock::now();
  id.job = 4;  // analysis and factorisation
  dmumps_c(&id);
  const double factor_s = seconds_since(t0), peak = status_gib("VmHWM");
  if (id.infog[0] < 0) {
    std::printf("| MUMPS | failed: INFOG(1) = %d | | | | | | |\n", int(id.infog[0]));
  } else {
    std::vector<double> rhs(std::size_t(b.size()));
    std::vector<double> ms;
    for (int r = 0; r < 7; ++r) {
      std::memcpy(rhs.data(), b.data(), sizeof(double) * rhs.size());  // column-major n x 3
      id.rhs = rhs.data(), id.nrhs = 3, id.lrhs = id.n;
      id.job = 3;
      t0 = Clock::now();
      dmumps_c(&id);
      ms.push_back(1e3 * seconds_since(t0));
    }
    // INFOG(29): entries in the factors (negative: millions); RINFOG(...) not needed.
    const double entries = id.infog[28] < 0 ? -double(id.infog[28]) : double(id.infog[28]) / 1e6;
    std::printf("| MUMPS 5.5 (ordering ICNTL(7) = auto: %d) | %.2f | %.1f | %.0f | %.2f | %.1f | - | - | - |\n",
                int(id.infog[6]), factor_s, entries, double(id.infog[21]), peak, median(ms));
  }
  id.job = -2;
  dmumps_c(&id);
}
#endif

void run_scene(const Scene& s, int threads, bool supernodal_only) {
  std::printf("\n### %s: %lld vertices, %lld triangles, %zu held\n\n", s.name.c_str(),
              static_cast<long long>(s.v.rows()), static_cast<long long>(s.f.rows()), s.held.size());
  Eigen::SparseMatrix<double> L;
  PointsD points;
  reduced_laplacian(s, L, points);
  Eigen::MatrixX3d b = Eigen::MatrixX3d::Random(L.rows(), 3);
  std::printf(
      "| factorisation | factorise s | entries of L (M) | factor MiB | peak RSS GiB | substitution ms | substitution "
      "CPU ms, 1 thread | ARAP set-up s | ms per iteration |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  using F = mlsdeform::ArapFactorisation;
  using Method = mlsdeform::detail::SubtreeLdlt::Method;
  struct Variant {
    const char* name;
    Method method;
    F factorisation;
  };
  std::vector<Variant> variants{{"supernodal_mit (ours, MIT)", Method::supernodal_mit, F::supernodal_mit}};
  if (mlsdeform::supernodal_factorisation_available())
    variants.push_back({"supernodal (CHOLMOD, GPL)", Method::supernodal, F::supernodal});
  if (!supernodal_only) variants.push_back({"simplicial (Eigen)", Method::simplicial, F::simplicial});
  const int cores = tbb::info::default_concurrency();
  const std::size_t bins = threads == 1 ? 1 : std::size_t(threads == 0 ? cores : std::min(threads, cores));
  for (const Variant& v : variants) {
    double factor_s = 0, peak = 0, mib = 0, entries = 0, solve_ms = 0, solve_cpu_ms = 0;
    {
      const auto t0 = Clock::now();
      mlsdeform::detail::SubtreeLdlt solver;
      if (!solver.compute(L, bins, v.method, &points)) {
        std::printf("| %s | failed | | | | | | |\n", v.name);
        continue;
      }
      factor_s = seconds_since(t0);
      mib = double(solver.memory_bytes()) / (1024.0 * 1024.0);
      entries = double(solver.entries()) / 1e6;
      std::vector<double> y(3 * std::size_t(L.rows())), ms;
      for (int r = 0; r < 7; ++r) {
        for (Eigen::Index i = 0; i < L.rows(); ++i)
          for (int k = 0; k < 3; ++k) y[3 * std::size_t(solver.row_of(i)) + std::size_t(k)] = b(i, k);
        const auto t1 = Clock::now();
        solver.solve(y, threads, nullptr);
        ms.push_back(1e3 * seconds_since(t1));
      }
      solve_ms = median(ms);
      ms.clear();
      for (int r = 0; r < 7; ++r) {  // the same on one thread, in CPU time (less sensitive to other load)
        for (Eigen::Index i = 0; i < L.rows(); ++i)
          for (int k = 0; k < 3; ++k) y[3 * std::size_t(solver.row_of(i)) + std::size_t(k)] = b(i, k);
        const double c0 = thread_cpu_s();
        solver.solve(y, 1, nullptr);
        ms.push_back(1e3 * (thread_cpu_s() - c0));
      }
      solve_cpu_ms = median(ms);
    }
    const mlsdeform::Points<float> rest = s.v.cast<float>(), targets = s.targets.cast<float>();
    reset_peak();
    const auto t0 = Clock::now();
    mlsdeform::ArapRefiner<float> session(rest, s.f, s.held, mlsdeform::ArapOptions{threads, v.factorisation});
    const double setup_s = seconds_since(t0);
    peak = status_gib("VmHWM");
    mlsdeform::Points<float> out;
    session.refine(rest, targets, 1, out);  // warm-up
    std::vector<double> it_ms;
    for (int r = 0; r < 3; ++r) {
      const auto t = Clock::now();
      session.refine(rest, targets, 10, out);
      it_ms.push_back(1e2 * seconds_since(t));
    }
    std::printf("| %s | %.2f | %.1f | %.0f | %.2f | %.1f | %.1f | %.2f | %.1f |\n", v.name, factor_s, entries, mib,
                peak, solve_ms, solve_cpu_ms, setup_s, median(it_ms));
    std::fflush(stdout);
  }
#ifdef MLSDEFORM_HAVE_MUMPS
  if (!supernodal_only) run_mumps(L, b);
#else
  std::printf("\n(MUMPS not found at configure time: its row is skipped.)\n");
#endif
}

}  // namespace

int main(int argc, char** argv) {
  int threads = 0;
  bool supernodal_only = false;
  std::string only;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    if (arg == "--threads" && a + 1 < argc)
      threads = std::atoi(argv[++a]);
    else if (arg == "--mesh" && a + 1 < argc)
      only = argv[++a];
    else if (arg == "--supernodal-only")
      supernodal_only = true;
    else {
      std::fprintf(stderr, "usage: bench_arap_solver [--threads N] [--mesh spot|human] [--supernodal-only]\n");
      return 2;
    }
  }
  if (only.empty() || only == "human") {
    const std::string path = mlsdeform::testing::bundled_mesh("human_man.obj");
    PointsD v = mlsdeform::testing::read_obj_vertices(path);
    Triangles f = mlsdeform::testing::read_obj_triangles(path);
    subdivide(v, f);
    subdivide(v, f);
    run_scene(make_scene("human_man.obj, two 1:4 subdivisions", std::move(v), std::move(f)), threads, supernodal_only);
  }
  if (only.empty() || only == "spot") {
    const std::string path = mlsdeform::testing::mesh_dir() + "/spot_loop3.ply.gz";
    if (!std::ifstream(path)) {
      std::printf("\nspot_loop3: %s not found: skipped\n", path.c_str());
    } else {
      Triangles f;
      PointsD v = mlsdeform::testing::read_ply_vertices(path, &f);
      run_scene(make_scene("spot_loop3.ply.gz", std::move(v), std::move(f)), threads, supernodal_only);
    }
  }
  return 0;
}
