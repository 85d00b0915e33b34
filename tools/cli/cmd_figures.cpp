// `mlsdeform figures`: the paper's Fig. 1 to 8 redrawn from our deformer, and MLS against MLS + ARAP
// (arap.png), as PNG files (by default in the source tree's docs/figures/, which README.md shows).
#include "tools/cli/commands.hpp"
#include "tools/cli/error.hpp"
#include "tools/cli/mesh.hpp"
#include "tools/cli/render.hpp"
#include "tools/cli/scenes.hpp"

#include <mlsdeform/arap.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <numbers>
#include <set>
#include <sstream>

namespace mlsdeform::cli {

namespace {

namespace fs = std::filesystem;

Mesh deformed(const Scene& s) { return with_vertices(s.mesh, run_scene<double>(s).result); }

// The shared meshes (../shared/data/meshes beside the source tree, or $MLSDEFORM_MESHES): fish.obj for Fig. 2.
// Absent in a checkout of the repository alone.
std::string shared_mesh_dir() {
  if (const char* env = std::getenv("MLSDEFORM_MESHES"); env && *env) return env;
  return MLSDEFORM_SHARED_MESHES;
}

// The panel of Fig. 5's lower row: the model faint, and each vertex's centroid (p* or q*) as a dot.
Panel centroid_panel(const std::string& title, const Mesh& mesh, const Points<double>& centroids) {
  Panel p;
  p.title = title;
  p.meshes.push_back({mesh, {0.78f, 0.80f, 0.86f}, 0.25f});
  PointLayer c;
  c.xyz = centroids;
  c.color = {0.05f, 0.55f, 0.25f};
  c.size = 5;
  c.label = "weighted centroid p* / q*";
  p.points.push_back(c);
  return p;
}

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

// One grey arrow a -> b, for a group of handles that all move by b - a (add_moves draws at most 12).
void add_group_move(Panel& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  SegmentLayer s;
  s.color = {0.35f, 0.35f, 0.35f};
  s.width = 3.0f;
  s.arrow = true;
  s.label = "handle move";
  s.a = a.transpose();
  s.b = b.transpose();
  p.segments.push_back(std::move(s));
}

// The q-quantile of sorted values (nearest rank).
double quantile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return 0;
  const auto i = std::size_t(std::ceil(q * double(sorted.size())));
  return sorted[std::min(sorted.size() - 1, i > 0 ? i - 1 : 0)];
}

// Fig. 1: one model and handle set, three kinds of local transform (Sec. 4, 6.1).
Figure figure_1(const Mesh& human) {
  Figure fig;
  fig.title = "Fig. 1: MLS deformations with affine, similarity and rigid transforms";
  fig.caption =
      "data/human_man.obj (6890 vertices), 7 point handles: toes and heels fixed, the head rotated 60 degrees "
      "forward about the waist, the hands brought to the knees; u = 2. No handle near the navel (Sec. 7).";
  fig.cols = 4;
  fig.panel_width = 2.8;
  const char* titles[] = {"(b) affine", "(c) similarity", "(d) rigid"};
  const Transform transforms[] = {Transform::affine, Transform::similarity, Transform::rigid};
  const Scene base = human_bend_scene(human, 1, 60, Transform::rigid);
  fig.panels.push_back(mesh_panel("(a) original and handles", base.mesh, base.rest));
  for (int i = 0; i < 3; ++i) {
    const Scene s = human_bend_scene(human, 1, 60, transforms[i]);
    fig.panels.push_back(mesh_panel(titles[i], deformed(s), s.rest, &s.frames.back()));
  }
  for (auto& p : fig.panels) {
    p.elev = 8;
    p.azim = -40;
  }
  return fig;
}

// Fig. 2: the fish flexed by 4 point handles, as the paper's dolphin (Sec. 5).
Figure figure_2(const Mesh& fish) {
  Figure fig;
  fig.title = "Fig. 2: deformation of a fish using 4 control points";
  fig.caption =
      "fish.obj (\"Blub\" by Keenan Crane, remeshed by Oded Stein; public domain), 10786 vertices; point handles at "
      "the mouth, the tail tip, the top of the dorsal fin and the bottom of the belly; the head and the tail turned "
      "up by 25 and 40 degrees, the fins fixed; rigid, u = 2.";
  fig.cols = 2;
  fig.panel_width = 4.2;
  fig.panel_height = 3.0;
  const Scene s = fish_scene(fish);
  fig.panels.push_back(mesh_panel("(a) original and handles", s.mesh, s.rest));
  fig.panels.push_back(mesh_panel("(b) deformed", deformed(s), s.rest, &s.frames.back()));
  for (auto& p : fig.panels) {
    p.elev = 8;
    p.azim = -12;
  }
  return fig;
}

// Fig. 3: a bar twisted by several small torsions in succession (Sec. 5), and, for contrast, by one large one.
Figure figure_3() {
  Figure fig;
  fig.title = "Fig. 3: twisting a bar by small torsions in succession";
  fig.caption =
      "Table 2's bar: 6146 vertices, 256 point handles (two rings at each end); the top rotates about the bar's "
      "axis, the bottom stays; each step deforms the previous result. (d): the same 180 degrees in one step.";
  fig.cols = 4;
  fig.panel_width = 2.4;
  fig.panel_height = 4.2;
  const Scene rest = bar_twist_scene(1, 0);
  fig.panels.push_back(mesh_panel("(a) original and handles", rest.mesh, rest.rest));
  const Scene s90 = bar_twist_scene(8, 90), s180 = bar_twist_scene(16, 180), once = bar_twist_scene(1, 180);
  fig.panels.push_back(mesh_panel("(b) 90 deg, 8 steps", deformed(s90), s90.rest, &s90.frames.back()));
  fig.panels.push_back(mesh_panel("(c) 180 deg, 16 steps", deformed(s180), s180.rest, &s180.frames.back()));
  fig.panels.push_back(mesh_panel("(d) 180 deg, 1 step", deformed(once), once.rest, &once.frames.back()));
  for (auto& p : fig.panels) p.elev = 22;
  return fig;
}

// Fig. 4: point handles (few, then more) against segment handles (Sec. 6.2).
Figure figure_4() {
  Figure fig;
  fig.title = "Fig. 4: deforming with (a), (b) point handles and (c) segment handles";
  fig.caption =
      "A bar (1666 vertices) bent 90 degrees: its upper end rotated and moved along an arc, its lower end fixed; "
      "rigid, u = 2. (a) two points per end, (b) 16 per end, (c) two segments per end along the side edges. "
      "Top: handles at rest; bottom: result and targets.";
  fig.rows = 2;
  fig.cols = 3;
  fig.panel_width = 3.0;
  fig.panel_height = 3.0;
  const char* titles[] = {"(a) 4 points", "(b) 32 points", "(c) 4 segments"};
  std::vector<Panel> top, bottom;
  for (int v = 0; v < 3; ++v) {
    const Scene s = bar_bend_scene(v, 1);
    top.push_back(mesh_panel(titles[v], s.mesh, s.rest));
    bottom.push_back(mesh_panel("", deformed(s), s.rest, &s.frames.back()));
  }
  fig.panels = top;
  fig.panels.insert(fig.panels.end(), bottom.begin(), bottom.end());
  for (auto& p : fig.panels) {
    p.elev = 10;
    p.azim = -80;
  }
  return fig;
}

// Fig. 5: the cylinder under a large rotation of its top for u = 2, 3, 4, and the weighted centroids q* (eq. 2).
Figure figure_5() {
  Figure fig;
  fig.title = "Fig. 5: large deformation of a cylinder with weights w(d) = d^-u";
  fig.caption =
      "Table 2's cylinder: 1058 vertices, 322 point handles (7 rings at each end); the top group rotated 120 degrees. "
      "Lower row: each vertex's weighted centroid q* (eq. 2) over the deformed mesh; (a): p* at rest, u = 2.";
  fig.rows = 2;
  fig.cols = 4;
  fig.panel_width = 2.6;
  fig.panel_height = 3.2;
  const Scene rest = cylinder_scene(2, 1, 120);
  std::vector<Panel> top, bottom;
  top.push_back(mesh_panel("(a) original and handles", rest.mesh, rest.rest));
  bottom.push_back(
      centroid_panel("p* (rest, u = 2)", rest.mesh, weighted_centroids(to_points(rest.mesh), rest.rest, rest.rest, 2)));
  const char* letters = "bcd";
  for (int i = 0; i < 3; ++i) {
    const double u = 2 + i;
    const Scene s = cylinder_scene(u, 1, 120);
    const Mesh m = deformed(s);
    top.push_back(
        mesh_panel(std::string("(") + letters[i] + ") u = " + std::to_string(int(u)), m, s.rest, &s.frames.back()));
    bottom.push_back(centroid_panel("q*, u = " + std::to_string(int(u)), m,
                                    weighted_centroids(to_points(s.mesh), s.rest, s.frames.back(), u)));
  }
  fig.panels = top;
  fig.panels.insert(fig.panels.end(), bottom.begin(), bottom.end());
  for (auto& p : fig.panels) {
    p.elev = 5;
    p.azim = -90;
  }
  return fig;
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

// Fig. 6: handles only translated (Sec. 7): the grid lines along the move stay straight.
Figure figure_6() {
  Figure fig;
  Scene s = plane_translate_scene();
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
  fig.title = "Fig. 6: deformation caused by translation";
  fig.caption = caption;
  fig.cols = 2;
  fig.panel_width = 3.6;
  fig.panel_height = 3.4;
  Panel a = mesh_panel("(a) original and handles", s.mesh, s.rest);
  a.segments.insert(a.segments.begin(), polygon_edges(s.mesh));
  const Mesh m = with_vertices(s.mesh, x);
  Panel b = mesh_panel("(b) the middle column moved 0.5 down", m, s.rest, &s.frames.back());
  b.segments.insert(b.segments.begin(), polygon_edges(m));
  fig.panels = {a, b};
  for (auto& p : fig.panels) {
    p.elev = 90;
    p.azim = -90;
  }
  return fig;
}

// Fig. 7: a large translation of one end of a bar (Sec. 7); bands of alternating colour show the cross-sections.
Figure figure_7() {
  Figure fig;
  fig.title = "Fig. 7: deformation with a large displacement";
  fig.caption =
      "A bar (1666 vertices, 1 x 6 x 1) with 32 point handles (two rings of 8 at each end): its upper end translated "
      "by (5.4, -3, 0), more than the bar's length, without rotation; the lower end fixed; rigid, u = 2. The bands "
      "are the rest pose's cross-sections, a quarter of the width apart; (b) shows the rest pose faintly.";
  fig.cols = 2;
  fig.panel_width = 3.6;
  fig.panel_height = 3.6;
  const Scene s = bar_far_scene();
  std::vector<Color> bands;
  for (std::size_t f = 0; f < s.mesh.face_count(); ++f) {
    double y = 0;
    for (auto i = s.mesh.face_start[f]; i < s.mesh.face_start[f + 1]; ++i)
      y += s.mesh.vertices(s.mesh.face_indices[i], 1);
    y /= double(s.mesh.face_start[f + 1] - s.mesh.face_start[f]);
    bands.push_back(int(std::floor(y / 0.25)) % 2 ? Color{0.55f, 0.62f, 0.78f} : Color{0.86f, 0.87f, 0.90f});
  }
  Panel a = mesh_panel("(a) original and handles", s.mesh, s.rest);
  Panel b = mesh_panel("(b) deformed", deformed(s), s.rest, &s.frames.back());
  const Eigen::Vector3d top(0, 6, 0),
      shift = (s.frames.back().points.bottomRows(1) - s.rest.points.bottomRows(1)).transpose();
  add_group_move(b, top, top + shift);
  a.meshes[0].face_colors = b.meshes[0].face_colors = bands;
  b.meshes.insert(b.meshes.begin(), {s.mesh, {0.6f, 0.6f, 0.65f}, 0.15f});  // the rest pose, faint
  fig.panels = {a, b};
  for (auto& p : fig.panels) {
    p.elev = 15;
    p.azim = -75;
  }
  return fig;
}

// Fig. 8: a row of handles raised on the plane, with the paper's centroids (eq. 2) and with RBF centroids
// q* = g(p*) (Sec. 8, Options::centroids), the centroids below; beside them the distribution of the change
// of dihedral angle per interior edge, the measure of smoothness.
Figure figure_8() {
  Figure fig;
  fig.title = "Fig. 8: mixing MLS with RBFs";
  fig.rows = 2;
  fig.cols = 4;
  fig.panel_width = 3.0;
  fig.panel_height = 2.9;
  const Scene mls = plane_row_scene(Centroids::mls), rbf = plane_row_scene(Centroids::rbf);
  const Points<double> rest = to_points(mls.mesh);
  const Points<double> x_mls = run_scene<double>(mls).result, x_rbf = run_scene<double>(rbf).result;
  const Triangles t = fan_triangles(mls.mesh, mls.name);
  const std::vector<double> d_mls = dihedral_change(t, rest, x_mls), d_rbf = dihedral_change(t, rest, x_rbf);
  const double u = mls.options.weight_exponent;
  std::vector<Panel> top, bottom;
  top.push_back(mesh_panel("(a) original and handles", mls.mesh, mls.rest));
  top.push_back(mesh_panel("(b) MLS centroids (eq. 2)", with_vertices(mls.mesh, x_mls), mls.rest, &mls.frames.back()));
  top.push_back(
      mesh_panel("(c) RBF centroids q* = g(p*)", with_vertices(rbf.mesh, x_rbf), rbf.rest, &rbf.frames.back()));
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
  fig.caption = caption;
  fig.panels = top;
  fig.panels.insert(fig.panels.end(), bottom.begin(), bottom.end());
  for (auto& p : fig.panels) {
    p.elev = 22;
    p.azim = -60;
  }
  return fig;
}

// Not in the paper: MLS alone and MLS followed by surface-ARAP iterations (Sorkine & Alexa 2007,
// Options::arap_iterations) on one handle set. The panel titles give each result's ARAP energy E, which the
// iterations lower.
Figure figure_arap(const Mesh& human) {
  Figure fig;
  fig.title = "MLS, then surface-ARAP iterations (Sorkine & Alexa 2007)";
  fig.caption =
      "data/human_man.obj, 8 point handles (red: their targets): navel, toes and heels fixed, the head and the hands "
      "moved; rigid, u = 2. E: the ARAP energy over the one-rings (clamped cotangent weights, the rest pose as "
      "reference).";
  fig.cols = 3;
  fig.panel_width = 3.4;
  fig.panel_height = 4.0;
  Scene s = human_arap_scene(human);
  const Points<double> rest = to_points(s.mesh);
  std::vector<Eigen::Index> pinned;
  for (Eigen::Index k = 0; k < s.rest.point_count(); ++k) {
    Eigen::Index nearest = 0;
    (rest.rowwise() - s.rest.points.row(k)).rowwise().squaredNorm().minCoeff(&nearest);
    pinned.push_back(nearest);
  }
  const ArapRefiner<double> energy(rest, fan_triangles(s.mesh, s.name), pinned);
  for (const int iterations : {0, 2, 10}) {
    s.options.arap_iterations = iterations;
    const Points<double> x = run_scene<double>(s).result;
    char title[96];
    if (iterations == 0)
      std::snprintf(title, sizeof title, "MLS, E = %.4f", energy.energy(x));
    else
      std::snprintf(title, sizeof title, "MLS + %d ARAP, E = %.4f", iterations, energy.energy(x));
    Panel p;
    p.title = title;
    p.meshes.push_back({with_vertices(s.mesh, x)});
    add_handles(p, s.frames.back(), true);
    p.elev = 8;
    p.azim = -30;
    fig.panels.push_back(p);
  }
  return fig;
}

}  // namespace

int run_figures(const FiguresArgs& a) {
  // Figure names for --only, and each one's file: the paper's figures by number, then ours.
  const std::vector<std::pair<std::string, std::string>> known = {
      {"1", "fig1.png"}, {"2", "fig2.png"}, {"3", "fig3.png"}, {"4", "fig4.png"},   {"5", "fig5.png"},
      {"6", "fig6.png"}, {"7", "fig7.png"}, {"8", "fig8.png"}, {"arap", "arap.png"}};
  std::set<std::string> wanted;
  if (a.only.empty()) {
    for (const auto& [name, file] : known) wanted.insert(name);
  } else {
    std::stringstream ss(a.only);
    std::string item;
    while (std::getline(ss, item, ',')) {
      if (std::none_of(known.begin(), known.end(), [&](const auto& k) { return k.first == item; }))
        throw InputError("--only", "no figure '" + item + "' (choose from 1 to 8, arap)");
      wanted.insert(item);
    }
  }
  std::string why;
  if (!renderer_available(&why)) throw InputError("figures", "cannot render: " + why);
  const std::string& out_dir = a.out_dir;
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec || !fs::is_directory(out_dir)) throw InputError(out_dir, "cannot create the output folder: " + ec.message());

  for (const auto& [f, file] : known) {
    if (!wanted.count(f)) continue;
    const auto t0 = std::chrono::steady_clock::now();
    const auto human = [&] { return read_mesh((fs::path(data_dir(a.data_dir)) / "human_man.obj").string()); };
    Figure fig;
    if (f == "1") {
      fig = figure_1(human());
    } else if (f == "2") {
      const fs::path fish = fs::path(shared_mesh_dir()) / "fish.obj";
      if (!fs::exists(fish)) {
        std::printf("skipped %s: %s not found (the shared meshes; set MLSDEFORM_MESHES to their folder)\n",
                    file.c_str(), fish.string().c_str());
        continue;
      }
      fig = figure_2(read_mesh(fish.string()));
    } else if (f == "3") {
      fig = figure_3();
    } else if (f == "4") {
      fig = figure_4();
    } else if (f == "5") {
      fig = figure_5();
    } else if (f == "6") {
      fig = figure_6();
    } else if (f == "7") {
      fig = figure_7();
    } else if (f == "8") {
      fig = figure_8();
    } else {
      fig = figure_arap(human());
    }
    const std::string png = (fs::path(out_dir) / file).string();
    render(fig, png, a.keep_spec);
    std::printf("%s (%.1f s)\n", png.c_str(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return 0;
}

}  // namespace mlsdeform::cli
