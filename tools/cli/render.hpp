// mlsdeform CLI: figures. A figure is described here (meshes, handles, targets, points per panel), written as a
// JSON spec, and drawn by tools/figures.py with Debian's python3-matplotlib.
#pragma once

#include "core/files/mesh.hpp"

#include <mlsdeform/deformer.hpp>

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace mlsdeform::cli {

// The program is a command layer over the files library (core/files/): its names are the program's own.
using namespace mlsdeform::files;

using Color = std::array<float, 3>;  // RGB in [0, 1]

struct MeshLayer {
  Mesh mesh;
  Color color{0.78f, 0.80f, 0.86f};
  float alpha = 1.0f;
  std::vector<Color> face_colors{};  ///< one per face of `mesh` (a pattern that shows distortion); empty: `color`
};

/// Markers at n points (n x 3).
struct PointLayer {
  Points<double> xyz;
  Color color{0.1f, 0.3f, 0.9f};
  float size = 18.0f;        ///< marker area in points^2
  std::string marker = "o";  ///< matplotlib marker
  std::string label;         ///< legend entry (the first layer with a label names it)
};

/// Line segments a_i b_i, or arrows a_i -> b_i.
struct SegmentLayer {
  Points<double> a, b;
  Color color{0.1f, 0.3f, 0.9f};
  float width = 2.5f;
  bool arrow = false;
  std::string label;
};

/// A 2D chart in place of a 3D view: one curve per series.
struct Plot {
  struct Series {
    std::string label;
    Color color{0.1f, 0.3f, 0.9f};
    std::vector<double> x, y;
  };
  std::string xlabel, ylabel;
  bool log_x = false;
  std::vector<Series> series;
};

struct Panel {
  std::string title;
  double elev = 12, azim = -65;  ///< view direction, degrees (matplotlib's, with the model's y axis up)
  std::vector<MeshLayer> meshes;
  std::vector<PointLayer> points;
  std::vector<SegmentLayer> segments;
  std::optional<Plot> plot;  ///< a chart instead of the 3D layers
  int row_span = 1;          ///< rows of the grid the panel covers (panels fill the free cells row by row)
};

struct Figure {
  std::string title;
  std::string caption;
  int rows = 1, cols = 1;
  double panel_width = 3.2, panel_height = 3.6;  ///< inches
  int dpi = 110;
  bool shared_bounds = true;  ///< every panel at the same scale (the union of all bounds)
  std::vector<Panel> panels;  ///< row by row
};

/// Handles drawn the same way everywhere: rest positions in blue, targets in red, a grey arrow between.
void add_handles(Panel& panel, const Handles<double>& handles, bool target, bool with_labels = true);
void add_moves(Panel& panel, const Handles<double>& rest, const Handles<double>& target);
/// The edges of the mesh's polygons (each once; no triangulation diagonals) as lines: a wireframe drawn over
/// the shaded mesh, for flat models seen from one side.
SegmentLayer polygon_edges(const Mesh& mesh, Color color = {0.2f, 0.2f, 0.25f}, float width = 0.5f);

/// The python script and whether python3 with matplotlib runs here (checked once; `why_not` says what is missing).
std::string figures_script();
bool renderer_available(std::string* why_not = nullptr);

/// Writes the spec to `png_path` with ".json" for ".png" when `keep_spec`, else to a temporary file, and runs
/// the script. Throws InputError naming `png_path` when rendering fails.
void render(const Figure& figure, const std::string& png_path, bool keep_spec = false);

}  // namespace mlsdeform::cli

namespace mlsdeform::cli {

/// A panel with one shaded mesh and handles: the rest handles when `target` is null, else the targets and an
/// arrow from each moved handle's rest position to its target.
Panel mesh_panel(const std::string& title, const Mesh& mesh, const Handles<double>& rest,
                 const Handles<double>* target = nullptr);

}  // namespace mlsdeform::cli
