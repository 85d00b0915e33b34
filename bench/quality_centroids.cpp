// bench_quality --centroids: the centroids table per scene and the RBF conditioning table (bench_quality.cpp
// describes both).
#include "bench/quality.hpp"

#include "core/src/deformer/local_frame.hpp"
#include "core/src/deformer/rbf_centroids.hpp"

#include <Eigen/SVD>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <utility>

namespace bench::quality {

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

static void print_centroid_table(const QualityScene& s, const std::vector<CentroidRow>& rows) {
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

static std::string json_centroid_row(const QualityScene& s, const CentroidRow& r) {
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

std::vector<std::string> centroid_section(const QualityScene& s, const Settings& set) {
  const std::vector<CentroidRow> rows = set.use_double ? centroid_rows<double>(s, set) : centroid_rows<float>(s, set);
  print_centroid_table(s, rows);
  std::vector<std::string> json;
  for (const CentroidRow& r : rows) json.push_back(json_centroid_row(s, r));
  return json;
}

}  // namespace bench::quality
