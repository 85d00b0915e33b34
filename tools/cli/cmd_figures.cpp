// `mlsdeform figures`: the paper's Fig. 1 to 8 redrawn from our deformer, and MLS against MLS + ARAP
// (arap.png), as PNG files (by default in the source tree's docs/figures/, which README.md shows). The figures
// themselves are in tools/cli/figures/.
#include <mlsdeform/files_error.hpp>
#include "core/files/mesh.hpp"
#include "tools/cli/commands.hpp"
#include "tools/cli/figures/figures.hpp"
#include "tools/cli/render.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace mlsdeform::cli {

namespace {

namespace fs = std::filesystem;

// The shared meshes (../shared/data/meshes beside the source tree, or $MLSDEFORM_MESHES): fish.obj for Fig. 2.
// Absent in a checkout of the repository alone.
std::string shared_mesh_dir() {
  if (const char* env = std::getenv("MLSDEFORM_MESHES"); env && *env) return env;
  return MLSDEFORM_SHARED_MESHES;
}

struct KnownFigure {
  std::string name;  ///< for --only
  std::string file;
  std::function<Figure()> draw;
};

}  // namespace

int run_figures(const FiguresArgs& a) {
  const auto human = [&] { return read_mesh((fs::path(data_dir(a.data_dir)) / "human_man.obj").string()); };
  const fs::path fish = fs::path(shared_mesh_dir()) / "fish.obj";
  // The paper's figures by number, then ours.
  const std::vector<KnownFigure> known = {{"1", "fig1.png", [&] { return figure_1(human()); }},
                                          {"2", "fig2.png", [&] { return figure_2(read_mesh(fish.string())); }},
                                          {"3", "fig3.png", figure_3},
                                          {"4", "fig4.png", figure_4},
                                          {"5", "fig5.png", figure_5},
                                          {"6", "fig6.png", figure_6},
                                          {"7", "fig7.png", figure_7},
                                          {"8", "fig8.png", figure_8},
                                          {"arap", "arap.png", [&] { return figure_arap(human()); }}};
  std::set<std::string> wanted;
  if (a.only.empty()) {
    for (const auto& k : known) wanted.insert(k.name);
  } else {
    std::stringstream ss(a.only);
    std::string item;
    while (std::getline(ss, item, ',')) {
      if (std::none_of(known.begin(), known.end(), [&](const auto& k) { return k.name == item; }))
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

  for (const auto& k : known) {
    if (!wanted.count(k.name)) continue;
    if (k.name == "2" && !fs::exists(fish)) {
      std::printf("skipped %s: %s not found (the shared meshes; set MLSDEFORM_MESHES to their folder)\n",
                  k.file.c_str(), fish.string().c_str());
      continue;
    }
    const auto t0 = std::chrono::steady_clock::now();
    const Figure fig = k.draw();
    const std::string png = (fs::path(out_dir) / k.file).string();
    render(fig, png, a.keep_spec);
    std::printf("%s (%.1f s)\n", png.c_str(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return 0;
}

}  // namespace mlsdeform::cli
