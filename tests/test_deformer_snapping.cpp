// Snapping (core/src/deformer/snap.hpp) is decided by each vertex's own neighbourhood: a vertex far away from
// the model changes which vertices go exactly onto a handle nowhere else, and collapses nothing.
#include "tests/test_deformer_common.hpp"

#include <algorithm>
#include <array>
#include <vector>

using namespace deformer_test;

namespace {

/// Rows of `out` that equal some row of `targets` bitwise (vertices put exactly on a handle's target).
template <class T>
std::vector<Eigen::Index> on_targets(const Points<T>& out, Eigen::Index rows, const Points<T>& targets) {
  std::vector<Eigen::Index> on;
  for (Eigen::Index i = 0; i < rows; ++i)
    for (Eigen::Index j = 0; j < targets.rows(); ++j)
      if (out.row(i) == targets.row(j)) {
        on.push_back(i);
        break;
      }
  return on;
}

/// Pairs of rows among the first `rows` of `out` that are bitwise equal (distinct rest vertices collapsed).
template <class T>
std::size_t collapsed_pairs(const Points<T>& out, Eigen::Index rows) {
  std::vector<std::array<T, 3>> r(static_cast<std::size_t>(rows));
  for (Eigen::Index i = 0; i < rows; ++i) r[std::size_t(i)] = {out(i, 0), out(i, 1), out(i, 2)};
  std::sort(r.begin(), r.end());
  std::size_t pairs = 0;
  for (std::size_t i = 1; i < r.size(); ++i) pairs += r[i] == r[i - 1];
  return pairs;
}

}  // namespace

TEMPLATE_TEST_CASE("snapping is local: a far-away vertex snaps and collapses nothing else", "[deformer][snap]", float,
                   double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  // A 2-unit random cloud, 4 point handles, and one vertex far away on the x axis. A snapping radius of
  // 64 eps(T) times the model's diagonal grew with the stray: at 1e4 in float (radius 0.08) it put 808 of
  // 5,000 vertices exactly on a handle's target, at 1e5 all of them; in double the same from 1e13 on.
  // Now the radius is 64 eps(T) times each vertex's distance to its second-nearest handle (snap.hpp): the
  // vertices on a handle are those of the cloud alone, and distinct rest vertices stay distinct.
  const Eigen::Index n = 3000;
  Points<T> cloud = random_points<T>(g, n);
  Handles<T> rest;
  rest.points = random_points<T>(g, 4);
  // Vertex 0 on handle 0; vertex 1 a few ulps from handle 1 (well inside 64 eps(T) of the handle spacing,
  // about 1 here): both snap, with or without the stray.
  cloud.row(0) = rest.points.row(0);
  cloud.row(1) = rest.points.row(1);
  for (int c = 0; c < 3; ++c) cloud(1, c) = std::nextafter(std::nextafter(cloud(1, c), T(2)), T(2));
  const std::vector<double> strays =
      sizeof(T) == 4 ? std::vector<double>{1e4, 1e5, 1e6} : std::vector<double>{1e4, 1e10, 1e13};
  const Handles<T> moved = transformed(rest, 1.5 * random_rotation(g), random_vector(g));
  for (Transform tr : all_transforms)
    for (WeightStorage ws : {WeightStorage::precomputed, WeightStorage::on_the_fly}) {
      if (ws == WeightStorage::on_the_fly && tr == Transform::affine) continue;  // not offered
      Options o;
      o.transform = tr;
      o.weight_storage = ws;
      o.weight_exponent = 2;
      Points<T> clean;
      Deformer<T>(cloud, rest, o).deform(moved, clean);
      const std::vector<Eigen::Index> snapped = on_targets(clean, n, moved.points);
      CHECK(snapped == std::vector<Eigen::Index>{0, 1});
      REQUIRE(collapsed_pairs(clean, n) == 0);
      for (double x : strays) {
        // On-the-fly weights keep the rest vertices in T in the scene's frame, whose resolution the stray
        // coarsens (eps(T) x): beyond 1e4 in float two cloud vertices may share a rounded position.
        if (ws == WeightStorage::on_the_fly && x > 1e4 && sizeof(T) == 4) continue;
        INFO(name(tr) << (ws == WeightStorage::on_the_fly ? ", on the fly" : ", precomputed")
                      << ", stray at x = " << x);
        Points<T> v(n + 1, 3);
        v.topRows(n) = cloud;
        v.row(n) << T(x), T(0), T(0);
        Points<T> out;
        Deformer<T>(v, rest, o).deform(moved, out);
        REQUIRE(out.allFinite());
        CHECK(on_targets(out, n, moved.points) == snapped);
        CHECK(collapsed_pairs(out, n) == 0);
        // And every vertex within the library's derived bound of the direct evaluation (mls_reference.hpp),
        // in float. The precomputation's frame (centred on the bounding box, in double) rounds the rest
        // geometry to eps(double) times the box, which the stray inflates: 2e-16 x, below eps(float) of the
        // cloud up to x = 1e6, but in double beyond the bound's eps(double)-sized terms (not a snapping matter).
        if (ws == WeightStorage::precomputed && sizeof(T) == 4) {
          const Comparison c = compare_with_direct(out, v, rest, moved, o);
          INFO("max deviation " << c.max_dev << ", max deviation / bound " << c.max_ratio);
          CHECK(c.failures == 0);
        }
      }
    }
}
