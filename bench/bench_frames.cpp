// The cost of frames (FramesOut: each vertex's rotation, scale, linear part, mlsdeform/frames.hpp) beside the
// positions, rigid MLS in float at 10^6 vertices (random points in a 4 x 1 x 1 box, 10 handles twisted and bent:
// tests/support/deform_cases.hpp), one thread (its CPU time: robust to other processes on a shared machine),
// Options::isa unset, for both weight storages:
//   frames/<storage>/positions        deform() alone
//   frames/<storage>/quaternions      positions + quaternions (n x 4)
//   frames/<storage>/quaternions+linear  positions + quaternions + the linear part (n x 9)
//   frames/<storage>/all              positions + quaternions, rotations, scales and linear
//   frames/affine/positions, frames/affine/linear   Transform::affine (precomputed: its only storage) with
//                                     Options::affine_frames, deform() alone and with the fit's matrix (n x 9: a
//                                     second pass over the handles)
// Counters: ms_per_frame, fps; the ratio to `positions` in the same run is the figure (docs/api.md, "Frames";
// the target: at most 1.2). Each variant first checks that its positions are bitwise those of deform()
// without frames.
#include "bench/deform_common.hpp"

#include <mlsdeform/deformer.hpp>

#include <cstring>
#include <string>
#include <vector>

namespace {

using T = float;
using mlsdeform::WeightStorage;

const bench::DeformCase& scene() {
  static const bench::DeformCase s =
      mlsdeform::testing::twisted_mesh_case("box", mlsdeform::testing::random_box(1000000, 7), 10, 21);
  return s;
}

enum class Wanted { positions, quaternions, quaternions_linear, all, linear };

void bm(benchmark::State& state, WeightStorage storage, Wanted wanted, bool affine = false) {
  mlsdeform::Options o = bench::deformer_options(std::nullopt, 1, storage);
  o.precompute_budget_bytes = std::size_t(1) << 30;  // 10^6 vertices x 10 handles x 16 bytes: 160 MB
  if (affine) o.transform = mlsdeform::Transform::affine;
  o.affine_frames = affine;  // the fit's matrix table, for linear (positions read alpha alone either way)
  const mlsdeform::Deformer<T> d(scene().vertices.cast<T>(), bench::point_handles<T>(scene().rest.points), o);
  const mlsdeform::Handles<T> moved = bench::point_handles<T>(scene().moved.points);
  const std::size_t n = std::size_t(d.vertex_count());
  std::vector<T> q(4 * n), r(9 * n), s(n), l(9 * n);
  mlsdeform::FramesOut<T> frames;
  if (wanted != Wanted::positions && wanted != Wanted::linear) frames.quaternions = q;
  if (wanted == Wanted::quaternions_linear || wanted == Wanted::all || wanted == Wanted::linear) frames.linear = l;
  if (wanted == Wanted::all) frames.rotations = r, frames.scales = s;
  mlsdeform::Points<T> out, plain;
  d.deform(moved, plain);
  d.deform(moved, out, frames);
  if (std::memcmp(out.data(), plain.data(), sizeof(T) * std::size_t(out.size())) != 0) {
    state.SkipWithError("positions with frames differ from deform() without frames");
    return;
  }
  bench::time_frames<T>(state, out, [&] { d.deform(moved, out, frames); });
  state.counters["vertices"] = static_cast<double>(n);
}

}  // namespace

int main(int argc, char** argv) {
  for (WeightStorage st : {WeightStorage::precomputed, WeightStorage::on_the_fly}) {
    const std::string s = st == WeightStorage::precomputed ? "precomputed" : "on_the_fly";
    for (auto [w, name] : {std::pair{Wanted::positions, "positions"}, std::pair{Wanted::quaternions, "quaternions"},
                           std::pair{Wanted::quaternions_linear, "quaternions+linear"}, std::pair{Wanted::all, "all"}})
      benchmark::RegisterBenchmark(("frames/" + s + "/" + name).c_str(), [=](benchmark::State& state) {
        bm(state, st, w);
      })->Unit(benchmark::kMillisecond);
  }
  for (auto [w, name] : {std::pair{Wanted::positions, "positions"}, std::pair{Wanted::linear, "linear"}})
    benchmark::RegisterBenchmark(("frames/affine/" + std::string(name)).c_str(), [=](benchmark::State& state) {
      bm(state, WeightStorage::precomputed, w, true);
    })->Unit(benchmark::kMillisecond);
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
