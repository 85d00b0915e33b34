// CancelCheck (cancel.hpp): a long call asks its caller's check between blocks of work and stops with
// Cancelled, changing nothing; an empty check, or one that never says stop, changes no bit of any result.
// Nothing here is timed: the checks are counted (the granularity is the documented block) and a check that
// says stop after a given number of calls shows where the call stops.
#include "tests/support/meshes.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#include <atomic>
#include <cstring>
#include <limits>
#include <numeric>
#include <vector>

using namespace mlsdeform;
using mlsdeform::testing::human;

namespace {

/// Handles on the two hands and the two feet (vertex positions of the human), the right hand moved.
std::pair<Handles<double>, Handles<double>> limb_handles() {
  Handles<double> rest, moved;
  rest.points.resize(4, 3);
  const Eigen::Index at[4] = {2445, 5907, 3365, 6765};
  for (int i = 0; i < 4; ++i) rest.points.row(i) = human().v.row(at[i]);
  moved = rest;
  moved.points.row(0) += Eigen::RowVector3d(0.05, 0.3, 0.1);
  return {rest, moved};
}

/// A check that counts its calls (from any thread) and says stop from call `stop_at` on.
struct Counter {
  std::atomic<long> calls{0};
  long stop_at = std::numeric_limits<long>::max();
  CancelCheck check() {
    return [this] { return calls.fetch_add(1, std::memory_order_relaxed) + 1 >= stop_at; };
  }
};

bool bitwise_equal(const Points<double>& a, const Points<double>& b) {
  return a.rows() == b.rows() && std::memcmp(a.data(), b.data(), sizeof(double) * std::size_t(a.size())) == 0;
}

}  // namespace

TEST_CASE("cancel: construction checks once per block of kLanes vertices and stops where told", "[cancel][deformer]") {
  const auto [rest, moved] = limb_handles();
  const Eigen::Index blocks = (human().v.rows() + 15) / 16;
  for (WeightStorage ws : {WeightStorage::precomputed, WeightStorage::on_the_fly}) {
    INFO("storage " << int(ws));
    Options o;
    o.threads = 1;
    o.weight_storage = ws;
    Counter never;
    const Deformer<double> d(human().v, rest, o, never.check());
    CHECK(never.calls == blocks);
    Points<double> with_check, without;
    d.deform(moved, with_check);
    Deformer<double>(human().v, rest, o).deform(moved, without);
    CHECK(bitwise_equal(with_check, without));

    Counter stop;
    stop.stop_at = blocks / 2;
    CHECK_THROWS_AS(Deformer<double>(human().v, rest, o, stop.check()), Cancelled);
    CHECK(stop.calls == blocks / 2);  // one thread: no block after the one that said stop
  }
  // On all cores the exception comes out of the TBB workers as itself.
  Options o;
  o.threads = 0;
  Counter first;
  first.stop_at = 1;
  CHECK_THROWS_AS(Deformer<double>(human().v, rest, o, first.check()), Cancelled);
  CHECK_THROWS_WITH(Deformer<double>(human().v, rest, o, [] { return true; }),
                    Catch::Matchers::ContainsSubstring("cancelled"));
}

TEST_CASE("cancel: reset_rest_pose leaves the session as it was", "[cancel][deformer]") {
  const auto [rest, moved] = limb_handles();
  Options o;
  o.threads = 2;
  Deformer<double> d(human().v, rest, o);
  Points<double> before, after;
  d.deform(moved, before);
  const Points<double> shifted = human().v.rowwise() + Eigen::RowVector3d(1, 2, 3);
  CHECK_THROWS_AS(d.reset_rest_pose(shifted, rest, [] { return true; }), Cancelled);
  d.deform(moved, after);
  CHECK(bitwise_equal(before, after));
}

TEST_CASE("cancel: ARAP iterations stop between iterations with out untouched", "[cancel][deformer][arap]") {
  const auto [rest, moved] = limb_handles();
  for (int threads : {1, 0}) {
    INFO("threads " << threads);
    Options o;
    o.threads = threads;
    o.arap_iterations = 5;
    const Deformer<double> d(human().v, human().f, rest, o);
    Points<double> reference;
    d.deform(moved, reference);

    // A check that never says stop: asked before every 64 blocks of the MLS pass (into the refinement's
    // scratch) and once per iteration, every bit as without it. With one thread the pass is one range:
    // ceil(blocks / 64) checks.
    Counter never;
    Points<double> same;
    d.deform(moved, same, never.check());
    const long mls_checks = (human().v.rows() + 16 * 64 - 1) / (16 * 64);
    if (threads == 1)
      CHECK(never.calls == mls_checks + o.arap_iterations);
    else
      CHECK(never.calls >= mls_checks + o.arap_iterations);
    CHECK(bitwise_equal(same, reference));

    // Stopped before the third iteration (one thread), or anywhere in the frame: Cancelled, out as it was
    // (both outputs), and the session's scratch does not leak into the next frame.
    Counter stop;
    stop.stop_at = mls_checks + 3;
    Points<double> out = Points<double>::Constant(human().v.rows(), 3, -7.25);
    const Points<double> sentinel = out;
    CHECK_THROWS_AS(d.deform(moved, out, stop.check()), Cancelled);
    if (threads == 1) CHECK(stop.calls == stop.stop_at);
    CHECK(bitwise_equal(out, sentinel));
    PointsRowMajor<double> buffer = PointsRowMajor<double>::Constant(human().v.rows(), 3, -7.25);
    CHECK_THROWS_AS(d.deform(moved, InterleavedView<double>(buffer.data(), buffer.rows(), 3), [] { return true; }),
                    Cancelled);
    CHECK((buffer.array() == -7.25).all());
    Points<double> next;
    d.deform(moved, next);
    CHECK(bitwise_equal(next, reference));
  }
}

TEST_CASE("cancel: ArapRefiner::refine allows any iteration count and stops when told", "[cancel][arap]") {
  const auto [rest, moved] = limb_handles();
  const std::vector<Eigen::Index> constrained = {2445, 5907, 3365, 6765};
  ArapRefiner<double> arap(human().v, human().f, constrained);
  Points<double> targets = moved.points;
  Points<double> out = human().v;
  const Points<double> before = out;
  Counter stop;
  stop.stop_at = 4;
  CHECK_THROWS_AS(arap.refine(human().v, targets, std::numeric_limits<int>::max(), out, stop.check()), Cancelled);
  CHECK(stop.calls == 4);
  CHECK(bitwise_equal(out, before));
}

TEST_CASE("cancel: the region's nearest-vertex scan stops when told", "[cancel][region]") {
  const auto [rest, moved] = limb_handles();
  Options o;
  o.threads = 1;
  o.region.resize(200);
  std::iota(o.region.begin(), o.region.end(), Eigen::Index(0));
  Counter stop;
  stop.stop_at = 50;
  CHECK_THROWS_AS(Deformer<double>(human().v, rest, o, stop.check()), Cancelled);  // no triangles: the scan
  CHECK(stop.calls == 50);
}

TEST_CASE("cancel: the MLS pass stops between chunks of blocks, bitwise as unchecked otherwise", "[cancel][deformer]") {
  // On-the-fly weights with many handles make one MLS pass long (n x k work): it checks before every 64
  // blocks (1,024 vertices). Without ARAP it writes `out` directly, so a stopped pass leaves `out` partly
  // written (deformer.hpp); the check never changes a bit of a pass it does not stop.
  const auto [rest, moved] = limb_handles();
  for (WeightStorage ws : {WeightStorage::precomputed, WeightStorage::on_the_fly})
    for (int threads : {1, 0}) {
      INFO("threads " << threads << (ws == WeightStorage::on_the_fly ? ", on the fly" : ", precomputed"));
      Options o;
      o.threads = threads;
      o.weight_storage = ws;
      const Deformer<double> d(human().v, rest, o);
      Points<double> reference, same;
      d.deform(moved, reference);
      Counter never;
      d.deform(moved, same, never.check());
      const long checks = (human().v.rows() + 16 * 64 - 1) / (16 * 64);
      if (threads == 1)
        CHECK(never.calls == checks);
      else
        CHECK(never.calls >= checks);
      CHECK(bitwise_equal(same, reference));
      Counter stop;
      stop.stop_at = 2;
      Points<double> out;
      CHECK_THROWS_AS(d.deform(moved, out, stop.check()), Cancelled);
      if (threads == 1) CHECK(stop.calls == 2);
      Points<double> next;
      d.deform(moved, next);
      CHECK(bitwise_equal(next, reference));
    }
}
