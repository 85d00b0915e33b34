// bench_quality's scenes, timing and tables (quality.hpp).
#include "bench/quality.hpp"

#include <Eigen/Geometry>

#include <chrono>
#include <cstdio>
#include <numbers>
#include <stdexcept>

namespace bench::quality {

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

}  // namespace bench::quality
