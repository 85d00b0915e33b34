// See figures.hpp: the figures that show a deformation as it is (Fig. 1 to 5, Fig. 7 and MLS + ARAP); the two
// that measure what they show (Fig. 6 and 8) are in measures.cpp.
#include "tools/cli/figures/figures.hpp"

#include <mlsdeform/arap.hpp>

#include <Eigen/Core>

#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

namespace mlsdeform::cli {
namespace {

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

}  // namespace

// Fig. 1: one model and handle set, three kinds of local transform (Sec. 4, 6.1).
Figure figure_1(const Mesh& human) {
  const char* titles[] = {"(b) affine", "(c) similarity", "(d) rigid"};
  const Transform transforms[] = {Transform::affine, Transform::similarity, Transform::rigid};
  std::vector<Panel> panels = {rest_panel(human_bend_scene(human, 1, 60, Transform::rigid))};
  for (int i = 0; i < 3; ++i) panels.push_back(result_panel(titles[i], human_bend_scene(human, 1, 60, transforms[i])));
  return laid_out(
      "Fig. 1: MLS deformations with affine, similarity and rigid transforms",
      "data/human_man.obj (6890 vertices), 7 point handles: toes and heels fixed, the head rotated 60 degrees "
      "forward about the waist, the hands brought to the knees; u = 2. No handle near the navel (Sec. 7).",
      {.cols = 4, .panel_width = 2.8, .elev = 8, .azim = -40}, std::move(panels));
}

// Fig. 2: the fish flexed by 4 point handles, as the paper's dolphin (Sec. 5).
Figure figure_2(const Mesh& fish) {
  const Scene s = fish_scene(fish);
  return laid_out(
      "Fig. 2: deformation of a fish using 4 control points",
      "fish.obj (\"Blub\" by Keenan Crane, remeshed by Oded Stein; public domain), 10786 vertices; point handles at "
      "the mouth, the tail tip, the top of the dorsal fin and the bottom of the belly; the head and the tail turned "
      "up by 25 and 40 degrees, the fins fixed; rigid, u = 2.",
      {.cols = 2, .panel_width = 4.2, .panel_height = 3.0, .elev = 8, .azim = -12},
      {rest_panel(s), result_panel("(b) deformed", s)});
}

// Fig. 3: a bar twisted by several small torsions in succession (Sec. 5), and, for contrast, by one large one.
Figure figure_3() {
  const Scene rest = bar_twist_scene(1, 0);
  const Scene s90 = bar_twist_scene(8, 90), s180 = bar_twist_scene(16, 180), once = bar_twist_scene(1, 180);
  return laid_out(
      "Fig. 3: twisting a bar by small torsions in succession",
      "Table 2's bar: 6146 vertices, 256 point handles (two rings at each end); the top rotates about the bar's "
      "axis, the bottom stays; each step deforms the previous result. (d): the same 180 degrees in one step.",
      {.cols = 4, .panel_width = 2.4, .panel_height = 4.2, .elev = 22},
      {rest_panel(rest), result_panel("(b) 90 deg, 8 steps", s90), result_panel("(c) 180 deg, 16 steps", s180),
       result_panel("(d) 180 deg, 1 step", once)});
}

// Fig. 4: point handles (few, then more) against segment handles (Sec. 6.2).
Figure figure_4() {
  const char* titles[] = {"(a) 4 points", "(b) 32 points", "(c) 4 segments"};
  std::vector<Panel> top, bottom;
  for (int v = 0; v < 3; ++v) {
    const Scene s = bar_bend_scene(v, 1);
    top.push_back(rest_panel(s, titles[v]));
    bottom.push_back(result_panel("", s));
  }
  return laid_out(
      "Fig. 4: deforming with (a), (b) point handles and (c) segment handles",
      "A bar (1666 vertices) bent 90 degrees: its upper end rotated and moved along an arc, its lower end fixed; "
      "rigid, u = 2. (a) two points per end, (b) 16 per end, (c) two segments per end along the side edges. "
      "Top: handles at rest; bottom: result and targets.",
      {.rows = 2, .cols = 3, .panel_width = 3.0, .panel_height = 3.0, .elev = 10, .azim = -80}, two_rows(top, bottom));
}

// Fig. 5: the cylinder under a large rotation of its top for u = 2, 3, 4, and the weighted centroids q* (eq. 2).
Figure figure_5() {
  const Scene rest = cylinder_scene(2, 1, 120);
  std::vector<Panel> top = {rest_panel(rest)};
  std::vector<Panel> bottom = {
      centroid_panel("p* (rest, u = 2)", rest.mesh, weighted_centroids(to_points(rest.mesh), rest.rest, rest.rest, 2))};
  const char* letters = "bcd";
  for (int i = 0; i < 3; ++i) {
    const double u = 2 + i;
    const Scene s = cylinder_scene(u, 1, 120);
    const Mesh m = deformed(s);
    top.push_back(result_panel(std::string("(") + letters[i] + ") u = " + std::to_string(int(u)), s, m));
    bottom.push_back(centroid_panel("q*, u = " + std::to_string(int(u)), m,
                                    weighted_centroids(to_points(s.mesh), s.rest, s.frames.back(), u)));
  }
  return laid_out(
      "Fig. 5: large deformation of a cylinder with weights w(d) = d^-u",
      "Table 2's cylinder: 1058 vertices, 322 point handles (7 rings at each end); the top group rotated 120 degrees. "
      "Lower row: each vertex's weighted centroid q* (eq. 2) over the deformed mesh; (a): p* at rest, u = 2.",
      {.rows = 2, .cols = 4, .panel_width = 2.6, .panel_height = 3.2, .elev = 5, .azim = -90}, two_rows(top, bottom));
}

// Fig. 7: a large translation of one end of a bar (Sec. 7); bands of alternating colour show the cross-sections.
Figure figure_7() {
  const Scene s = bar_far_scene();
  std::vector<Color> bands;
  for (std::size_t f = 0; f < s.mesh.face_count(); ++f) {
    double y = 0;
    for (auto i = s.mesh.face_start[f]; i < s.mesh.face_start[f + 1]; ++i)
      y += s.mesh.vertices(s.mesh.face_indices[i], 1);
    y /= double(s.mesh.face_start[f + 1] - s.mesh.face_start[f]);
    bands.push_back(int(std::floor(y / 0.25)) % 2 ? Color{0.55f, 0.62f, 0.78f} : Color{0.86f, 0.87f, 0.90f});
  }
  Panel a = rest_panel(s);
  Panel b = result_panel("(b) deformed", s);
  const Eigen::Vector3d top(0, 6, 0),
      shift = (s.frames.back().points.bottomRows(1) - s.rest.points.bottomRows(1)).transpose();
  add_group_move(b, top, top + shift);
  a.meshes[0].face_colors = b.meshes[0].face_colors = bands;
  b.meshes.insert(b.meshes.begin(), {s.mesh, {0.6f, 0.6f, 0.65f}, 0.15f});  // the rest pose, faint
  return laid_out(
      "Fig. 7: deformation with a large displacement",
      "A bar (1666 vertices, 1 x 6 x 1) with 32 point handles (two rings of 8 at each end): its upper end translated "
      "by (5.4, -3, 0), more than the bar's length, without rotation; the lower end fixed; rigid, u = 2. The bands "
      "are the rest pose's cross-sections, a quarter of the width apart; (b) shows the rest pose faintly.",
      {.cols = 2, .panel_width = 3.6, .panel_height = 3.6, .elev = 15, .azim = -75}, {a, b});
}

// Not in the paper: MLS alone and MLS followed by surface-ARAP iterations (Sorkine & Alexa 2007,
// Options::arap_iterations) on one handle set. The panel titles give each result's ARAP energy E, which the
// iterations lower.
Figure figure_arap(const Mesh& human) {
  Scene s = human_arap_scene(human);
  const Points<double> rest = to_points(s.mesh);
  std::vector<Eigen::Index> pinned;
  for (Eigen::Index k = 0; k < s.rest.point_count(); ++k) {
    Eigen::Index nearest = 0;
    (rest.rowwise() - s.rest.points.row(k)).rowwise().squaredNorm().minCoeff(&nearest);
    pinned.push_back(nearest);
  }
  const ArapRefiner<double> energy(rest, fan_triangles(s.mesh, s.name), pinned);
  std::vector<Panel> panels;
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
    panels.push_back(p);
  }
  return laid_out(
      "MLS, then surface-ARAP iterations (Sorkine & Alexa 2007)",
      "data/human_man.obj, 8 point handles (red: their targets): navel, toes and heels fixed, the head and the hands "
      "moved; rigid, u = 2. E: the ARAP energy over the one-rings (clamped cotangent weights, the rest pose as "
      "reference).",
      {.cols = 3, .panel_width = 3.4, .panel_height = 4.0, .elev = 8, .azim = -30}, std::move(panels));
}

}  // namespace mlsdeform::cli
