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
//   bench_quality [--threads N] [--min-time S] [--precision float|double] [--json FILE] [--centroids]
#include "bench/common.hpp"
#include "tests/support/meshes.hpp"
#include "tests/support/quality.hpp"

#ifdef MLSDEFORM_HAVE_CGAL
#include "bench/quality_cgal.hpp"

#include <CGAL/version.h>
#endif

#include "core/src/deformer/local_frame.hpp"
#include "core/src/deformer/rbf_centroids.hpp"

#include <mlsdeform/arap.hpp>
#include <mlsdeform/deformer.hpp>
#include <mlsdeform/dispatch.hpp>

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using mlsdeform::Handles;
using mlsdeform::Points;
using mlsdeform::Triangles;
using mlsdeform::testing::PointsD;
using mlsdeform::testing::ShapeQuality;

struct Settings {
  int threads = 0;
  double min_time = 0.5;
  bool use_double = false;
  bool centroids = false;
  std::string json;
};

// A triangle mesh with point handles at some of its vertices, each moved to its target.
struct QualityScene {
  std::string name, description;
  PointsD rest;
  Triangles triangles;
  std::vector<Eigen::Index> handles;  // vertex indices
  PointsD targets;                    // targets.row(k) for handles[k]
};

struct Row {
  std::string tool;
  double ms = 0;
  ShapeQuality quality;
};

PointsD rows_of(const PointsD& p, const std::vector<Eigen::Index>& idx) {
  PointsD q(static_cast<Eigen::Index>(idx.size()), 3);
  for (std::size_t k = 0; k < idx.size(); ++k) q.row(static_cast<Eigen::Index>(k)) = p.row(idx[k]);
  return q;
}

// Fig. 8's plane (tools/cli/scenes.cpp, plane_row_scene): 33 x 33 vertices over 2 x 2 in the xz plane, each
// quad cut into two triangles as the program's fan does, the two side columns held and a row of 5 handles in
// the middle raised by half the plane's size.
QualityScene plane_row_scene() {
  constexpr int n = 32;
  constexpr double size = 2.0;
  QualityScene s;
  s.rest.resize((n + 1) * (n + 1), 3);
  for (int k = 0; k <= n; ++k)
    for (int i = 0; i <= n; ++i) s.rest.row(k * (n + 1) + i) << -size / 2 + size * i / n, 0, -size / 2 + size * k / n;
  s.triangles.resize(2 * n * n, 3);
  const auto at = [&](int i, int k) { return k * (n + 1) + i; };
  for (int k = 0; k < n; ++k)
    for (int i = 0; i < n; ++i) {
      const int a = at(i, k), b = at(i + 1, k), c = at(i + 1, k + 1), d = at(i, k + 1), f = 2 * (k * n + i);
      s.triangles.row(f) << d, c, b;
      s.triangles.row(f + 1) << d, b, a;
    }
  for (int k = 0; k <= n; ++k) s.handles.insert(s.handles.end(), {at(0, k), at(n, k)});
  const auto fixed = static_cast<Eigen::Index>(s.handles.size());
  for (int k = n / 2 - 8; k <= n / 2 + 8; k += 4) s.handles.push_back(at(n / 2, k));
  s.targets = rows_of(s.rest, s.handles);
  s.targets.bottomRows(s.targets.rows() - fixed).col(1).array() += 0.5 * size;
  s.name = "plane";
  s.description =
      "Fig. 8: plane 33 x 33 (the paper's Plane), both side columns held, a row of 5 handles raised by "
      "half the plane's size (" +
      std::to_string(s.handles.size()) + " point handles)";
  return s;
}

// (a) data/human_man.obj bending forward: the navel and both feet (toes, heels) held where they are, the head
// and both hands moved (data/human_bend.json's last frame, with the left foot's segment as two points).
QualityScene human_scene() {
  QualityScene s;
  const std::string path = mlsdeform::testing::bundled_mesh("human_man.obj");
  s.rest = mlsdeform::testing::read_obj_vertices(path);
  s.triangles = mlsdeform::testing::read_obj_triangles(path);
  s.handles = {1337, 3215, 3386, 6618, 6786, 411, 5906, 2445};
  s.targets.resize(8, 3);
  s.targets << 0.007005, 1.053843, 0.171833,  // navel
      0.078112, 0.019384, 0.180523,           // right toes
      0.095968, 0.039844, -0.085711,          // right heel
      -0.086231, 0.01583, 0.179475,           // left toes
      -0.098815, 0.041748, -0.090276,         // left heel
      0.00213, 1.38829, 0.68933,              // top of the head
      -0.3, 0.55, 0.45,                       // left hand
      0.3, 0.55, 0.45;                        // right hand
  s.name = "human";
  s.description =
      "data/human_man.obj bending forward, hands to the knees: navel and feet fixed, head and hands "
      "moved (8 point handles at vertices 1337, 3215, 3386, 6618, 6786, 411, 5906, 2445)";
  return s;
}

// (b) The paper's Bar (Table 2: 16 x 16 x 88 unit cells, 6,146 surface vertices), both end caps' vertices as
// handles, the cap at z = 88 turned 135 degrees about the bar's axis. Short of 180 degrees, where the middle
// of the bar sees its two ends' rotations cancel and the best rotation there is not unique.
QualityScene bar_scene() {
  constexpr int a = 16, b = 16, c = 88;
  constexpr double degrees = 135;
  QualityScene s;
  s.rest = mlsdeform::testing::box_surface(a, b, c);
  s.triangles = mlsdeform::testing::box_surface_triangles(a, b, c);
  std::vector<Eigen::Index> top;
  for (Eigen::Index i = 0; i < s.rest.rows(); ++i) {
    if (s.rest(i, 2) == 0) s.handles.push_back(i);
    if (s.rest(i, 2) == c) top.push_back(i);
  }
  const auto fixed = static_cast<Eigen::Index>(s.handles.size());
  s.handles.insert(s.handles.end(), top.begin(), top.end());
  s.targets = rows_of(s.rest, s.handles);
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(degrees * std::numbers::pi / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d axis(a / 2.0, b / 2.0, 0);
  for (Eigen::Index k = fixed; k < s.targets.rows(); ++k)
    s.targets.row(k) = (R * (s.targets.row(k).transpose() - axis) + axis).transpose();
  s.name = "bar";
  s.description = "box surface 16 x 16 x 88 (the paper's Bar), " + std::to_string(s.handles.size()) +
                  " point handles (both end caps' vertices), the cap at z = 88 twisted 135 degrees about the axis";
  return s;
}

// (c) ../shared/data/meshes/fish.obj (Keenan Crane's Blub): the mouth and the top of the back held, the two
// tips of the tail fin turned 45 degrees about the vertical (y) axis through the tail's narrowest section
// (x = 3.34, z = -1.0): a tail flick that bends the fish where it is thinnest.
std::optional<QualityScene> fish_scene() {
  const std::string path = mlsdeform::testing::shared_mesh("fish.obj");
  if (path.empty()) return std::nullopt;
  QualityScene s;
  s.rest = mlsdeform::testing::read_obj_vertices(path);
  s.triangles = mlsdeform::testing::read_obj_triangles(path);
  if (s.rest.rows() != 10786)
    throw std::runtime_error(path + ": expected the 10,786-vertex fish, got " + std::to_string(s.rest.rows()));
  s.handles = {9329, 2932, 8815, 9563};  // mouth (largest z), top of the back (largest y), tail tips (upper, lower)
  s.targets = rows_of(s.rest, s.handles);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(std::numbers::pi / 4, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d pivot(3.34, 0, -1.0);
  for (Eigen::Index k = 2; k < 4; ++k)
    s.targets.row(k) = (R * (s.targets.row(k).transpose() - pivot) + pivot).transpose();
  s.name = "fish";
  s.description =
      "../shared/data/meshes/fish.obj, tail flicked 45 degrees: mouth (vertex 9329) and back (2932) "
      "fixed, tail-fin tips (8815, 9563) turned about the vertical axis through the tail's waist";
  return s;
}

// The median of the times of `frame` (ms): one untimed warm-up call, then at least 3 calls and at least
// `min_time` seconds.
double ms_per_frame(const std::function<void()>& frame, double min_time) {
  using Clock = std::chrono::steady_clock;
  frame();
  std::vector<double> ms;
  double total = 0;
  while (ms.size() < 3 || total < min_time) {
    const auto t0 = Clock::now();
    frame();
    const double s = std::chrono::duration<double>(Clock::now() - t0).count();
    ms.push_back(1e3 * s);
    total += s;
  }
  return mlsdeform::testing::quantile(ms, 0.5);
}

// Every handle vertex must end at its target (MLS interpolates its handles, ARAP and CGAL hold them): a
// row that does not is a broken run, not a quality figure.
void check_handles(const QualityScene& s, const std::string& tool, const PointsD& x) {
  const double size = (s.rest.colwise().maxCoeff() - s.rest.colwise().minCoeff()).norm();
  for (std::size_t k = 0; k < s.handles.size(); ++k) {
    const double err = (x.row(s.handles[k]) - s.targets.row(static_cast<Eigen::Index>(k))).norm();
    // float coordinates carry ~1e-7 relative rounding; 1e-4 of the model's size is far above that and far
    // below any deformation shown here.
    if (!(err <= 1e-4 * size))
      throw std::runtime_error(s.name + ", " + tool + ": handle at vertex " + std::to_string(s.handles[k]) + " ends " +
                               std::to_string(err) + " from its target");
  }
}

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

struct CentroidRow {
  std::string centroids;
  double ms = 0, setup_ms = 0, kappa = 0;  // kappa 0: no RBF system (MLS centroids)
  ShapeQuality quality;
  std::vector<double> dihedral;
};

template <class T>
std::vector<CentroidRow> centroid_rows(const QualityScene& s, const Settings& set) {
  using mlsdeform::detail::RbfKernel;
  std::vector<CentroidRow> rows;
  const Points<T> rest = s.rest.cast<T>();
  Handles<T> rest_handles, moved;
  rest_handles.points = rows_of(s.rest, s.handles).cast<T>();
  moved.points = s.targets.cast<T>();
  Points<T> out;
  for (const auto& [label, kernel] :
       {std::pair{"MLS (eq. 2)", std::optional<RbfKernel>()}, std::pair{"RBF, phi = r", std::optional(RbfKernel::r)},
        std::pair{"RBF, phi = r^3", std::optional(RbfKernel::r3)}}) {
    mlsdeform::Options o;  // rigid, u = 2
    o.threads = set.threads;
    o.centroids = kernel ? mlsdeform::Centroids::rbf : mlsdeform::Centroids::mls;
    // The weight table for every row (RBF centroids need it; the bar's is over the default budget), so the
    // per-frame work is the same kernels on the same table.
    o.weight_storage = mlsdeform::WeightStorage::precomputed;
    const mlsdeform::detail::ScopedRbfKernel scoped(kernel.value_or(RbfKernel::r3));
    CentroidRow r;
    r.centroids = label;
    const auto t0 = std::chrono::steady_clock::now();
    const mlsdeform::Deformer<T> d(rest, rest_handles, o);
    r.setup_ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (kernel) {
      // The matrix the deformer factorised: the same pseudo-handles in the same local frame.
      const auto frame = mlsdeform::detail::make_local_frame(rest, rest_handles);
      const Eigen::MatrixXd M =
          mlsdeform::detail::RbfCentroids(mlsdeform::detail::make_rest_handles(rest_handles, frame).P, *kernel)
              .matrix();
      const Eigen::VectorXd sv = Eigen::BDCSVD<Eigen::MatrixXd>(M).singularValues();
      r.kappa = sv(0) / sv(sv.size() - 1);
    }
    r.ms = ms_per_frame([&] { d.deform(moved, out); }, set.min_time);
    const PointsD x = out.template cast<double>();
    check_handles(s, label, x);
    r.quality = mlsdeform::testing::shape_quality(s.rest, x, s.triangles);
    r.dihedral = mlsdeform::testing::dihedral_change(s.rest, x, s.triangles);
    rows.push_back(std::move(r));
  }
  return rows;
}

void print_centroid_table(const QualityScene& s, const std::vector<CentroidRow>& rows) {
  using mlsdeform::testing::quantile;
  std::printf("\n### %s\n\n%s: %lld vertices, %lld triangles, %zu interior edges.\n\n", s.name.c_str(),
              s.description.c_str(), static_cast<long long>(s.rest.rows()), static_cast<long long>(s.triangles.rows()),
              rows.front().dihedral.size());
  std::printf(
      "| centroids | ms per frame | setup ms | kappa(M) | rigidity median / p95 | dihedral change median / p95 / max "
      "(deg) | flipped |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|\n");
  for (const CentroidRow& r : rows) {
    char kappa[32] = "-";
    if (r.kappa > 0) std::snprintf(kappa, sizeof kappa, "%.3g", r.kappa);
    std::printf("| %s | %.3g | %.4g | %s | %.4f / %.4f | %.3g / %.3g / %.4g | %lld |\n", r.centroids.c_str(), r.ms,
                r.setup_ms, kappa, quantile(r.quality.rigidity, 0.5), quantile(r.quality.rigidity, 0.95),
                quantile(r.dihedral, 0.5), quantile(r.dihedral, 0.95), quantile(r.dihedral, 1.0),
                static_cast<long long>(r.quality.flipped));
  }
  std::fflush(stdout);
}

std::string json_centroid_row(const QualityScene& s, const CentroidRow& r) {
  using mlsdeform::testing::quantile;
  char buf[640];
  std::snprintf(buf, sizeof buf,
                "{\"scene\": \"%s\", \"centroids\": \"%s\", \"ms_per_frame\": %.6g, \"setup_ms\": %.6g, "
                "\"kappa\": %.6g, \"rigidity_median\": %.6g, \"rigidity_p95\": %.6g, \"dihedral_median\": %.6g, "
                "\"dihedral_p95\": %.6g, \"dihedral_max\": %.6g, \"flipped\": %lld}",
                s.name.c_str(), r.centroids.c_str(), r.ms, r.setup_ms, r.kappa, quantile(r.quality.rigidity, 0.5),
                quantile(r.quality.rigidity, 0.95), quantile(r.dihedral, 0.5), quantile(r.dihedral, 0.95),
                quantile(r.dihedral, 1.0), static_cast<long long>(r.quality.flipped));
  return buf;
}

// The conditioning table of the file comment (bar 16 x 16 x 88, caps of n x n cells, the deformer's local
// frame: scaled by 2^-ilogb(diagonal)).
void print_conditioning_table() {
  using mlsdeform::detail::RbfKernel;
  std::printf(
      "\n### conditioning\n\nThe interpolant's matrix M for the bar's end caps (16 x 16 x 88) cut into n x n "
      "cells as handles: kappa(M) (2-norm) and the LU's reciprocal condition estimate (refused below "
      "1e-10).\n\n");
  std::printf("| caps | handles | kappa(M), phi = r | rcond, phi = r | kappa(M), phi = r^3 | rcond, phi = r^3 |\n");
  std::printf("|---|---:|---:|---:|---:|---:|\n");
  for (const int n : {8, 16, 24, 32}) {
    const double h = 16.0 / n, scale = std::ldexp(1.0, -std::ilogb(std::sqrt(2 * 16.0 * 16.0 + 88.0 * 88.0)));
    std::vector<Eigen::Vector3d> P;
    for (const double z : {0.0, 88.0})
      for (int i = 0; i <= n; ++i)
        for (int j = 0; j <= n; ++j) P.push_back(scale * Eigen::Vector3d(i * h, j * h, z));
    std::printf("| %d x %d | %zu", n, n, P.size());
    for (const RbfKernel kernel : {RbfKernel::r, RbfKernel::r3}) {
      try {
        const Eigen::MatrixXd M = mlsdeform::detail::RbfCentroids(P, kernel).matrix();
        const Eigen::VectorXd sv = Eigen::BDCSVD<Eigen::MatrixXd>(M).singularValues();
        std::printf(" | %.3g | %.3g", sv(0) / sv(sv.size() - 1), Eigen::PartialPivLU<Eigen::MatrixXd>(M).rcond());
      } catch (const std::invalid_argument&) {
        std::printf(" | refused | below 1e-10");
      }
    }
    std::printf(" |\n");
  }
  std::fflush(stdout);
}

// /proc/self/status's field `key` (kB) in GiB; 0 where unreadable.
double status_gib(const std::string& key) {
  std::ifstream f("/proc/self/status");
  for (std::string line; std::getline(f, line);)
    if (line.rfind(key + ":", 0) == 0) return std::atof(line.c_str() + key.size() + 1) / (1024.0 * 1024.0);
  return 0;
}

// Prints the table; returns its JSON rows, one per factorisation the build has (none where skipped).
template <class T>
std::vector<std::string> print_large_arap(const Settings& set) {
  const std::string path = mlsdeform::testing::mesh_dir() + "/spot_loop3.ply.gz";
  if (!std::ifstream(path)) {
    std::printf("\nspot_loop3: %s not found: skipped\n", path.c_str());
    return {};
  }
  mlsdeform::Triangles triangles;
  const mlsdeform::Points<T> rest = mlsdeform::testing::read_ply_vertices(path, &triangles).cast<T>();
  // The hooves (the 1% lowest vertices) held, the highest vertex moved along x by a tenth of the height.
  std::vector<Eigen::Index> by_height(std::size_t(rest.rows()));
  for (Eigen::Index i = 0; i < rest.rows(); ++i) by_height[std::size_t(i)] = i;
  std::stable_sort(by_height.begin(), by_height.end(),
                   [&](Eigen::Index a, Eigen::Index b) { return rest(a, 1) < rest(b, 1); });
  std::vector<Eigen::Index> held(by_height.begin(), by_height.begin() + rest.rows() / 100);
  held.push_back(by_height.back());
  mlsdeform::Points<T> targets(Eigen::Index(held.size()), 3);
  for (std::size_t k = 0; k < held.size(); ++k) targets.row(Eigen::Index(k)) = rest.row(held[k]);
  targets(targets.rows() - 1, 0) += T(0.1) * (rest(by_height.back(), 1) - rest(by_height.front(), 1));

  std::printf(
      "\n### spot_loop3: ARAP on a large mesh\n\nspot_loop3.ply.gz (\"Spot\" by Keenan Crane, 3 Loop "
      "subdivisions): %lld vertices, %lld triangles; the %zu lowest vertices (the hooves) held, the highest "
      "moved along x by a tenth of the height. One row per factorisation of the global step this build has "
      "(ArapFactorisation).\n\n",
      static_cast<long long>(rest.rows()), static_cast<long long>(triangles.rows()), held.size() - 1);
  std::printf("| factorisation | set-up s | held MiB | peak RSS GiB | ms per iteration |\n|---|---:|---:|---:|---:|\n");
  using F = mlsdeform::ArapFactorisation;
  std::vector<std::pair<F, const char*>> methods{{F::simplicial, "simplicial"}};
  if (mlsdeform::supernodal_factorisation_available()) methods.insert(methods.begin(), {F::supernodal, "supernodal"});
  std::vector<std::string> json;
  for (const auto& [method, name] : methods) {
    { std::ofstream("/proc/self/clear_refs") << "5"; }  // resets VmHWM to the current RSS
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    mlsdeform::ArapRefiner<T> session(rest, triangles, held, mlsdeform::ArapOptions{set.threads, method});
    const double setup_s = std::chrono::duration<double>(Clock::now() - t0).count(), peak = status_gib("VmHWM");
    mlsdeform::Points<T> out;
    std::vector<double> ms;
    session.refine(rest, targets, 1, out);  // warm-up
    for (int r = 0; r < 3; ++r) {
      const auto t = Clock::now();
      session.refine(rest, targets, 10, out);
      ms.push_back(1e3 * std::chrono::duration<double>(Clock::now() - t).count() / 10);
    }
    std::sort(ms.begin(), ms.end());
    const double held_mib = double(session.memory_bytes()) / (1024.0 * 1024.0);
    std::printf("| %s | %.1f | %.0f | %.2f | %.0f |\n", name, setup_s, held_mib, peak, ms[1]);
    std::fflush(stdout);
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "{\"scene\": \"spot_loop3\", \"tool\": \"ArapRefiner\", \"factorisation\": \"%s\", "
                  "\"setup_s\": %.6g, \"held_mib\": %.6g, \"peak_rss_gib\": %.6g, \"ms_per_iteration\": %.6g}",
                  name, setup_s, held_mib, peak, ms[1]);
    json.push_back(buf);
  }
  if (methods.size() == 1)
    std::printf("\n(This build has no supernodal factorisation: configure with -DMLSDEFORM_CHOLMOD=ON.)\n");
  return json;
}

void print_table(const QualityScene& s, const std::vector<Row>& rows) {
  std::printf("\n### %s\n\n%s: %lld vertices, %lld triangles.\n\n", s.name.c_str(), s.description.c_str(),
              static_cast<long long>(s.rest.rows()), static_cast<long long>(s.triangles.rows()));
  std::printf("| tool | ms per frame | rigidity median / p95 | edge ratio p1 / p99 | flipped |\n");
  std::printf("|---|---:|---:|---:|---:|\n");
  for (const Row& r : rows) {
    using mlsdeform::testing::quantile;
    std::printf(r.ms < 100 ? "| %s | %.3g | %.4f / %.4f | %.3f / %.3f | %lld |\n"
                           : "| %s | %.0f | %.4f / %.4f | %.3f / %.3f | %lld |\n",
                r.tool.c_str(), r.ms, quantile(r.quality.rigidity, 0.5), quantile(r.quality.rigidity, 0.95),
                quantile(r.quality.edge_ratio, 0.01), quantile(r.quality.edge_ratio, 0.99),
                static_cast<long long>(r.quality.flipped));
  }
  std::fflush(stdout);
}

std::string json_row(const QualityScene& s, const Row& r) {
  using mlsdeform::testing::quantile;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "{\"scene\": \"%s\", \"tool\": \"%s\", \"ms_per_frame\": %.6g, \"rigidity_median\": %.6g, "
                "\"rigidity_p95\": %.6g, \"edge_ratio_p1\": %.6g, \"edge_ratio_p99\": %.6g, \"flipped\": %lld, "
                "\"triangles\": %lld}",
                s.name.c_str(), r.tool.c_str(), r.ms, quantile(r.quality.rigidity, 0.5),
                quantile(r.quality.rigidity, 0.95), quantile(r.quality.edge_ratio, 0.01),
                quantile(r.quality.edge_ratio, 0.99), static_cast<long long>(r.quality.flipped),
                static_cast<long long>(r.quality.triangles));
  return buf;
}

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
  for (const QualityScene& s : scenes) {
    if (set.centroids) {
      const std::vector<CentroidRow> rows =
          set.use_double ? centroid_rows<double>(s, set) : centroid_rows<float>(s, set);
      print_centroid_table(s, rows);
      for (const CentroidRow& r : rows) json.push_back(json_centroid_row(s, r));
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
  } else {
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
    } else {
      std::fprintf(stderr,
                   "usage: %s [--threads N] [--min-time S] [--precision float|double] [--json FILE] "
                   "[--centroids]\n",
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
