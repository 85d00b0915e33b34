// See figures.hpp: the layout and the panels the figures share.
#include "tools/cli/figures/figures.hpp"

#include <utility>

namespace mlsdeform::cli {

Figure laid_out(std::string title, std::string caption, const Layout& layout, std::vector<Panel> panels) {
  Figure fig;
  fig.title = std::move(title);
  fig.caption = std::move(caption);
  fig.rows = layout.rows;
  fig.cols = layout.cols;
  fig.panel_width = layout.panel_width;
  fig.panel_height = layout.panel_height;
  fig.panels = std::move(panels);
  for (auto& p : fig.panels) {
    p.elev = layout.elev;
    p.azim = layout.azim;
  }
  return fig;
}

std::vector<Panel> two_rows(std::vector<Panel> top, const std::vector<Panel>& bottom) {
  top.insert(top.end(), bottom.begin(), bottom.end());
  return top;
}

Mesh deformed(const Scene& scene) { return with_vertices(scene.mesh, run_scene<double>(scene).result); }

Panel rest_panel(const Scene& scene, const std::string& title) { return mesh_panel(title, scene.mesh, scene.rest); }

Panel result_panel(const std::string& title, const Scene& scene, const Mesh& result) {
  return mesh_panel(title, result, scene.rest, &scene.frames.back());
}

Panel result_panel(const std::string& title, const Scene& scene) { return result_panel(title, scene, deformed(scene)); }

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

}  // namespace mlsdeform::cli
