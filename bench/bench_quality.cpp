// bench_quality: how rigid the deformed surface is, not how fast the rotations are. On the same meshes and
// handles it runs MLS (rigid, u = 2), MLS followed by k surface-ARAP iterations (mlsdeform::ArapRefiner
// through Deformer's arap_iterations) and, where CMake found CGAL, CGAL's Surface_mesh_deformation
// (ORIGINAL_ARAP) with its default 5 iterations and until converged, and prints one markdown table per scene:
//
//   tool | ms per frame | rigidity median / p95 | edge ratio p1 / p99 | flipped
//
// The measures are tests/support/quality.hpp's: local rigidity per vertex (RMS relative error of its
// one-ring edges after their best rotation; 0 = locally rigid), deformed / rest edge length over all edges,
// and triangles whose deformed normal points against their rest normal turned by the ring rotations of at
// least two of their corners. Quantiles interpolate between ranks.
//
// ms per frame: the median over repeated calls (at least 3, and at least --min-time seconds in all) of one
// frame from the rest pose with the scene's targets, after one untimed warm-up call: everything that depends
// on the rest pose only (MLS weights, the ARAP and CGAL factorisations) is set up before and not timed.
// mlsdeform runs on --threads threads (0: all cores); CGAL's deformation runs on one.
//
// --centroids prints instead one table per scene (with the Fig. 8 plane first) comparing the centroids q*:
// Options::centroids = mls (eq. 2) against Centroids::rbf with each radial kernel of
// core/src/deformer/rbf_centroids.hpp (phi = r and r^3, both with a linear polynomial; the library's is set
// there, by these numbers):
//
//   centroids | ms per frame | setup ms | kappa(M) | rigidity median / p95 | dihedral change median / p95 / max |
//   flipped
//
// setup ms: one construction of the Deformer (the RBF weights are solved there, so the per-frame cost is
// the same); kappa(M): the 2-norm condition number of the interpolant's matrix in the deformer's local frame
// (singular values, double); dihedral change: per interior edge, in degrees (quality.hpp; the measure of
// Fig. 8, whose figure takes nearest-rank quantiles where these interpolate).
//
// Last, the conditioning table: the interpolant's matrix M for the Bar's two end caps as handles, the caps
// cut into n x n cells (16 x 16 is the bar scene's), per kernel: kappa(M) and the LU's estimated reciprocal
// condition, which core/src/deformer/rbf_centroids.cpp refuses below 1e-10.
//
// Last in the default run, the cost of ARAP on the 737,986-vertex spot_loop3 (from ../shared; skipped with a
// message where it is absent), for each factorisation the build has (ArapFactorisation): set-up s (one
// ArapRefiner construction: the Laplacian and its factorisation),
// held MiB (ArapRefiner::memory_bytes), peak RSS GiB (the process's high-water mark, reset just before the
// construction through /proc/self/clear_refs: it includes the mesh itself, about 0.05 GiB), and ms per
// iteration (the median of 3 refine calls of 10 iterations from the rest pose, divided by 10).
//
// A plain program rather than Google Benchmark: each row needs its result measured once and one time, not a
// timing loop per benchmark. Usage:
//   bench_quality [--threads N] [--min-time S] [--precision float|double] [--json FILE] [--centroids | --arap]
#include "bench/common.hpp"
#include "bench/quality.hpp"

#ifdef MLSDEFORM_HAVE_CGAL
#include "bench/quality_cgal.hpp"

#include <CGAL/version.h>
#endif

#include <mlsdeform/dispatch.hpp>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace {

using namespace bench::quality;

template <class T>
std::vector<Row> mls_rows(const QualityScene& s, const Settings& set) {
  std::vector<Row> rows;
  const Points<T> rest = s.rest.cast<T>();
  Handles<T> rest_handles, moved;
  rest_handles.points = rows_of(s.rest, s.handles).cast<T>();
  moved.points = s.targets.cast<T>();
  mlsdeform::Options o;  // rigid, u = 2
  o.threads = set.threads;
  Points<T> out;
  auto add = [&](const std::string& tool, const mlsdeform::Deformer<T>& d) {
    Row r;
    r.tool = tool;
    r.ms = ms_per_frame([&] { d.deform(moved, out); }, set.min_time);
    const PointsD x = out.template cast<double>();
    check_handles(s, tool, x);
    r.quality = mlsdeform::testing::shape_quality(s.rest, x, s.triangles);
    rows.push_back(std::move(r));
  };
  add("MLS (rigid, u = 2)", mlsdeform::Deformer<T>(rest, rest_handles, o));
  // The handles sit on vertices, so ARAP holds exactly those vertices, at their targets (where MLS puts them).
  for (const int k : {1, 2, 5, 10}) {
    o.arap_iterations = k;
    add("MLS + " + std::to_string(k) + " ARAP", mlsdeform::Deformer<T>(rest, s.triangles, rest_handles, o));
  }
  return rows;
}

#ifdef MLSDEFORM_HAVE_CGAL
std::vector<Row> cgal_rows(const QualityScene& s, const Settings& set) {
  std::vector<Row> rows;
  bench::CgalArap cgal(s.rest, s.triangles, s.handles);
  if (cgal.refused_faces() > 0)
    std::printf("(CGAL's Surface_mesh refused %lld non-manifold faces of %s)\n",
                static_cast<long long>(cgal.refused_faces()), s.name.c_str());
  PointsD out;
  auto add = [&](const std::string& tool, unsigned iterations, double tolerance) {
    Row r;
    r.tool = tool;
    r.ms = ms_per_frame([&] { cgal.deform(s.targets, iterations, tolerance, out); }, set.min_time);
    check_handles(s, tool, out);
    r.quality = mlsdeform::testing::shape_quality(s.rest, out, s.triangles);
    rows.push_back(std::move(r));
  };
  // CGAL's defaults: 5 iterations, stopping early at a relative energy change below 1e-4.
  add("CGAL ARAP, default (5 it.)", 5, 1e-4);
  // Until the relative energy change falls below 1e-6, at most 500 iterations. CGAL tests the change only
  // before its last iteration, so a run of all 500 stopped at the cap, not converged.
  constexpr unsigned cap = 500;
  const unsigned ran = cgal.iterations_run(s.targets, cap, 1e-6);
  const std::string label = ran == 0     ? "CGAL ARAP, to 1e-6 or 500 it. (count unknown)"
                            : ran == cap ? "CGAL ARAP, 500 it. (cap: energy change still > 1e-6)"
                                         : "CGAL ARAP, converged to 1e-6 (" + std::to_string(ran) + " it.)";
  add(label, cap, 1e-6);
  return rows;
}
#endif

int run(const Settings& set) {
  std::printf("bench_quality: CPU %s (%s), library ISA %s, %d threads (0 = all %d cores; CGAL: 1), %s\n",
              bench::cpu_model().c_str(), bench::cpu_isa().c_str(),
              std::string(mlsdeform::to_string(mlsdeform::active_isa())).c_str(), set.threads,
              bench::hardware_threads(), set.use_double ? "double" : "float");
#ifdef MLSDEFORM_HAVE_CGAL
  if (!set.centroids)
    std::printf("CGAL %s: Surface_mesh_deformation, ORIGINAL_ARAP, whole mesh as region of interest\n",
                CGAL_VERSION_STR);
#else
  if (!set.centroids) std::printf("CGAL not found: skipped\n");
#endif
  std::vector<QualityScene> scenes;
  if (set.centroids) scenes.push_back(plane_row_scene());
  scenes.push_back(human_scene());
  scenes.push_back(bar_scene());
  if (auto fish = fish_scene())
    scenes.push_back(std::move(*fish));
  else
    std::printf("fish: %s/fish.obj not found: skipped\n", mlsdeform::testing::mesh_dir().c_str());

  std::vector<std::string> json;
  if (set.arap) json = set.use_double ? arap_section<double>(scenes, set) : arap_section<float>(scenes, set);
  for (const QualityScene& s : scenes) {
    if (set.arap) break;
    if (set.centroids) {
      for (std::string& row : centroid_section(s, set)) json.push_back(std::move(row));
      continue;
    }
    std::vector<Row> rows = set.use_double ? mls_rows<double>(s, set) : mls_rows<float>(s, set);
#ifdef MLSDEFORM_HAVE_CGAL
    for (Row& r : cgal_rows(s, set)) rows.push_back(std::move(r));
#endif
    print_table(s, rows);
    for (const Row& r : rows) json.push_back(json_row(s, r));
  }
  if (set.centroids) {
    print_conditioning_table();
  } else if (!set.arap) {
    for (std::string& row : set.use_double ? print_large_arap<double>(set) : print_large_arap<float>(set))
      json.push_back(std::move(row));
  }
  if (!set.json.empty()) {
    std::ofstream out(set.json);
    out << "[\n";
    for (std::size_t i = 0; i < json.size(); ++i) out << "  " << json[i] << (i + 1 < json.size() ? ",\n" : "\n");
    out << "]\n";
    if (!out) throw std::runtime_error("cannot write " + set.json);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Settings set;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--threads" && has_value) {
      set.threads = std::atoi(argv[++i]);
    } else if (a == "--min-time" && has_value) {
      set.min_time = std::atof(argv[++i]);
    } else if (a == "--precision" && has_value &&
               (std::string(argv[i + 1]) == "float" || std::string(argv[i + 1]) == "double")) {
      set.use_double = std::string(argv[++i]) == "double";
    } else if (a == "--json" && has_value) {
      set.json = argv[++i];
    } else if (a == "--centroids") {
      set.centroids = true;
    } else if (a == "--arap") {
      set.arap = true;
    } else {
      std::fprintf(stderr,
                   "usage: %s [--threads N] [--min-time S] [--precision float|double] [--json FILE] "
                   "[--centroids | --arap]\n",
                   argv[0]);
      return 2;
    }
  }
  try {
    return run(set);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_quality: %s\n", e.what());
    return 1;
  }
}
