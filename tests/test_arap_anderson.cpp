// ArapAcceleration::anderson: Anderson acceleration of the local/global iteration with Peng et al.'s energy
// safeguard (core/src/arap/anderson.hpp). The invariants it must keep are the plain iteration's (energy never
// increasing, handles exact, rigid motions reproduced, bitwise the same for any thread count), and it must pay
// for itself: a lower energy than the plain iteration after the same number of iterations.
#include "tests/support/meshes.hpp"
#include "tests/test_arap_common.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

using namespace mlsdeform;
using namespace mlsdeform::arap_test;

namespace {

ArapOptions anderson(int threads = 0, int window = 5) {
  ArapOptions o;
  o.threads = threads;
  o.acceleration = ArapAcceleration::anderson;
  o.anderson_window = window;
  return o;
}

/// A = sum over directed edges of w_ij (|x_i - x_j|^2 + |p_i - p_j|^2), in long double: the size of the
/// terms whose difference the local step's energy (ring_energy.hpp) is.
LD energy_terms(const Tube& t, const MatrixLD& W, const Points<double>& x) {
  LD A = 0;
  for (Eigen::Index i = 0; i < W.rows(); ++i)
    for (Eigen::Index j = 0; j < W.cols(); ++j)
      if (W(i, j) != 0)
        A += W(i, j) *
             ((x.row(i) - x.row(j)).cast<LD>().squaredNorm() + (t.v.row(i) - t.v.row(j)).cast<LD>().squaredNorm());
  return A;
}

}  // namespace

TEST_CASE("ARAP Anderson: energy never increases, constrained vertices exact", "[arap][anderson]") {
  const Tube t = tube(16, 20, 0.02, 1);
  const std::vector<Eigen::Index> c = ends(t);
  const MatrixLD W = cotangent_weights(t);
  const Points<double> q = end_targets(t, 1.5, 0.4);
  int rejected = 0;
  for (int window : {1, 5, 8}) {
    ArapRefiner<double> arap(t.v, t.f, c, anderson(0, window));
    Points<double> x;
    arap.refine(t.v, q, 0, x);
    double E = arap.energy(x);
    // The results after k and k + 1 iterations share their first k iterations (the run is deterministic), and
    // the safeguard returns an iterate whose energy, as the local step computes it, is not above the last
    // checked one's (anderson.hpp). Two roundings separate that from arap.energy(): the local step's
    // expansion E_i = sum w|d|^2 - 2 tr(R^T S) + sum w|p|^2 cancels terms of total size <= 2 A (A below),
    // each computed with at most valence + 12 < 32 roundings (valence 6 here), so 64 eps A on each of the
    // two energies compared; energy() sums ~2,000 terms of one sign directly: 1e-12 relative, as in
    // test_arap.cpp. The rotations' own rounding enters only at second order (each step is optimal).
    for (int it = 1; it <= 30; ++it) {
      Points<double> y;
      arap.refine(t.v, q, it, y);
      rejected += arap.rejected_iterates();
      const double E1 = arap.energy(y);
      const LD slack = 2 * 64 * std::numeric_limits<double>::epsilon() * energy_terms(t, W, y);
      INFO("window " << window << ", iteration " << it << ": " << E << " -> " << E1 << ", slack " << double(slack));
      CHECK(LD(E1) <= LD(E) * (1 + 1e-12L) + slack);
      E = E1;
      for (std::size_t k = 0; k < c.size(); ++k) CHECK(y.row(c[k]) == q.row(Eigen::Index(k)));  // bitwise
    }
  }
  // The safeguard's other branch ran too (rejected extrapolations replaced by the plain step): with windows
  // 1 and 8 this twist has tens of them over the runs.
  CHECK(rejected > 0);
}

TEST_CASE("ARAP Anderson: a rigid motion of every handle gives that motion", "[arap][anderson]") {
  const Tube t = tube(12, 10, 0.02, 2);
  const std::vector<Eigen::Index> c = ends(t);
  ArapRefiner<double> arap(t.v, t.f, c, anderson());
  const auto [moved, q] = rigid_motion(t, c);
  // From the motion itself each plain step stays within 16 eps kappa(L_ff) max |x| (test_arap.cpp). An
  // extrapolated iterate is accepted only if its energy is not above the last one's, and both are then at
  // the rounding level of an exact motion; the result is the last checked iterate or its plain step.
  Points<double> x;
  arap.refine(moved, q, 3, x);
  const Conditioning k = conditioning(t);
  const LD bound = 16 * std::numeric_limits<double>::epsilon() * k.kappa * moved.cwiseAbs().maxCoeff();
  INFO("kappa(L_ff) = " << double(k.kappa) << ", bound " << double(bound));
  CHECK(LD((x - moved).cwiseAbs().maxCoeff()) <= bound);
  // From the rest pose it converges to the motion: in fewer iterations than the plain iteration's 200.
  arap.refine(t.v, q, 100, x);
  CHECK((x - moved).cwiseAbs().maxCoeff() < 1e-6);
}

TEST_CASE("ARAP Anderson: bitwise the same for any thread count", "[arap][anderson]") {
  const Tube t = tube(24, 40, 0.02, 3);
  const std::vector<Eigen::Index> c = ends(t);
  const Points<float> v = t.v.cast<float>(), q = end_targets(t, 2.0, 0.5).cast<float>();
  Points<float> ref;
  for (int threads : {1, 2, 0}) {
    ArapRefiner<float> arap(v, t.f, c, anderson(threads));
    Points<float> x;
    arap.refine(v, q, 12, x);
    if (threads == 1) {
      ref = x;
      continue;
    }
    INFO("threads " << threads);
    CHECK(std::memcmp(x.data(), ref.data(), sizeof(float) * std::size_t(x.size())) == 0);
  }
}

TEST_CASE("ARAP Anderson: a lower energy than the plain iteration on the human bend", "[arap][anderson]") {
  // bench_quality's human scene: MLS's result as the start, then k iterations of each kind.
  const std::string path = testing::bundled_mesh("human_man.obj");
  const Points<double> rest = testing::read_obj_vertices(path);
  const Triangles f = testing::read_obj_triangles(path);
  const std::vector<Eigen::Index> h = {1337, 3215, 3386, 6618, 6786, 411, 5906, 2445};
  Points<double> targets(8, 3);
  targets << 0.007005, 1.053843, 0.171833, 0.078112, 0.019384, 0.180523, 0.095968, 0.039844, -0.085711, -0.086231,
      0.01583, 0.179475, -0.098815, 0.041748, -0.090276, 0.00213, 1.38829, 0.68933, -0.3, 0.55, 0.45, 0.3, 0.55, 0.45;
  Handles<double> rest_handles, moved;
  rest_handles.points.resize(8, 3);
  for (int k = 0; k < 8; ++k) rest_handles.points.row(k) = rest.row(h[std::size_t(k)]);
  moved.points = targets;
  Points<double> mls;
  Deformer<double>(rest, rest_handles).deform(moved, mls);
  ArapRefiner<double> plain(rest, f, h), accelerated(rest, f, h, anderson());
  for (int k : {5, 10, 20, 40}) {
    Points<double> a, b;
    plain.refine(mls, targets, k, a);
    accelerated.refine(mls, targets, k, b);
    const double Ea = plain.energy(a), Eb = plain.energy(b);
    INFO(k << " iterations: plain " << Ea << ", Anderson " << Eb << " (" << accelerated.rejected_iterates()
           << " rejected)");
    CHECK(Eb < Ea);
  }
}

TEST_CASE("ARAP Anderson: a window outside [1, 8] is refused", "[arap][anderson]") {
  const Tube t = tube(8, 4, 0, 5);
  for (int window : {0, 9, -1})
    CHECK_THROWS_WITH(ArapRefiner<double>(t.v, t.f, ends(t), anderson(0, window)),
                      Catch::Matchers::ContainsSubstring("anderson_window"));
}
