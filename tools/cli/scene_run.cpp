// See scenes.hpp: run_scene.
#include "tools/cli/scenes.hpp"

#include <chrono>
#include <numeric>

namespace mlsdeform::cli {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

template <class T>
Handles<T> cast(const Handles<double>& h) {
  Handles<T> c;
  c.points = h.points.cast<T>();
  c.segment_a = h.segment_a.cast<T>();
  c.segment_b = h.segment_b.cast<T>();
  return c;
}

}  // namespace

double SceneRun::frames_per_second() const {
  const double total = std::accumulate(frame_seconds.begin(), frame_seconds.end(), 0.0);
  return total > 0 ? double(frame_seconds.size()) / total : 0.0;
}

template <class T>
SceneRun run_scene(const Scene& scene, std::optional<Isa> isa, int threads) {
  SceneRun run;
  Options options = scene.options;
  options.isa = isa;
  options.threads = threads;
  std::vector<Handles<T>> frames;
  frames.reserve(scene.frames.size());
  for (const auto& f : scene.frames) frames.push_back(cast<T>(f));

  Points<T> previous = to_points(scene.mesh).cast<T>(), out(previous.rows(), 3);
  auto t0 = Clock::now();
  Deformer<T> deformer = options.arap_iterations > 0 ? Deformer<T>(previous, fan_triangles(scene.mesh, scene.name),
                                                                   cast<T>(scene.rest), options)
                                                     : Deformer<T>(previous, cast<T>(scene.rest), options);
  run.setup_seconds = seconds_since(t0);
  // One untimed frame first: the first call pays for page faults on `out` and for starting TBB's workers.
  if (!frames.empty()) deformer.deform(frames[0], out);
  for (std::size_t f = 0; f < frames.size(); ++f) {
    if (scene.successive && f > 0) {
      previous.swap(out);
      t0 = Clock::now();
      deformer.reset_rest_pose(previous, frames[f - 1]);
      run.setup_seconds += seconds_since(t0);
    }
    t0 = Clock::now();
    deformer.deform(frames[f], out);
    run.frame_seconds.push_back(seconds_since(t0));
  }
  run.result = frames.empty() ? previous.template cast<double>() : out.template cast<double>();
  return run;
}

template SceneRun run_scene<float>(const Scene&, std::optional<Isa>, int);
template SceneRun run_scene<double>(const Scene&, std::optional<Isa>, int);

}  // namespace mlsdeform::cli
