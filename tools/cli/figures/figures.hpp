// mlsdeform CLI, `figures`: the paper's Fig. 1 to 8 and the ARAP figure. Each figure is a function that builds
// its scenes (scenes.hpp), runs them and puts the results in panels (figures.cpp, measures.cpp); all share one
// layout and the same kinds of panel (layout.cpp). cmd_figures.cpp picks the figures and renders them.
#pragma once

#include "core/files/mesh.hpp"
#include "tools/cli/render.hpp"
#include "tools/cli/scenes.hpp"

#include <string>
#include <vector>

namespace mlsdeform::cli {

// The program is a command layer over the files library (core/files/): its names are the program's own.
using namespace mlsdeform::files;

/// What every figure shares: a grid of panels of one size (inches), all seen from one direction (matplotlib's
/// elevation and azimuth in degrees, with the model's y axis up; Panel's defaults unless a figure says).
struct Layout {
  int rows = 1, cols = 1;
  double panel_width = 3.2, panel_height = 3.6;
  double elev = 12, azim = -65;
};

/// The figure `title` over `panels` (row by row) and `caption`, laid out and seen as `layout` says.
Figure laid_out(std::string title, std::string caption, const Layout& layout, std::vector<Panel> panels);
/// A figure's two rows: `top`, then `bottom`.
std::vector<Panel> two_rows(std::vector<Panel> top, const std::vector<Panel>& bottom);

/// The result of `scene` (its last frame; double precision, the SIMD backend) as a mesh.
Mesh deformed(const Scene& scene);
/// The scene's mesh at rest with its rest handles.
Panel rest_panel(const Scene& scene, const std::string& title = "(a) original and handles");
/// `result` (the scene's mesh after its last frame) with that frame's targets and an arrow to each.
Panel result_panel(const std::string& title, const Scene& scene, const Mesh& result);
/// result_panel of deformed(scene).
Panel result_panel(const std::string& title, const Scene& scene);
/// The panel of Fig. 5's and Fig. 8's lower rows: the model faint, and each vertex's centroid (p* or q*) as a dot.
Panel centroid_panel(const std::string& title, const Mesh& mesh, const Points<double>& centroids);

/// The weighted centroids q* = sum_i w_i q_i / sum_i w_i of eq. (2) (Sec. 6.2's midpoint rule for segments,
/// w = d^-u with d the distance to the rest handle), per vertex: what Fig. 5's lower row draws.
Points<double> weighted_centroids(const Points<double>& vertices, const Handles<double>& rest,
                                  const Handles<double>& moved, double u);
/// Centroids::rbf's q* = g(p*) per vertex (point handles only): p* as above over the rest handles, g the
/// biharmonic interpolant (r plus a linear polynomial, the library's kernel) of rest -> moved. Solved here
/// by a minimum-norm least-squares solve, for drawing: on coplanar handles the polynomial's normal part is
/// free but p* lies in their plane, so g(p*) is the library's.
Points<double> rbf_centroids(const Points<double>& vertices, const Handles<double>& rest, const Handles<double>& moved,
                             double u);

/// The figures, each from its paper's section (figures.cpp, measures.cpp); `human` is data/human_man.obj and
/// `fish` the shared fish.obj.
Figure figure_1(const Mesh& human);
Figure figure_2(const Mesh& fish);
Figure figure_3();
Figure figure_4();
Figure figure_5();
Figure figure_6();
Figure figure_7();
Figure figure_8();
Figure figure_arap(const Mesh& human);

}  // namespace mlsdeform::cli
