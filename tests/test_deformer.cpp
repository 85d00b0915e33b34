// The MLS deformer: properties on random scenes, for the three transforms and both precisions.
// Identity, interpolation, reproduction of rigid / similarity / affine maps, translation, scale
// invariance. The session's own guarantees (threads, the stateful API, memory, allocation) are in
// test_deformer_session.cpp.
// Tolerances: the per-vertex bound of test_deformer_common.hpp (derived from eps and the conditioning of
// each vertex's fit), or exact equality where the algorithm is exact.
#include "tests/test_deformer_common.hpp"

#include "core/src/deformer/data.hpp"

#include <cstdio>
#include <utility>
#include <vector>

using namespace deformer_test;

namespace {

/// Checks out against expected(v) for every vertex, with the bound of the direct evaluation (moved handles
/// as given) plus `extra` (absolute). Returns the largest deviation / bound. Vertices where the fit is
/// ill-posed fail the test unless `ill_posed` is given, which then counts them: singular in double (affine:
/// G; rigid, similarity: gap = 0), or H rank-deficient to the double reference's own rounding (gap <= 64
/// eps_double s1: the sum's and the SVD's rounding, a few eps s1 each, with a margin), where the reference's
/// rotation, and so its bound, mean nothing; above that the bound covers T's rounding, which grows as 1 / gap.
template <class T, class F>
double check_expected(const Points<T>& out, const DeformCase<T>& sc, const Handles<T>& moved, const Options& o,
                      F expected, double extra = 0, long* ill_posed = nullptr) {
  const double l = scene_size(sc.vertices, sc.rest);
  double worst = 0;
  for (Eigen::Index i = 0; i < sc.vertices.rows(); ++i) {
    const Vec3d v = sc.vertices.row(i).transpose().template cast<double>();
    const DirectVertex d = direct_vertex(v, sc.rest, moved, o, l);
    const double eps_d = std::numeric_limits<double>::epsilon();
    const bool rotation = o.transform != Transform::affine;
    if ((!d.well_posed || (rotation && d.gap <= 64 * eps_d * d.s1)) && ill_posed) {
      ++*ill_posed;
      // Whatever rotation the fit takes, a rigid or similarity map moves v by at most mu |v - p*| off
      // (the centroid's image is exact to rounding): 2 mu |vhat| apart from the expected point.
      if (rotation && d.well_posed) {
        const double dev = (out.row(i).transpose().template cast<double>() - expected(v)).norm();
        CHECK(dev <= 2 * d.mu * d.vhat_norm + 8 * std::numeric_limits<T>::epsilon() * (expected(v).norm() + l));
      }
      continue;
    }
    REQUIRE(d.well_posed);
    const double bound = std::numeric_limits<T>::epsilon() * d.bound_unit + extra;
    const double dev = (out.row(i).transpose().template cast<double>() - expected(v)).norm();
    INFO("vertex " << i << " deviation " << dev << " bound " << bound);
    REQUIRE(dev <= bound);
    worst = std::max(worst, dev / bound);
  }
  return worst;
}

}  // namespace

TEMPLATE_TEST_CASE("identity: moved handles equal to the rest handles give the rest pose", "[deformer]", float,
                   double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed() << " (rerun with --rng-seed N)");
  for (Transform tr : all_transforms) {
    INFO(name(tr));
    const DeformCase<T> sc = random_case<T>(g, 300, 9, 2);
    Options o;
    o.transform = tr;
    const Deformer<T> def(sc.vertices, sc.rest, o);
    Points<T> out;
    def.deform(sc.rest, out);
    REQUIRE(out.rows() == sc.vertices.rows());
    // Exact answer v; the bound is the path's own (derived in test_deformer_common.hpp).
    check_expected(out, sc, sc.rest, o, [](const Vec3d& v) { return v; });
  }
}

TEMPLATE_TEST_CASE("interpolation: vertices on point handles go exactly to their targets", "[deformer]", float,
                   double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  for (Transform tr : all_transforms) {
    INFO(name(tr));
    DeformCase<T> sc = random_case<T>(g, 40, 7, 1);
    // Every handle is also a vertex (rows 0..6), plus vertices at a segment end and its midpoint.
    for (Eigen::Index i = 0; i < 7; ++i) sc.vertices.row(i) = sc.rest.points.row(i);
    sc.vertices.row(7) = sc.rest.segment_a.row(0);
    sc.vertices.row(8) = (sc.rest.segment_a.row(0) + sc.rest.segment_b.row(0)) / T(2);
    Options o;
    o.transform = tr;
    const Deformer<T> def(sc.vertices, sc.rest, o);
    const Handles<T> moved = transformed(sc.rest, random_rotation(g), random_vector(g));
    Handles<T> wild = moved;
    wild.points = random_points<T>(g, 7, -3, 3);  // no transform family at all: still interpolates
    for (const Handles<T>* q : {&moved, &std::as_const(wild)}) {
      Points<T> out;
      def.deform(*q, out);
      for (Eigen::Index i = 0; i < 7; ++i) {
        INFO("handle " << i);
        CHECK(out.row(i) == q->points.row(i));  // exact, not approximate (deformer/data.hpp: snapped vertices)
      }
      // On a segment moved rigidly: its end's target at t = 0, (c + d) / 2 at the midpoint. With the default
      // paper_constant weights the vertex takes the map's limit there (deformer/data.hpp), the fit to that
      // segment alone: q* + mu R vhat with a rank-1 H, whose fit maps the segment's direction to 16 eps;
      // |vhat| <= |c - d| / 2, and q* + mu R vhat rounds twice (8 eps each) on values below |c| + |d| + 1.
      const double tol =
          32 * std::numeric_limits<T>::epsilon() * (q->segment_a.row(0).norm() + q->segment_b.row(0).norm() + 1);
      CHECK((out.row(7) - q->segment_a.row(0)).template cast<double>().norm() <= tol);
      const Vec3d mid = 0.5 * (q->segment_a.row(0) + q->segment_b.row(0)).transpose().template cast<double>();
      CHECK((out.row(8).transpose().template cast<double>() - mid).norm() <= tol);
      CHECK(out.allFinite());
    }
  }
}

TEMPLATE_TEST_CASE("interpolation: vertices within the snapping distance of a handle map exactly to its target",
                   "[deformer]", float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  // deformer/snap.hpp: closer than 64 eps(T) times the distance to the second-nearest handle snaps. An offset
  // of one ulp of a coordinate below 1 (at most eps(T) / 2) is inside that when the handles are at least
  // 1/128 apart: drawn until they are.
  auto spacing = [](const Points<T>& p) {
    double d = std::numeric_limits<double>::infinity();
    for (Eigen::Index i = 0; i < p.rows(); ++i)
      for (Eigen::Index j = 0; j < i; ++j) d = std::min(d, double((p.row(i) - p.row(j)).norm()));
    return d;
  };
  DeformCase<T> sc = random_case<T>(g, 20, 6, 0);
  while (!(spacing(sc.rest.points) >= 1.0 / 64)) sc = random_case<T>(g, 20, 6, 0);
  for (Eigen::Index i = 0; i < 6; ++i) {
    sc.vertices.row(i) = sc.rest.points.row(i);
    sc.vertices(i, int(i % 3)) = std::nextafter(sc.vertices(i, int(i % 3)), T(10));
  }
  for (Transform tr : all_transforms) {
    INFO(name(tr));
    Options o;
    o.transform = tr;
    o.weight_exponent = 4;
    const Handles<T> moved = transformed(sc.rest, 2 * random_rotation(g), random_vector(g));
    Points<T> out;
    Deformer<T>(sc.vertices, sc.rest, o).deform(moved, out);
    for (Eigen::Index i = 0; i < 6; ++i) CHECK(out.row(i) == moved.points.row(i));
    CHECK(out.allFinite());
  }
}

TEMPLATE_TEST_CASE("extreme weight exponents and vertices close to handles stay finite and exact", "[deformer]", float,
                   double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  DeformCase<T> sc = random_case<T>(g, 200, 7, 2);
  // Vertices 1e-3 of the scene from a handle, and 4 times 64 eps(T) times the scene size (about 1e-4 in
  // float, 2e-13 in double; beyond the snapping distance, deformer/snap.hpp): weight ratios down to
  // (1e-4 / 3.5)^20 = 1e-90 in float and (5e-14)^20 = 1e-266 in double. The first is far below the float
  // range: the per-vertex power-of-two scaling of A keeps those handles in H. (For u * log10(d_min / d)
  // below about -300 the weights leave the double range too and the farther handles stop counting.)
  const double l = scene_size(sc.vertices, sc.rest);
  for (Eigen::Index i = 0; i < 7; ++i) {
    const double d = i % 2 ? 1e-3 * l : 4 * 64 * std::numeric_limits<T>::epsilon() * l;
    sc.vertices.row(i) = sc.rest.points.row(i) + (d * random_vector(g).normalized()).cast<T>().transpose();
  }
  for (double u : {1.0, 1.5, 8.0, 20.0})
    for (Transform tr : all_transforms) {
      INFO(name(tr) << " u " << u);
      Options o;
      o.transform = tr;
      o.weight_exponent = u;
      const Deformer<T> def(sc.vertices, sc.rest, o);
      const Mat3d R = random_rotation(g);
      const Vec3d t = random_vector(g);
      const Handles<T> moved = transformed(sc.rest, R, t);
      Points<T> out;
      def.deform(moved, out);
      REQUIRE(out.allFinite());
      // Every transform reproduces a rigid motion (test_deformer_common.hpp bound). With large u the nearest
      // handles take all the weight at some vertices, and what is left of the others' below rounding: a
      // segment alone, two points (a vertex 256 eps from one handle: H is the next handle's term, 1e-238, the
      // third's 1e-17 of it), fewer than four points for affine. The fit is ill-posed there (rotation about
      // that line free) for every transform; such vertices are counted, and stay few (300 seeds: at most 10
      // of 200, none with u <= 1.5).
      long ill_posed = 0;
      check_expected(
          out, sc, moved, o, [&](const Vec3d& v) { return Vec3d(R * v + t); },
          8 * std::numeric_limits<double>::epsilon() * (2 + t.norm()), &ill_posed);
      CHECK(ill_posed <= (u <= 1.5 ? 0 : sc.vertices.rows() / 10));
      if (ill_posed)
        std::printf("[extreme] %s %s u = %g: %ld vertices with an ill-posed fit skipped\n", type_name<T>(), name(tr), u,
                    ill_posed);
    }
}

TEMPLATE_TEST_CASE("reproduction: rigid motions, uniform scales and affine maps are reproduced", "[deformer]", float,
                   double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  for (int trial = 0; trial < 4; ++trial) {
    const DeformCase<T> sc = random_case<T>(g, 200, 8, trial % 2 ? 2 : 0);
    const Mat3d R = random_rotation(g);
    const Vec3d t = random_vector(g, -2, 2);
    const double s = std::exp(std::uniform_real_distribution<double>(-1.5, 1.5)(g));
    Mat3d N;
    for (int c = 0; c < 3; ++c) N.col(c) = random_vector(g);
    const Mat3d M = R * (Mat3d::Identity() + 0.4 * N);  // any (well-conditioned) affine map
    struct Case {
      Transform tr;
      Mat3d map;
    };
    for (const Case& cs :
         {Case{Transform::rigid, R}, Case{Transform::similarity, R}, Case{Transform::similarity, s * R},
          Case{Transform::affine, R}, Case{Transform::affine, s * R}, Case{Transform::affine, M}}) {
      INFO(name(cs.tr) << " trial " << trial << " map\n" << cs.map);
      Options o;
      o.transform = cs.tr;
      const Deformer<T> def(sc.vertices, sc.rest, o);
      const Handles<T> moved = transformed(sc.rest, cs.map, t);
      Points<T> out;
      def.deform(moved, out);
      // The expected map, evaluated in double: its own rounding is a few eps(double) of |map v + t|.
      const double extra = 8 * std::numeric_limits<double>::epsilon() * (cs.map.norm() * 2 + t.norm());
      check_expected(
          out, sc, moved, o, [&](const Vec3d& v) { return Vec3d(cs.map * v + t); }, extra);
    }
  }
}

TEMPLATE_TEST_CASE("translation of all handles translates every vertex", "[deformer]", float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  for (Transform tr : all_transforms) {
    INFO(name(tr));
    const DeformCase<T> sc = random_case<T>(g, 200, 6, 2);
    Options o;
    o.transform = tr;
    const Deformer<T> def(sc.vertices, sc.rest, o);
    for (double len : {1e-3, 1.0, 100.0}) {
      const Vec3d t = len * random_vector(g).normalized();
      const Handles<T> moved = transformed(sc.rest, Mat3d::Identity(), t);
      Points<T> out;
      def.deform(moved, out);
      check_expected(
          out, sc, moved, o, [&](const Vec3d& v) { return Vec3d(v + t); },
          8 * std::numeric_limits<double>::epsilon() * (t.norm() + 2));
    }
  }
}

TEMPLATE_TEST_CASE("scale invariance: scaling the scene scales the output and changes nothing else", "[deformer]",
                   float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  // Powers of two near the decimal factors below (1e-20, 1e20 in double; 1e-8, 1e8 in float) scale every input
  // exactly; the precomputation works in a frame scaled by a power of two and fit_rotation is bitwise
  // invariant under power-of-two scaling of H, so the output must scale bitwise.
  const int e = sizeof(T) == 8 ? 66 : 27;
  // The decimal factors themselves round the inputs, so there the check is against the direct evaluation
  // of the scaled scene, with its derived bound: no overflow, underflow or loss of accuracy at any scale.
  const double decimal = sizeof(T) == 8 ? 1e20 : 1e8;
  for (Transform tr : all_transforms) {
    for (SegmentWeight sw : {SegmentWeight::paper_constant, SegmentWeight::exact_integral}) {
      INFO(name(tr) << (sw == SegmentWeight::exact_integral ? " exact_integral" : " paper_constant"));
      const DeformCase<T> sc = random_case<T>(g, 100, 6, 2);
      Options o;
      o.transform = tr;
      o.segment_weight = sw;
      const Handles<T> moved = transformed(sc.rest, 1.3 * random_rotation(g), random_vector(g));
      Points<T> out;
      Deformer<T>(sc.vertices, sc.rest, o).deform(moved, out);
      for (int sign : {-1, 1}) {
        const T f = std::ldexp(T(1), sign * e);
        DeformCase<T> s2;
        s2.vertices = sc.vertices * f;
        s2.rest = {sc.rest.points * f, sc.rest.segment_a * f, sc.rest.segment_b * f};
        const Handles<T> m2{moved.points * f, moved.segment_a * f, moved.segment_b * f};
        Points<T> out2;
        Deformer<T>(s2.vertices, s2.rest, o).deform(m2, out2);
        CHECK(out2 == out * f);
        if (sw == SegmentWeight::exact_integral) continue;  // the direct evaluation knows paper_constant only
        const T fd = T(sign > 0 ? decimal : 1 / decimal);
        DeformCase<T> s3;
        s3.vertices = sc.vertices * fd;
        s3.rest = {sc.rest.points * fd, sc.rest.segment_a * fd, sc.rest.segment_b * fd};
        const Handles<T> m3{moved.points * fd, moved.segment_a * fd, moved.segment_b * fd};
        Points<T> out3;
        Deformer<T>(s3.vertices, s3.rest, o).deform(m3, out3);
        REQUIRE(out3.allFinite());
        const Comparison c = compare_with_direct(out3, s3.vertices, s3.rest, m3, o);
        INFO("scale " << double(fd) << ": max deviation " << c.max_dev << ", max deviation / bound " << c.max_ratio);
        CHECK(c.failures == 0);
        CHECK(c.ill_posed == 0);
      }
    }
  }
}
