// WeightStorage::on_the_fly and WeightStorage::precomputed_weights against the precomputed table, scalar and
// SIMD, and their limits.
#include "kernels/contract.hpp"
#include "tests/test_deformer_common.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

using namespace mlsdeform;

namespace {

using mlsdeform::testing::DeformCase;

// Vertices in the unit cube, k handles among them (so some vertices sit exactly on handles), moved by a
// twist of up to `angle` about z (tests/support/deform_cases.hpp, no noise).
template <class T>
DeformCase<T> scene(Eigen::Index n, int k, double angle, std::uint64_t seed) {
  return mlsdeform::testing::twisted_cube_case<T>(n, k, 0, false, angle, 0.0, seed);
}

}  // namespace

TEMPLATE_TEST_CASE("on-the-fly weights agree with the precomputed table", "[deformer][on_the_fly]", float, double) {
  using T = TestType;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  const DeformCase<T> s = scene<T>(3000, 10, 2.5, 11);
  for (Transform tr : {Transform::rigid, Transform::similarity})
    for (const std::optional<Isa> isa : {std::optional<Isa>(Isa::scalar), std::optional<Isa>()})
      for (double u : {2.0, 3.0}) {
        INFO("transform " << int(tr) << " isa " << (isa ? to_string(*isa) : "active") << " u " << u);
        Options o;
        o.transform = tr;
        o.isa = isa;
        o.weight_exponent = u;
        o.weight_storage = WeightStorage::precomputed;
        const Deformer<T> pre(s.vertices, s.rest, o);
        o.weight_storage = WeightStorage::on_the_fly;
        const Deformer<T> fly(s.vertices, s.rest, o);
        CHECK(pre.uses_precomputed_weights());
        CHECK(!fly.uses_precomputed_weights());
        // 24 bytes per vertex (float) against 16 per vertex and handle.
        CHECK(fly.memory_bytes() < pre.memory_bytes() / 4);
        Points<T> a, b;
        pre.deform(s.moved, a);
        fly.deform(s.moved, b);
        REQUIRE(b.allFinite());
        for (int i = 0; i < 10; ++i) CHECK(b.row(i) == s.moved.points.row(i));  // vertices on handles: exact
        // The two paths compute the same weights (double then rounded, against T relative to the vertex):
        // H agrees to a few eps relative, the rotations to c eps kappa, kappa = O(1) with ten handles spread
        // in the cube; |vhat| <= 2 sqrt(3). 256 eps allows c kappa up to about 70 (measured: below 16 eps).
        CHECK((a - b).cwiseAbs().maxCoeff() <= T(256) * eps);
      }
}

TEST_CASE("on-the-fly weights: unsupported settings are refused, automatic follows the budget",
          "[deformer][on_the_fly]") {
  const DeformCase<float> s = scene<float>(2000, 8, 1.0, 3);
  Options o;
  o.weight_storage = WeightStorage::on_the_fly;
  o.transform = Transform::affine;
  CHECK_THROWS_WITH(Deformer<float>(s.vertices, s.rest, o),
                    Catch::Matchers::ContainsSubstring("point handles and MLS centroids only"));
  o.transform = Transform::rigid;
  Handles<float> seg = s.rest;
  seg.segment_a = s.rest.points.topRows(1);
  seg.segment_b = s.rest.points.bottomRows(1);
  CHECK_THROWS_WITH(Deformer<float>(s.vertices, seg, o),
                    Catch::Matchers::ContainsSubstring("point handles and MLS centroids only"));
  o.weight_storage = WeightStorage::automatic;
  CHECK(Deformer<float>(s.vertices, s.rest, o).uses_precomputed_weights());  // 2000 x 8 x 16 B << 64 MiB
  o.precompute_budget_bytes = 1000;
  CHECK(!Deformer<float>(s.vertices, s.rest, o).uses_precomputed_weights());
  // Segments and affine have no on-the-fly weights: over the budget they are refused, naming the budget.
  CHECK_THROWS_WITH(Deformer<float>(s.vertices, seg, o), Catch::Matchers::ContainsSubstring("precompute_budget_bytes"));
  o.transform = Transform::affine;
  CHECK_THROWS_WITH(Deformer<float>(s.vertices, s.rest, o),
                    Catch::Matchers::ContainsSubstring("precompute_budget_bytes"));
  // Within the budget, or asked for explicitly, they are precomputed; automatic never exceeds the budget.
  o.precompute_budget_bytes = std::size_t(1) << 20;
  const Deformer<float> affine(s.vertices, s.rest, o);
  CHECK(affine.uses_precomputed_weights());
  o.transform = Transform::rigid;
  const Deformer<float> segments(s.vertices, seg, o);
  CHECK(segments.uses_precomputed_weights());
  // The table (2000 vertices padded to 2000, 10 pseudo-handles, 16 bytes) is the bulk of memory_bytes().
  CHECK(segments.memory_bytes() >= std::size_t(2000) * 10 * 16);
  CHECK(segments.memory_bytes() <= std::size_t(1) << 20);
  o.precompute_budget_bytes = 1000;
  o.weight_storage = WeightStorage::precomputed;
  CHECK(Deformer<float>(s.vertices, seg, o).uses_precomputed_weights());
}

// WeightStorage::automatic's rule (precompute.cpp, choose_storage): where the weights alone are supported, on
// AVX-512 the weights while they fit the budget, elsewhere the table while it stays within 16 MiB (and the
// budget), then the weights while they fit the budget; then on the fly. Each choice must be the explicit
// storage's session: the same memory and the same bits. Every ISA the CPU runs, as Options::isa.
TEST_CASE("automatic weight storage: the table in the cache (not on AVX-512), then the weights alone, then on the fly",
          "[deformer][on_the_fly][precomputed_weights]") {
  for (const Isa isa : supported_isas()) {
    INFO("isa " << to_string(isa));
    const auto session = [isa](const DeformCase<float>& s, WeightStorage w, std::size_t budget) {
      Options o;
      o.weight_storage = w;
      o.precompute_budget_bytes = budget;
      o.isa = isa;
      return Deformer<float>(s.vertices, s.rest, o);
    };
    const auto same = [](const Deformer<float>& a, const Deformer<float>& b, const Handles<float>& moved) {
      Points<float> x, y;
      a.deform(moved, x);
      b.deform(moved, y);
      return a.memory_bytes() == b.memory_bytes() && (x.array() == y.array()).all();
    };
    constexpr std::size_t MiB = std::size_t(1) << 20;
    // 2,000 x 8: a 0.25 MiB table. 20,000 x 64: a 19.5 MiB table (over 16 MiB), 4.9 MiB of weights.
    const DeformCase<float> small = scene<float>(2000, 8, 1.0, 3), large = scene<float>(20000, 64, 1.0, 5);
    const WeightStorage in_cache = isa == Isa::avx512 ? WeightStorage::precomputed_weights : WeightStorage::precomputed;
    const Deformer<float> chosen = session(small, WeightStorage::automatic, 32 * MiB);
    CHECK(same(chosen, session(small, in_cache, 0), small.moved));
    for (const std::size_t budget : {32 * MiB, 64 * MiB}) {
      INFO("budget " << budget / MiB << " MiB");
      CHECK(same(session(large, WeightStorage::automatic, budget),
                 session(large, WeightStorage::precomputed_weights, 0), large.moved));
    }
    const Deformer<float> tight = session(large, WeightStorage::automatic, 4 * MiB);
    CHECK(!tight.uses_precomputed_weights());
    CHECK(same(tight, session(large, WeightStorage::on_the_fly, 0), large.moved));
  }
}

TEMPLATE_TEST_CASE("precomputed weights agree with the precomputed table", "[deformer][precomputed_weights]", float,
                   double) {
  using T = TestType;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  const DeformCase<T> s = scene<T>(3000, 10, 2.5, 11);
  for (Transform tr : {Transform::rigid, Transform::similarity})
    for (const std::optional<Isa> isa : {std::optional<Isa>(Isa::scalar), std::optional<Isa>()})
      for (double u : {2.0, 3.0}) {
        INFO("transform " << int(tr) << " isa " << (isa ? to_string(*isa) : "active") << " u " << u);
        Options o;
        o.transform = tr;
        o.isa = isa;
        o.weight_exponent = u;
        o.weight_storage = WeightStorage::precomputed;
        const Deformer<T> pre(s.vertices, s.rest, o);
        o.weight_storage = WeightStorage::precomputed_weights;
        const Deformer<T> wts(s.vertices, s.rest, o);
        CHECK(wts.uses_precomputed_weights());
        // 4 bytes per vertex and handle and 28 per vertex (float) against 16 per vertex and handle and 24.
        CHECK(wts.memory_bytes() < pre.memory_bytes() / 2);
        Points<T> a, b, c;
        pre.deform(s.moved, a);
        wts.deform(s.moved, b);
        REQUIRE(b.allFinite());
        for (int i = 0; i < 10; ++i) CHECK(b.row(i) == s.moved.points.row(i));  // vertices on handles: exact
        // Both paths take their weights from double, rounded once to T; this one forms A_j = (w_j / S) phat_j
        // in T from coordinates relative to the vertex (a few roundings of |phat_j| each), as the on-the-fly
        // pass does: the same bound as there (256 eps: c kappa up to about 70 with |vhat| <= 2 sqrt(3)).
        CHECK((a - b).cwiseAbs().maxCoeff() <= T(256) * eps);
        // Each vertex's sums run over the handles in one order: bitwise the same on one thread.
        o.threads = 1;
        Deformer<T>(s.vertices, s.rest, o).deform(s.moved, c);
        CHECK(c == b);
      }
}

TEMPLATE_TEST_CASE("stored and on-the-fly weights, with and without cached targets, agree with the direct evaluation",
                   "[deformer][on_the_fly][precomputed_weights]", float, double) {
  using T = TestType;
  std::mt19937_64 g(deformer_test::seed());
  INFO("seed " << deformer_test::seed());
  // 520 point handles: more than a frame computes once (kCachedTargets), so each batch forms its targets itself
  // (for_each_point_target's second loop); 8: the cached targets. Rigid sessions skip D, similarity's own sum.
  static_assert(520 > kernels::kCachedTargets);
  for (Transform tr : {Transform::rigid, Transform::similarity})
    for (WeightStorage ws : {WeightStorage::on_the_fly, WeightStorage::precomputed_weights})
      for (Eigen::Index k : {8, 520}) {
        INFO(deformer_test::name(tr) << ", storage " << int(ws) << ", " << k << " point handles");
        const DeformCase<T> sc = deformer_test::random_case<T>(g, 300, k);
        Options o;
        o.transform = tr;
        o.weight_storage = ws;
        const deformer_test::Mat3d M = deformer_test::random_rotation(g) *
                                       (deformer_test::Mat3d::Identity() +
                                        0.3 * deformer_test::Mat3d(deformer_test::random_vector(g).asDiagonal()));
        const Handles<T> moved = deformer_test::transformed(sc.rest, M, deformer_test::random_vector(g));
        Points<T> out;
        Deformer<T>(sc.vertices, sc.rest, o).deform(moved, out);
        const deformer_test::Comparison c = deformer_test::compare_with_direct(out, sc.vertices, sc.rest, moved, o);
        INFO("max deviation " << c.max_dev << ", max deviation / bound " << c.max_ratio << ", ill-posed "
                              << c.ill_posed);
        CHECK(c.failures == 0);
        CHECK(c.ill_posed == 0);
      }
}

TEST_CASE("precomputed weights: unsupported settings are refused, frames as on the fly",
          "[deformer][precomputed_weights]") {
  const DeformCase<float> s = scene<float>(2000, 8, 1.0, 3);
  Options o;
  o.weight_storage = WeightStorage::precomputed_weights;
  o.transform = Transform::affine;
  CHECK_THROWS_WITH(Deformer<float>(s.vertices, s.rest, o),
                    Catch::Matchers::ContainsSubstring("precomputed_weights supports") &&
                        Catch::Matchers::ContainsSubstring("point handles"));
  o.transform = Transform::rigid;
  Handles<float> seg = s.rest;
  seg.segment_a = s.rest.points.topRows(1);
  seg.segment_b = s.rest.points.bottomRows(1);
  CHECK_THROWS_WITH(Deformer<float>(s.vertices, seg, o),
                    Catch::Matchers::ContainsSubstring("point handles and MLS centroids only"));
  o.centroids = Centroids::rbf;
  CHECK_THROWS_WITH(Deformer<float>(s.vertices, s.rest, o), Catch::Matchers::ContainsSubstring("Centroids::rbf"));
  o.centroids = Centroids::mls;
  // Frames: the rotations of the on-the-fly path to its bound; at a vertex on a handle the fit's limit there, from
  // one computation for every storage (near_handles.hpp): the same bits (its accuracy: test_frames_near_handles).
  const Deformer<float> wts(s.vertices, s.rest, o);
  o.weight_storage = WeightStorage::on_the_fly;
  const Deformer<float> fly(s.vertices, s.rest, o);
  const std::size_t n = std::size_t(s.vertices.rows());
  std::vector<float> qa(4 * n), qb(4 * n);
  Points<float> a, b;
  FramesOut<float> fa, fb;
  fa.quaternions = qa;
  fb.quaternions = qb;
  wts.deform(s.moved, a, fa);
  fly.deform(s.moved, b, fb);
  for (std::size_t v = 0; v < 8; ++v) {  // the vertices on the eight handles
    for (std::size_t c = 0; c < 4; ++c) CHECK(qa[4 * v + c] == qb[4 * v + c]);
    CHECK(qa[4 * v] < 1.0f);  // not the identity: the scene's handles are moved by a twist
  }
  float worst = 0;
  for (std::size_t i = 0; i < 4 * n; ++i) worst = std::max(worst, std::abs(qa[i] - qb[i]));
  CHECK(worst <= 256 * std::numeric_limits<float>::epsilon());
}
