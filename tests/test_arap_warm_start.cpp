// Options::arap_warm_start: a session dragged a little per frame starts its ARAP iterations from its last
// result; a jump of the targets (beyond arap_warm_start_limit of the rest diagonal) starts from MLS again.
// Both branches are held bitwise against ArapRefiner called directly with the start each should use.
#include "tests/test_arap_common.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#include <cmath>
#include <vector>

using namespace mlsdeform;
using namespace mlsdeform::arap_test;

namespace {

Handles<double> end_handles(const Tube& t, double angle, double lift) {
  Handles<double> h;
  h.points = end_targets(t, angle, lift);
  return h;
}

}  // namespace

TEST_CASE("ARAP warm start: small moves continue from the last result, jumps restart from MLS", "[arap][warm]") {
  const Tube t = tube(16, 20, 0.01, 7);
  const std::vector<Eigen::Index> c = ends(t);
  const Handles<double> rest = end_handles(t, 0, 0);
  // The tube's diagonal is about 2.1: a limit of 0.05 allows moves up to ~0.1.
  for (ArapAcceleration acceleration : {ArapAcceleration::none, ArapAcceleration::anderson}) {
    INFO("acceleration " << int(acceleration));
    Options o;
    o.arap_iterations = 4;
    o.arap_acceleration = acceleration;
    Deformer<double> cold(t.v, t.f, rest, o);
    o.arap_warm_start = true;
    Deformer<double> warm(t.v, t.f, rest, o);
    ArapOptions ao;
    ao.acceleration = acceleration;
    ArapRefiner<double> arap(t.v, t.f, c, ao);  // the point handles sit on the end rings' vertices, in order
    Points<double> x_cold, x_warm, expected, previous;
    // First frame: no last result, so MLS's start, as without the option.
    const Handles<double> h1 = end_handles(t, 0.30, 0.10);
    cold.deform(h1, x_cold);
    warm.deform(h1, x_warm);
    CHECK(x_warm == x_cold);
    // A small move (the far ring turns 0.02 rad and rises 0.01: under 0.03 of movement): from the last result.
    // MLS interpolates point handles at vertices, so the constrained targets are the handles' exactly.
    previous = x_warm;
    const Handles<double> h2 = end_handles(t, 0.32, 0.11);
    warm.deform(h2, x_warm);
    arap.refine(previous, h2.points, o.arap_iterations, expected);
    CHECK(x_warm == expected);
    cold.deform(h2, x_cold);
    CHECK(x_warm != x_cold);
    // A jump (the far ring lifted by 0.5, a quarter of the tube's length): from MLS again.
    const Handles<double> h3 = end_handles(t, 0.32, 0.61);
    warm.deform(h3, x_warm);
    cold.deform(h3, x_cold);
    CHECK(x_warm == x_cold);
    // Dragging with the same targets keeps lowering the energy: each frame goes on from the last.
    double E = arap.energy(x_warm);
    for (int frame = 0; frame < 5; ++frame) {
      warm.deform(h3, x_warm);
      const double E1 = arap.energy(x_warm);
      // The ARAP tests' bound for an iteration (test_arap.cpp), with Anderson's slack for the energy it
      // compares (test_arap_anderson.cpp): far below the decrease a frame of 4 iterations makes here.
      CHECK(E1 <= E * (1 + 1e-10));
      E = E1;
    }
    INFO("after 5 more frames " << E << ", from MLS " << arap.energy(x_cold));
    CHECK(E < arap.energy(x_cold));
  }
}

TEST_CASE("ARAP warm start: a cancelled frame, or a limit of 0, starts from MLS", "[arap][warm]") {
  const Tube t = tube(12, 10, 0.01, 8);
  const Handles<double> rest = end_handles(t, 0, 0), h1 = end_handles(t, 0.3, 0.1), h2 = end_handles(t, 0.31, 0.1);
  Options o;
  o.arap_iterations = 3;
  Deformer<double> cold(t.v, t.f, rest, o);
  o.arap_warm_start = true;
  Deformer<double> warm(t.v, t.f, rest, o);
  Points<double> x_cold, x_warm;
  cold.deform(h2, x_cold);
  // The checks a frame makes: cancelling at the last one stops the ARAP iterations, whose start is then
  // spent, so the next frame starts from MLS; cancelling at the first stops MLS's pass, and the last result
  // stays the start.
  int checks = 0;
  warm.deform(h1, x_warm, [&] { return ++checks, false; });
  REQUIRE(checks > o.arap_iterations);
  int calls = 0;
  CHECK_THROWS_AS(warm.deform(h2, x_warm, [&] { return ++calls == checks; }), Cancelled);
  warm.deform(h2, x_warm);
  CHECK(x_warm == x_cold);
  Points<double> x_first = x_warm, expected;
  CHECK_THROWS_AS(warm.deform(h1, x_warm, [] { return true; }), Cancelled);
  warm.deform(h1, x_warm);
  ArapRefiner<double>(t.v, t.f, ends(t)).refine(x_first, h1.points, o.arap_iterations, expected);
  CHECK(x_warm == expected);
  o.arap_warm_start_limit = 0;  // any move at all is a jump; the same targets are not
  Deformer<double> strict(t.v, t.f, rest, o);
  strict.deform(h1, x_warm);
  strict.deform(h2, x_warm);
  CHECK(x_warm == x_cold);
  for (double bad : {-1.0, std::nan(""), HUGE_VAL}) {
    o.arap_warm_start_limit = bad;
    CHECK_THROWS_WITH(Deformer<double>(t.v, t.f, rest, o), Catch::Matchers::ContainsSubstring("arap_warm_start_limit"));
  }
}
