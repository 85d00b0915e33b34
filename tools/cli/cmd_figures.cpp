// `mlsdeform figures`: the paper's Fig. 1, 3, 4 and 5 redrawn from our deformer, and MLS against MLS + ARAP
// (arap.png), as PNG files (by default in the source tree's docs/figures/, which README.md shows).
#include "commands.hpp"
#include "error.hpp"
#include "mesh.hpp"
#include "render.hpp"
#include "scenes.hpp"

#include <mlsdeform/arap.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <set>
#include <sstream>

namespace mlsdeform::cli {

std::string default_figures_dir() { return MLSDEFORM_FIGURES_DIR; }

namespace {

namespace fs = std::filesystem;

Mesh deformed(const Scene& s) { return with_vertices(s.mesh, run_scene<double>(s, Backend::simd).result); }

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
  {
    Panel p;
    p.title = "p* (rest, u = 2)";
    p.meshes.push_back({rest.mesh, {0.78f, 0.80f, 0.86f}, 0.25f});
    PointLayer c;
    c.xyz = weighted_centroids(to_points(rest.mesh), rest.rest, rest.rest, 2);
    c.color = {0.05f, 0.55f, 0.25f};
    c.size = 5;
    c.label = "weighted centroid p* / q*";
    p.points.push_back(c);
    bottom.push_back(p);
  }
  const char* letters = "bcd";
  for (int i = 0; i < 3; ++i) {
    const double u = 2 + i;
    const Scene s = cylinder_scene(u, 1, 120);
    const Mesh m = deformed(s);
    top.push_back(
        mesh_panel(std::string("(") + letters[i] + ") u = " + std::to_string(int(u)), m, s.rest, &s.frames.back()));
    Panel p;
    p.title = "q*, u = " + std::to_string(int(u));
    p.meshes.push_back({m, {0.78f, 0.80f, 0.86f}, 0.25f});
    PointLayer c;
    c.xyz = weighted_centroids(to_points(s.mesh), s.rest, s.frames.back(), u);
    c.color = {0.05f, 0.55f, 0.25f};
    c.size = 5;
    c.label = "weighted centroid p* / q*";
    p.points.push_back(c);
    bottom.push_back(p);
  }
  fig.panels = top;
  fig.panels.insert(fig.panels.end(), bottom.begin(), bottom.end());
  for (auto& p : fig.panels) {
    p.elev = 5;
    p.azim = -90;
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
    const Points<double> x = run_scene<double>(s, Backend::simd).result;
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
      {"1", "fig1.png"}, {"3", "fig3.png"}, {"4", "fig4.png"}, {"5", "fig5.png"}, {"arap", "arap.png"}};
  std::set<std::string> wanted;
  if (a.only.empty()) {
    for (const auto& [name, file] : known) wanted.insert(name);
  } else {
    std::stringstream ss(a.only);
    std::string item;
    while (std::getline(ss, item, ',')) {
      if (std::none_of(known.begin(), known.end(), [&](const auto& k) { return k.first == item; }))
        throw InputError("--only", "no figure '" + item + "' (choose from 1, 3, 4, 5, arap)");
      wanted.insert(item);
    }
  }
  std::string why;
  if (!renderer_available(&why)) throw InputError("figures", "cannot render: " + why);
  const std::string out_dir = a.out_dir.empty() ? default_figures_dir() : a.out_dir;
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
    } else if (f == "3") {
      fig = figure_3();
    } else if (f == "4") {
      fig = figure_4();
    } else if (f == "5") {
      fig = figure_5();
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
