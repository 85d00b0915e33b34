// `mlsdeform demo`: what a new user runs first. Deforms the bundled human mesh and the paper's generated bar and
// cylinder (Table 2's sizes), times Deformer::deform with the scalar and the SIMD backend, runs the human again
// with surface-ARAP iterations after MLS, and writes the results (in several formats) and before/after images
// into one folder.
#include <mlsdeform/files_error.hpp>
#include "core/files/mesh.hpp"
#include "tools/cli/commands.hpp"
#include "tools/cli/render.hpp"
#include "tools/cli/scenes.hpp"

#include <mlsdeform/dispatch.hpp>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <thread>

namespace mlsdeform::cli {

std::string data_dir(const std::string& from_args) {
  if (!from_args.empty()) return from_args;
  if (const char* env = std::getenv("MLSDEFORM_DATA_DIR"); env && *env) return env;
  // An installed program (`cmake --install`, or the Python wheel's bin/mlsdeform) has its data beside it in
  // <prefix>/share/mlsdeform/data: the source tree it was built from may be gone.
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const std::filesystem::path installed = exe.parent_path().parent_path() / "share" / "mlsdeform" / "data";
    if (std::filesystem::is_directory(installed, ec)) return installed.string();
  }
  return MLSDEFORM_DATA_DIR;
}

namespace {

// Surface-ARAP iterations the demo runs after MLS on the human (Options::arap_iterations).
constexpr int kDemoArapIterations = 10;

struct DemoScene {
  Scene scene;
  std::string output;  ///< file name of the deformed mesh
  double elev = 12, azim = -65;
};

template <class T>
int demo(const DemoArgs& a) {
  namespace fs = std::filesystem;
  const fs::path out_dir = a.out_dir;
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec || !fs::is_directory(out_dir)) throw InputError(a.out_dir, "cannot create the output folder: " + ec.message());
  std::printf("mlsdeform demo: results go to %s/\n", out_dir.string().c_str());
  std::printf("SIMD backend: %s, %zu lanes of %s\n", std::string(to_string(checked_active_isa())).c_str(),
              simd_lanes<T>(), std::is_same_v<T, float> ? "float" : "double");
  std::printf("precision %s, %s; frames/s count Deformer::deform only (set-up excluded)\n\n",
              std::is_same_v<T, float> ? "float" : "double",
              a.threads > 0 ? (std::to_string(a.threads) + " threads").c_str()
                            : ("all cores (" + std::to_string(std::thread::hardware_concurrency()) + ")").c_str());

  std::vector<DemoScene> scenes;
  const fs::path human_path = fs::path(data_dir(a.data_dir)) / "human_man.obj";
  const bool has_human = fs::exists(human_path);  // then scenes[0]
  if (has_human) {
    scenes.push_back({human_bend_scene(read_mesh(human_path.string()), a.frames), "human_bent.obj", 10, -60});
  } else {
    std::printf("(skipping the human: %s not found; --data-dir or MLSDEFORM_DATA_DIR names the data folder)\n",
                human_path.string().c_str());
  }
  scenes.push_back({bar_twist_scene(std::max(a.frames, 2), 180), "bar_twisted.ply", 20, -60});
  scenes.push_back({cylinder_scene(2.0, a.frames, 120), "cylinder_rotated.off", 8, -90});
  scenes.push_back({bar_bend_scene(2, a.frames), "bar_bent_segments.ply.gz", 8, -90});

  std::printf("%-24s %8s %8s %6s %11s %11s %8s %12s\n", "scene", "vertices", "handles", "frames", "scalar f/s",
              "simd f/s", "speed-up", "max |d|");
  std::vector<std::string> written;
  Points<double> human_mls;  // the human's SIMD result, to compare with MLS + ARAP below
  for (const auto& ds : scenes) {
    const Scene& s = ds.scene;
    const SceneRun scalar = run_scene<T>(s, Isa::scalar, a.threads);
    const SceneRun simd = run_scene<T>(s, std::nullopt, a.threads);
    const double diff = (scalar.result - simd.result).cwiseAbs().maxCoeff();
    const auto handles = s.rest.point_count() + s.rest.segment_count();
    std::printf("%-24s %8lld %8lld %6zu %11.1f %11.1f %7.2fx %12.2e\n", s.name.c_str(),
                static_cast<long long>(s.mesh.vertex_count()), static_cast<long long>(handles), s.frames.size(),
                scalar.frames_per_second(), simd.frames_per_second(),
                simd.frames_per_second() / scalar.frames_per_second(), diff);
    std::printf("  %s\n", s.description.c_str());
    const Mesh result = with_vertices(s.mesh, simd.result);
    write_mesh(result, (out_dir / ds.output).string(), {/*force=*/true, PlyEncoding::binary, NormalsOut::computed});
    written.push_back(ds.output);
    if (has_human && &ds == &scenes.front()) human_mls = simd.result;
  }
  std::printf("(max |d|: the largest coordinate difference between the two backends' results)\n\n");

  // The same human frames with surface-ARAP iterations after MLS (`deform --arap N`), SIMD backend only.
  Points<double> human_arap;
  if (has_human) {
    Scene s = scenes.front().scene;
    s.options.arap_iterations = kDemoArapIterations;
    const SceneRun run = run_scene<T>(s, std::nullopt, a.threads);
    human_arap = run.result;
    std::printf("human + %d ARAP iterations (deform --arap %d): %.1f f/s simd, moves vertices up to %.3f from MLS\n\n",
                kDemoArapIterations, kDemoArapIterations, run.frames_per_second(),
                (human_arap - human_mls).rowwise().norm().maxCoeff());
    write_mesh(with_vertices(s.mesh, human_arap), (out_dir / "human_bent_arap.obj").string(),
               {/*force=*/true, PlyEncoding::binary, NormalsOut::computed});
    written.push_back("human_bent_arap.obj");
  }

  std::string why;
  if (!a.images) {
    std::printf("images skipped (--no-images)\n");
  } else if (!renderer_available(&why)) {
    std::printf("images skipped: %s\n", why.c_str());
  } else {
    for (const auto& ds : scenes) {
      const Scene& s = ds.scene;
      // Redo the simd run for the picture (cheap next to rendering) rather than keep every result around.
      const SceneRun run = run_scene<T>(s, std::nullopt, a.threads);
      Figure fig;
      fig.title = s.description;
      fig.cols = 2;
      Panel before = mesh_panel("before", s.mesh, s.rest);
      Panel after = mesh_panel("after (" + std::to_string(s.frames.size()) + " frames)",
                               with_vertices(s.mesh, run.result), s.rest, &s.frames.back());
      before.elev = after.elev = ds.elev;
      before.azim = after.azim = ds.azim;
      fig.panels = {before, after};
      if (has_human && &ds == &scenes.front()) {
        Panel arap = mesh_panel("after, + " + std::to_string(kDemoArapIterations) + " ARAP iterations",
                                with_vertices(s.mesh, human_arap), s.rest, &s.frames.back());
        arap.elev = ds.elev;
        arap.azim = ds.azim;
        fig.panels.push_back(arap);
        fig.cols = 3;
      }
      const std::string png = s.name + ".png";
      render(fig, (out_dir / png).string());
      written.push_back(png);
    }
  }
  std::printf("wrote to %s/:", out_dir.string().c_str());
  for (const auto& w : written) std::printf(" %s", w.c_str());
  std::printf("\n");
  return 0;
}

}  // namespace

int run_demo(const DemoArgs& args) {
  return args.precision == Precision::single ? demo<float>(args) : demo<double>(args);
}

}  // namespace mlsdeform::cli
