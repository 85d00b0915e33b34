// ArapRefiner (surface ARAP started from the MLS result) and Options::arap_iterations.
//
// Bounds come from the global step's conditioning: refine() solves L_ff x = b for the free vertices with a
// backward-stable sparse Cholesky, so a perturbation db of the right-hand side (different rounding of the
// rotations) moves x by at most |db|_2 / lambda_min(L_ff), and the solve's own rounding is a few eps
// kappa(L_ff) |x|. The test computes lambda_min and kappa of L_ff independently (dense, long double, from its
// own cotangent weights) for the small tube it deforms.
#include "tests/support/accuracy_bounds.hpp"
#include "tests/support/isa_guard.hpp"
#include "tests/support/rotation_cases.hpp"
#include "tests/test_arap_common.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include "tests/support/catch.hpp"

#include <cmath>
#include <cstring>
#include <numbers>
#include <random>
#include <vector>

using namespace mlsdeform;
using LD = long double;

using namespace mlsdeform::arap_test;

TEST_CASE("ARAP: constrained vertices exact, energy decreasing every iteration", "[arap]") {
  const Tube t = tube(16, 20, 0.02, 1);
  const std::vector<Eigen::Index> c = ends(t);
  ArapOptions o;
  o.factorisation = GENERATE(ArapFactorisation::automatic, ArapFactorisation::supernodal_mit);
  ArapRefiner<double> arap(t.v, t.f, c, o);
  CHECK(arap.clamped_weights() > 0);  // the jitter makes obtuse angles: the clamp is exercised
  const Points<double> q = end_targets(t, 1.5, 0.4);
  // Start: the rest pose with the constraints applied (far from rigid: the far ring jumps).
  Points<double> x;
  arap.refine(t.v, q, 0, x);
  double E = arap.energy(x);
  // The energy at x with its optimal rotations, evaluated in double over ~2,000 terms of one sign: relative
  // rounding below 2000 eps ~ 5e-13; each local and global step does not increase it in exact arithmetic
  // (rotation and solve errors enter only at second order at the optimum of each step).
  for (int it = 1; it <= 12; ++it) {
    arap.refine(x, q, 1, x);
    const double E1 = arap.energy(x);
    INFO("iteration " << it << ": " << E << " -> " << E1);
    CHECK(E1 <= E * (1 + 1e-12));
    E = E1;
    for (std::size_t k = 0; k < c.size(); ++k) CHECK(x.row(c[k]) == q.row(Eigen::Index(k)));  // bitwise
  }
}

TEST_CASE("ARAP: a rigid motion of every handle gives that motion", "[arap]") {
  const Tube t = tube(12, 10, 0.02, 2);
  const std::vector<Eigen::Index> c = ends(t);
  ArapOptions o;
  o.factorisation = GENERATE(ArapFactorisation::automatic, ArapFactorisation::supernodal_mit);
  ArapRefiner<double> arap(t.v, t.f, c, o);
  const auto [moved, q] = rigid_motion(t, c);
  // From the rest pose (constraints moved), the iterations converge to the rigid motion; from the motion
  // itself, they stay there to the solve's rounding: |dx| <= 16 eps kappa(L_ff) max |x| (16: the rounding
  // of R p + t and of the right-hand side's few terms per vertex, first order).
  Points<double> x;
  arap.refine(moved, q, 3, x);
  const Conditioning k = conditioning(t);
  const LD bound = 16 * std::numeric_limits<double>::epsilon() * k.kappa * moved.cwiseAbs().maxCoeff();
  INFO("kappa(L_ff) = " << double(k.kappa));
  CHECK(LD((x - moved).cwiseAbs().maxCoeff()) <= bound);
  arap.refine(t.v, q, 200, x);
  CHECK((x - moved).cwiseAbs().maxCoeff() < 1e-6);
}

TEST_CASE("ARAP: bitwise the same for any thread count", "[arap]") {
  const Tube t = tube(24, 40, 0.02, 3);
  const std::vector<Eigen::Index> c = ends(t);
  const Points<float> v = t.v.cast<float>(), q = end_targets(t, 2.0, 0.5).cast<float>();
  Points<float> ref;
  const ArapFactorisation factorisation = GENERATE(ArapFactorisation::automatic, ArapFactorisation::supernodal_mit);
  for (int threads : {1, 2, 0}) {
    ArapOptions o;
    o.threads = threads;
    o.factorisation = factorisation;
    ArapRefiner<float> arap(v, t.f, c, o);
    Points<float> x;
    arap.refine(v, q, 5, x);
    if (threads == 1) {
      ref = x;
      continue;
    }
    INFO("threads " << threads);
    CHECK(std::memcmp(x.data(), ref.data(), sizeof(float) * std::size_t(x.size())) == 0);
  }
}

TEST_CASE("ARAP: the local step on every ISA agrees with the scalar reference", "[arap][isa]") {
  // One iteration from the same start: the rotations R_i of the SIMD and scalar fits are each within the
  // accuracy suite's angle bound of the optimum for S_i (tests/support/accuracy_bounds.hpp, kappa_i of S_i
  // from the long-double SVD), so they differ by at most twice that; the right-hand side then differs by
  // |db_i| <= sum_j w_ij |p_i - p_j| dR_max and x by |db|_2 / lambda_min(L_ff), plus each solve's rounding.
  const Tube t = tube(12, 10, 0.02, 4);
  const std::vector<Eigen::Index> c = ends(t);
  const Points<double> q = end_targets(t, 1.0, 0.3);
  testing::IsaGuard guard;
  set_isa(Isa::scalar);
  ArapRefiner<double> arap(t.v, t.f, c);
  Points<double> start, ref;
  arap.refine(t.v, q, 0, start);
  arap.refine(start, q, 1, ref);
  // dR_max over the vertices, from S_i at the start.
  LD dR = 0, db2 = 0;
  const auto L = reduced_laplacian(t);
  for (Eigen::Index i = 0; i < t.v.rows(); ++i) {
    Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
    LD wp = 0;
    for (Eigen::Index f = 0; f < t.f.rows(); ++f)
      for (int k = 0; k < 3; ++k) {
        if (t.f(f, k) != i) continue;
        for (int o : {1, 2}) {
          const int j = t.f(f, (k + o) % 3);
          S += (start.row(i) - start.row(j)).transpose() * (t.v.row(i) - t.v.row(j));
          wp += (t.v.row(i) - t.v.row(j)).norm();
        }
      }
    const testing::Reference r = testing::reference(S);
    dR = std::max(dR, 2 * testing::tol_angle<double>(r.kappa, testing::c_b_uniform));
    // Weights at most the largest |L| entry: a bound on sum_j w_ij |e_ij| (each edge counted per triangle).
    db2 += std::pow(wp * L.cwiseAbs().maxCoeff(), 2);
  }
  const Conditioning k = conditioning(t);
  const LD bound = std::sqrt(db2) * dR / k.lambda_min +
                   16 * std::numeric_limits<double>::epsilon() * k.kappa * start.cwiseAbs().maxCoeff();
  for (Isa isa : supported_isas()) {
    if (isa == Isa::scalar) continue;
    set_isa(isa);
    Points<double> x;
    arap.refine(start, q, 1, x);
    INFO(to_string(isa) << ": bound " << double(bound));
    CHECK(LD((x - ref).cwiseAbs().maxCoeff()) <= bound);
  }
}

TEST_CASE("ARAP: bad input is refused with a message", "[arap]") {
  const Tube t = tube(8, 4, 0, 5);
  Triangles bad = t.f;
  bad(3, 1) = int(t.v.rows());
  CHECK_THROWS_WITH(ArapRefiner<double>(t.v, bad, ends(t)), Catch::Matchers::ContainsSubstring("outside"));
  std::vector<Eigen::Index> twice = {0, 0};
  CHECK_THROWS_WITH(ArapRefiner<double>(t.v, t.f, twice), Catch::Matchers::ContainsSubstring("constrained twice"));
  const ArapOptions supernodal{0, ArapFactorisation::supernodal};
  if (supernodal_factorisation_available())
    CHECK_NOTHROW(ArapRefiner<double>(t.v, t.f, ends(t), supernodal));
  else
    CHECK_THROWS_WITH(ArapRefiner<double>(t.v, t.f, ends(t), supernodal),
                      Catch::Matchers::ContainsSubstring("MLSDEFORM_CHOLMOD=ON"));
  ArapRefiner<double> arap(t.v, t.f, ends(t));
  Points<double> x;
  CHECK_THROWS_WITH(arap.refine(t.v, Points<double>(3, 3), 1, x), Catch::Matchers::ContainsSubstring("targets"));
  CHECK_THROWS_WITH(arap.refine(t.v, end_targets(t, 0, 0), -1, x), Catch::Matchers::ContainsSubstring("iterations"));
  Points<double> nan = t.v;
  nan(2, 1) = std::nan("");
  CHECK_THROWS_WITH(arap.refine(nan, end_targets(t, 0, 0), 1, x), Catch::Matchers::ContainsSubstring("non-finite"));
}

TEST_CASE("Deformer: arap_iterations refines MLS and keeps the handles", "[arap][deformer]") {
  const Tube t = tube(16, 20, 0.01, 6);
  Handles<double> rest;
  const std::vector<Eigen::Index> c = ends(t);
  rest.points.resize(Eigen::Index(c.size()), 3);
  for (std::size_t k = 0; k < c.size(); ++k) rest.points.row(Eigen::Index(k)) = t.v.row(c[k]);
  Handles<double> moved = rest;
  moved.points = end_targets(t, 1.5, 0.4);
  Options o;
  Points<double> mls, refined;
  Deformer<double>(t.v, t.f, rest, o).deform(moved, mls);
  o.arap_iterations = 10;
  Deformer<double> d(t.v, t.f, rest, o);
  d.deform(moved, refined);
  // Point handles at vertices: MLS interpolates them exactly, and ARAP holds them there.
  for (std::size_t k = 0; k < c.size(); ++k) CHECK(refined.row(c[k]) == moved.points.row(Eigen::Index(k)));
  ArapRefiner<double> arap(t.v, t.f, c);
  CHECK(arap.energy(refined) < arap.energy(mls));  // every iteration lowers it (first test case)
  // Interleaved output: the same values.
  PointsRowMajor<double> buffer(t.v.rows(), 3);
  d.deform(moved, InterleavedView<double>(buffer.data(), buffer.rows(), 3));
  CHECK(Points<double>(buffer) == refined);
  // Without triangles, or with a negative count, the option is refused.
  CHECK_THROWS_WITH(Deformer<double>(t.v, rest, o), Catch::Matchers::ContainsSubstring("triangles"));
  o.arap_iterations = -1;
  CHECK_THROWS_WITH(Deformer<double>(t.v, t.f, rest, o), Catch::Matchers::ContainsSubstring("arap_iterations"));
}
