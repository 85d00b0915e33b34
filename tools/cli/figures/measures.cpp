// See figures.hpp: the two figures that measure what they show, Fig. 6 (how straight the grid's lines stay) and
// Fig. 8 (how much the surface bends at each edge), with their measures; each prints its figures too.
#include "tools/cli/figures/figures.hpp"

#include <mlsdeform/arap.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

namespace mlsdeform::cli {
namespace {

// The smoothness measure of Fig. 8: for each interior edge of the triangulated mesh (an edge of exactly two
// triangles), |theta' - theta| in degrees, theta the angle between the two triangles' unit normals at rest and
// theta' the same after the deformation. 0 where the surface bends nowhere; a kink shows as a tail of large
// values along a line of edges.
std::vector<double> dihedral_change(const Triangles& t, const Points<double>& rest, const Points<double>& x) {
  const auto normal = [&](const Points<double>& v, Eigen::Index f) -> Eigen::Vector3d {
    const Eigen::Vector3d a = v.row(t(f, 0)), b = v.row(t(f, 1)), c = v.row(t(f, 2));
    return (b - a).cross(c - a).normalized();
  };
  const auto angle = [](const Eigen::Vector3d& m, const Eigen::Vector3d& n) {
    return std::atan2(m.cross(n).norm(), m.dot(n)) * 180 / std::numbers::pi;
  };
  std::map<std::pair<int, int>, std::vector<Eigen::Index>> faces_of;
  for (Eigen::Index f = 0; f < t.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = t(f, k), b = t(f, (k + 1) % 3);
      faces_of[{std::min(a, b), std::max(a, b)}].push_back(f);
    }
  std::vector<double> out;
  for (const auto& [edge, f] : faces_of)
    if (f.size() == 2)
      out.push_back(std::abs(angle(normal(x, f[0]), normal(x, f[1])) - angle(normal(rest, f[0]), normal(rest, f[1]))));
  std::sort(out.begin(), out.end());
  return out;
}

// The q-quantile of sorted values (nearest rank).
double quantile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return 0;
  const auto i = std::size_t(std::ceil(q * double(sorted.size())));
  return sorted[std::min(sorted.size() - 1, i > 0 ? i - 1 : 0)];
}

// The largest distance of a polyline's vertices from the straight line through its ends.
double deviation_from_straight(const Points<double>& x, const std::vector<Eigen::Index>& line) {
  const Eigen::Vector3d a = x.row(line.front()), b = x.row(line.back());
  const Eigen::Vector3d d = (b - a).normalized();
  double worst = 0;
  for (const Eigen::Index i : line) {
    const Eigen::Vector3d r = x.row(i).transpose() - a;
    worst = std::max(worst, (r - r.dot(d) * d).norm());
  }
  return worst;
}

}  // namespace

// Fig. 6: handles only translated (Sec. 7): the grid lines along the move stay straight.
Figure figure_6() {
  const Scene s = plane_translate_scene();
  const Points<double> x = run_scene<double>(s).result;
  // The grid's lines: along z (the move) at each x, and along x at each z.
  constexpr int n = 32;
  double along = 0, across = 0;
  for (int a = 0; a <= n; ++a) {
    std::vector<Eigen::Index> z_line, x_line;
    for (int b = 0; b <= n; ++b) {
      z_line.push_back(Eigen::Index(b) * (n + 1) + a);
      x_line.push_back(Eigen::Index(a) * (n + 1) + b);
    }
    along = std::max(along, deviation_from_straight(x, z_line));
    across = std::max(across, deviation_from_straight(x, x_line));
  }
  char caption[512];
  std::snprintf(caption, sizeof caption,
                "Table 2's plane (1089 vertices, 2 x 2): the side columns of vertices fixed, the middle column (33 "
                "handles) translated by 0.5 along itself (z), in the plane; rigid, u = 2. The grid's lines along the "
                "move stay straight (largest distance of a line's vertices from its chord: %.3f), those across it "
                "bend (%.2f).",
                along, across);
  std::printf("fig6: largest deviation from straight: lines along the move %.3g, across it %.3g\n", along, across);
  Panel a = rest_panel(s);
  a.segments.insert(a.segments.begin(), polygon_edges(s.mesh));
  const Mesh m = with_vertices(s.mesh, x);
  Panel b = result_panel("(b) the middle column moved 0.5 down", s, m);
  b.segments.insert(b.segments.begin(), polygon_edges(m));
  return laid_out("Fig. 6: deformation caused by translation", caption,
                  {.cols = 2, .panel_width = 3.6, .panel_height = 3.4, .elev = 90, .azim = -90}, {a, b});
}

// Fig. 8: a row of handles raised on the plane, with the paper's centroids (eq. 2) and with RBF centroids
// q* = g(p*) (Sec. 8, Options::centroids), the centroids below; beside them the distribution of the change
// of dihedral angle per interior edge, the measure of smoothness.
Figure figure_8() {
  const Scene mls = plane_row_scene(Centroids::mls), rbf = plane_row_scene(Centroids::rbf);
  const Points<double> rest = to_points(mls.mesh);
  const Points<double> x_mls = run_scene<double>(mls).result, x_rbf = run_scene<double>(rbf).result;
  const Triangles t = fan_triangles(mls.mesh, mls.name);
  const std::vector<double> d_mls = dihedral_change(t, rest, x_mls), d_rbf = dihedral_change(t, rest, x_rbf);
  const double u = mls.options.weight_exponent;
  std::vector<Panel> top, bottom;
  top.push_back(rest_panel(mls));
  top.push_back(result_panel("(b) MLS centroids (eq. 2)", mls, with_vertices(mls.mesh, x_mls)));
  top.push_back(result_panel("(c) RBF centroids q* = g(p*)", rbf, with_vertices(rbf.mesh, x_rbf)));
  Panel chart;
  chart.title = "change of dihedral angle per edge";
  chart.row_span = 2;
  Plot plot;
  plot.xlabel = "dihedral-angle change (degrees)";
  plot.log_x = true;
  plot.ylabel = "fraction of interior edges";
  const auto cdf = [](const std::vector<double>& v, const std::string& label, Color c) {
    Plot::Series sr;
    sr.label = label;
    sr.color = c;
    for (std::size_t i = 0; i < v.size(); ++i) {
      sr.x.push_back(std::max(v[i], 1e-3));  // the log axis starts at 0.001 degrees
      sr.y.push_back(double(i + 1) / double(v.size()));
    }
    return sr;
  };
  char label[128];
  std::snprintf(label, sizeof label, "MLS: median %.2f, p95 %.2f", quantile(d_mls, 0.5), quantile(d_mls, 0.95));
  plot.series.push_back(cdf(d_mls, label, {0.85f, 0.35f, 0.1f}));
  std::snprintf(label, sizeof label, "RBF: median %.2f, p95 %.2f", quantile(d_rbf, 0.5), quantile(d_rbf, 0.95));
  plot.series.push_back(cdf(d_rbf, label, {0.1f, 0.3f, 0.9f}));
  chart.plot = plot;
  top.push_back(chart);
  bottom.push_back(centroid_panel("p* (rest)", mls.mesh, weighted_centroids(rest, mls.rest, mls.rest, u)));
  bottom.push_back(centroid_panel("q*, MLS", with_vertices(mls.mesh, x_mls),
                                  weighted_centroids(rest, mls.rest, mls.frames.back(), u)));
  bottom.push_back(centroid_panel("q* = g(p*), RBF", with_vertices(rbf.mesh, x_rbf),
                                  rbf_centroids(rest, rbf.rest, rbf.frames.back(), u)));
  std::printf(
      "fig8: dihedral-angle change per interior edge (%zu edges), degrees: MLS median %.3f p95 %.3f max %.3f; "
      "RBF median %.3f p95 %.3f max %.3f\n",
      d_mls.size(), quantile(d_mls, 0.5), quantile(d_mls, 0.95), d_mls.back(), quantile(d_rbf, 0.5),
      quantile(d_rbf, 0.95), d_rbf.back());
  char caption[512];
  std::snprintf(caption, sizeof caption,
                "Table 2's plane (1089 vertices, 2 x 2), its side columns fixed, a row of 5 point handles raised by 1; "
                "rigid, u = 2. Right: per interior edge (%zu), the change of the angle between its two triangles' "
                "normals; median / p95 %.2f / %.2f degrees with MLS centroids, %.2f / %.2f with RBF centroids.",
                d_mls.size(), quantile(d_mls, 0.5), quantile(d_mls, 0.95), quantile(d_rbf, 0.5), quantile(d_rbf, 0.95));
  return laid_out("Fig. 8: mixing MLS with RBFs", caption,
                  {.rows = 2, .cols = 4, .panel_width = 3.0, .panel_height = 2.9, .elev = 22, .azim = -60},
                  two_rows(top, bottom));
}

}  // namespace mlsdeform::cli
