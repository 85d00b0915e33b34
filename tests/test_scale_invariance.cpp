// Scale invariance over the whole range of T: whole scenes scaled by powers of two 2^k, k from -120 to 120
// (float) and from -1000 to 1000 (double), through every path of the library (the deformer with every
// option, point and segment handles, RBF centroids, regions, handle groups, ARAP; the point fits), and what
// cannot be represented is refused with a message, never returned as NaN or infinity.
//
// The expected result, derived. Every scene here has coordinates that are multiples of 2^-16 in [-2, 2]
// (at most 18 significant bits), so its scaled copy is exact for every k above: the smallest nonzero
// coordinate becomes 2^(k-16) >= 2^-136 (float; 2^-1016 double), a multiple of the smallest subnormal, and
// the largest 2^(k+1) <= 2^121 stays below the deformer's coordinate limit (max / 64 = 2^122 in float).
// The library computes in frames scaled by exact powers of two that it takes from the input's own exponents
// (deformer/data.hpp Units, arap_refiner.cpp, point_fit.cpp): scaling the input by 2^k shifts those
// exponents by k and leaves every number inside bitwise the same, and the result leaves the frame through one
// product with a power of two, rounded once. So the output for the scaled scene must equal ldexp(x, k),
// x the unscaled output: ldexp rounds x 2^k correctly, and x itself is the frame's value times a power of
// two, exactly (the unscaled scene lies in the normal range). Bitwise, no tolerance. Two places round twice:
//  - ARAP in float: the refinement's result X is a double, rounded to float in each run; the unscaled run
//    returns fl(X) and the scaled one fl(X 2^k), where ldexp(fl(X), k) rounds once more. Both agree unless
//    X 2^k is subnormal in float; there |fl(X) 2^k - X 2^k| <= ulp(X) 2^k / 2 <= denorm_min / 2 (ulp(X) 2^k is
//    at most the subnormal spacing denorm_min when X 2^k < 2^-126), and rounding both to the subnormal grid
//    leaves them at most one denorm_min apart. So: bitwise, or subnormal and within one denorm_min.
//  - Handle groups: transform_handles rounds each image once (ldexp(image, k) bitwise, checked); an image
//    rounded to a subnormal then is not the unscaled image times 2^k, so the deformation that follows is
//    compared with the unscaled deformer run on those rounded targets divided back by 2^k (exact).
#include "tests/support/isa_guard.hpp"
#include "tests/support/meshes.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include <Eigen/Geometry>
#include "tests/support/catch.hpp"

#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

using namespace mlsdeform;

namespace {

template <class T>
constexpr int kMaxExponent = sizeof(T) == 4 ? 120 : 1000;

/// The scales tested: every 8th (float) or 40th (double) exponent from -max to max, and the ends' neighbours.
template <class T>
std::vector<int> exponents() {
  const int m = kMaxExponent<T>, step = sizeof(T) == 4 ? 8 : 40;
  std::vector<int> e{-m + 1, m - 1};
  for (int k = -m; k <= m; k += step) e.push_back(k);
  return e;
}

template <class T>
Points<T> scaled(const Points<T>& p, int k) {
  Points<T> q(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.size(); ++i) q.data()[i] = std::ldexp(p.data()[i], k);
  return q;
}

template <class T>
Handles<T> scaled(const Handles<T>& h, int k) {
  return {scaled(h.points, k), scaled(h.segment_a, k), scaled(h.segment_b, k)};
}

/// n points, each coordinate a multiple of 2^-16 in [lo, hi] (see the file comment).
template <class T>
Points<T> quantised_points(std::mt19937_64& g, Eigen::Index n, double lo = -1, double hi = 1) {
  std::uniform_real_distribution<double> d(lo, hi);
  Points<T> p(n, 3);
  for (Eigen::Index i = 0; i < p.size(); ++i) p.data()[i] = T(std::ldexp(std::round(std::ldexp(d(g), 16)), -16));
  return p;
}

/// How y, the output for the scene scaled by 2^k, compares with ldexp(x, k), x the unscaled output (the file
/// comment derives what is expected). Returns "" when every coordinate is bitwise ldexp(x, k) or, with
/// `subnormal_ulp`, subnormal and within one denorm_min of it; else the first coordinate that is not.
template <class T, class M>
std::string scaled_mismatch(const M& y, const M& x, int k, bool subnormal_ulp = false) {
  if (y.rows() != x.rows()) return "row count " + std::to_string(y.rows()) + " vs " + std::to_string(x.rows());
  for (Eigen::Index i = 0; i < x.rows(); ++i)
    for (Eigen::Index c = 0; c < x.cols(); ++c) {
      const T want = std::ldexp(x(i, c), k), got = y(i, c);
      if (got == want) continue;
      const bool near = subnormal_ulp && std::abs(got) < std::numeric_limits<T>::min() &&
                        std::abs(got - want) <= std::numeric_limits<T>::denorm_min();
      if (near) continue;
      std::ostringstream s;
      s.precision(std::numeric_limits<T>::max_digits10);
      s << "row " << i << " column " << c << ": " << got << " for the scaled scene, ldexp(" << x(i, c) << ", " << k
        << ") = " << want;
      return s.str();
    }
  return "";
}

template <class T>
const char* type_name() {
  return sizeof(T) == 4 ? "float" : "double";
}

const char* name(Transform t) {
  return t == Transform::rigid ? "rigid" : t == Transform::similarity ? "similarity" : "affine";
}

/// A random scene of quantised coordinates: `n` vertices (the first three on point handles, so that they
/// snap), 6 point handles and `segments` segment handles, and targets moved by a quantised offset of up to
/// 1/4 per coordinate.
template <class T>
struct RandomScene {
  Points<T> vertices;
  Handles<T> rest, moved;
};

template <class T>
RandomScene<T> random_scene(std::mt19937_64& g, Eigen::Index n, Eigen::Index segments) {
  RandomScene<T> s;
  s.vertices = quantised_points<T>(g, n);
  s.rest = {quantised_points<T>(g, 6), quantised_points<T>(g, segments), quantised_points<T>(g, segments)};
  s.moved = {s.rest.points + quantised_points<T>(g, 6, -0.25, 0.25),
             s.rest.segment_a + quantised_points<T>(g, segments, -0.25, 0.25),
             s.rest.segment_b + quantised_points<T>(g, segments, -0.25, 0.25)};
  for (Eigen::Index i = 0; i < 3; ++i) s.vertices.row(i) = s.rest.points.row(i);
  return s;
}

/// A 30 x 30 grid of spacing 1/32 with a quantised height field, two triangles per quad (the grid of the
/// ARAP report), handles on four corners and the middle, the middle lifted and one corner pulled.
template <class T>
struct GridScene {
  Points<T> vertices;
  Triangles triangles;
  Handles<T> rest, moved;
};

template <class T>
GridScene<T> grid_scene() {
  const int n = 30;
  GridScene<T> s;
  s.vertices.resize(n * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) s.vertices.row(i * n + j) << T(i / 32.0), T(j / 32.0), T(((i * 7 + j * 3) % 5) / 256.0);
  s.triangles.resize(2 * (n - 1) * (n - 1), 3);
  int t = 0;
  for (int i = 0; i + 1 < n; ++i)
    for (int j = 0; j + 1 < n; ++j) {
      const int a = i * n + j, b = a + 1, c = a + n, d = c + 1;
      s.triangles.row(t++) << a, b, d;
      s.triangles.row(t++) << a, d, c;
    }
  s.rest.points = s.vertices(std::vector<int>{0, n - 1, n * (n - 1), n * n - 1, n * n / 2 + n / 2}, Eigen::all);
  s.moved = s.rest;
  s.moved.points(4, 2) += T(0.25);
  s.moved.points(3, 0) += T(0.125);
  return s;
}

}  // namespace

TEMPLATE_TEST_CASE("scale: the deformer with every option scales with the scene, bitwise", "[scale][deformer]", float,
                   double) {
  using T = TestType;
  std::mt19937_64 g(20240611u);
  INFO(type_name<T>() << ", ISA " << to_string(active_isa()));
  for (const bool with_segments : {false, true}) {
    const RandomScene<T> sc = random_scene<T>(g, 40, with_segments ? 2 : 0);
    for (const Transform tr : {Transform::rigid, Transform::similarity, Transform::affine})
      for (const SegmentWeight sw : {SegmentWeight::paper_constant, SegmentWeight::exact_integral})
        for (const WeightStorage ws : {WeightStorage::precomputed, WeightStorage::on_the_fly})
          for (const std::optional<Isa> be : {std::optional<Isa>(), std::optional<Isa>(Isa::scalar)})
            for (const Centroids ce : {Centroids::mls, Centroids::rbf})
              for (const double u : {1.0, 2.0, 9.5, 300.0}) {
                if (!with_segments && sw == SegmentWeight::exact_integral) continue;
                if (ws == WeightStorage::on_the_fly &&
                    (tr == Transform::affine || with_segments || ce == Centroids::rbf))
                  continue;  // on-the-fly weights: rigid and similarity, point handles, MLS centroids only
                Options o;
                o.transform = tr;
                o.segment_weight = sw;
                o.weight_storage = ws;
                o.isa = be;
                o.centroids = ce;
                o.weight_exponent = u;
                INFO(name(tr) << (with_segments ? ", segments " : ", points only ")
                              << (sw == SegmentWeight::exact_integral ? "exact_integral" : "paper_constant")
                              << (ws == WeightStorage::on_the_fly ? ", on the fly" : ", precomputed")
                              << (be ? ", scalar" : ", simd") << (ce == Centroids::rbf ? ", rbf" : ", mls")
                              << ", u = " << u);
                Points<T> out0;
                Deformer<T>(sc.vertices, sc.rest, o).deform(sc.moved, out0);
                REQUIRE(out0.allFinite());
                for (const int k : exponents<T>()) {
                  INFO("scale 2^" << k);
                  Points<T> out;
                  Deformer<T>(scaled(sc.vertices, k), scaled(sc.rest, k), o).deform(scaled(sc.moved, k), out);
                  CHECK(scaled_mismatch<T>(out, out0, k) == "");
                }
              }
  }
}

TEMPLATE_TEST_CASE("scale: every rotation method, and the interleaved output", "[scale][deformer]", float, double) {
  using T = TestType;
  std::mt19937_64 g(7);
  const RandomScene<T> sc = random_scene<T>(g, 40, 1);
  for (const RotationMethod m : all_rotation_methods)
    for (const Transform tr : {Transform::rigid, Transform::similarity}) {
      INFO(type_name<T>() << " " << to_string(m) << " " << name(tr));
      Options o;
      o.method = m;
      o.transform = tr;
      Points<T> out0;
      Deformer<T>(sc.vertices, sc.rest, o).deform(sc.moved, out0);
      for (const int k : exponents<T>()) {
        INFO("scale 2^" << k);
        const Deformer<T> d(scaled(sc.vertices, k), scaled(sc.rest, k), o);
        PointsRowMajor<T> out(sc.vertices.rows(), 3);
        d.deform(scaled(sc.moved, k), InterleavedView<T>(out.data(), out.rows(), 3));
        CHECK(scaled_mismatch<T>(Points<T>(out), out0, k) == "");
      }
    }
}

TEMPLATE_TEST_CASE("scale: regions, with and without the mesh's triangles", "[scale][deformer][region]", float,
                   double) {
  using T = TestType;
  const GridScene<T> sc = grid_scene<T>();
  std::vector<Eigen::Index> region;  // the middle third of the grid, with the lifted handle
  for (Eigen::Index i = 0; i < sc.vertices.rows(); ++i)
    if (std::abs(sc.vertices(i, 0) - T(15 / 32.0)) < T(0.2) && std::abs(sc.vertices(i, 1) - T(15 / 32.0)) < T(0.2))
      region.push_back(i);
  for (const bool triangles : {true, false})
    for (const Transform tr : {Transform::rigid, Transform::similarity, Transform::affine}) {
      INFO(type_name<T>() << " " << name(tr)
                          << (triangles ? ", ring from the triangles" : ", ring from the nearest vertices"));
      Options o;
      o.region = region;
      o.transform = tr;
      const Triangles f = triangles ? sc.triangles : Triangles();
      Points<T> out0;
      Deformer<T>(sc.vertices, f, sc.rest, o).deform(sc.moved, out0);
      for (const int k : exponents<T>()) {
        INFO("scale 2^" << k);
        Points<T> out;
        Deformer<T>(scaled(sc.vertices, k), f, scaled(sc.rest, k), o).deform(scaled(sc.moved, k), out);
        CHECK(scaled_mismatch<T>(out, out0, k) == "");
      }
    }
}

TEMPLATE_TEST_CASE("scale: ARAP refinement, in the deformer and alone", "[scale][arap]", float, double) {
  using T = TestType;
  const GridScene<T> sc = grid_scene<T>();
  const bool twice = sizeof(T) == 4;  // the file comment: float rounds the refinement's double result twice
  Options o;
  o.arap_iterations = 2;
  Points<T> out0;
  Deformer<T>(sc.vertices, sc.triangles, sc.rest, o).deform(sc.moved, out0);
  REQUIRE(out0.allFinite());
  const std::vector<Eigen::Index> held{0, 29, 870, 899, 465};
  ArapRefiner<T> alone(sc.vertices, sc.triangles, held);
  const Points<T> start = sc.vertices;
  const Points<T> targets = sc.moved.points;
  Points<T> ref0;
  alone.refine(start, targets, 3, ref0);
  for (const int k : exponents<T>()) {
    INFO(type_name<T>() << ", scale 2^" << k);
    Points<T> out;
    Deformer<T>(scaled(sc.vertices, k), sc.triangles, scaled(sc.rest, k), o).deform(scaled(sc.moved, k), out);
    CHECK(scaled_mismatch<T>(out, out0, k, twice) == "");
    ArapRefiner<T> a(scaled(sc.vertices, k), sc.triangles, held);
    Points<T> ref;
    a.refine(scaled(start, k), scaled(targets, k), 3, ref);
    CHECK(scaled_mismatch<T>(ref, ref0, k, twice) == "");
  }
}

TEMPLATE_TEST_CASE("scale: handle groups move targets by the scaled motion, rounded once", "[scale][groups]", float,
                   double) {
  using T = TestType;
  std::mt19937_64 g(11);
  const RandomScene<T> sc = random_scene<T>(g, 40, 2);
  const Matrix3<T> R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix().cast<T>();
  const Vector3<T> t(T(0.25), T(-0.125), T(0.5)), pivot(T(0.5), T(0.25), T(-0.75));
  const std::vector<Eigen::Index> points{0, 2, 5}, segments{1};
  for (const Transform tr : {Transform::rigid, Transform::similarity, Transform::affine}) {
    Options o;
    o.transform = tr;
    Deformer<T> d0(sc.vertices, sc.rest, o);
    d0.transform_handles(points, segments, R, t, pivot);
    const Handles<T> q0 = d0.targets();
    for (const int k : exponents<T>()) {
      INFO(type_name<T>() << " " << name(tr) << ", scale 2^" << k);
      Deformer<T> d(scaled(sc.vertices, k), scaled(sc.rest, k), o);
      d.transform_handles(points, segments, R, scaled<T>(Points<T>(t.transpose()), k).row(0).transpose(),
                          scaled<T>(Points<T>(pivot.transpose()), k).row(0).transpose());
      const Handles<T>& q = d.targets();
      CHECK(scaled_mismatch<T>(q.points, q0.points, k) == "");
      CHECK(scaled_mismatch<T>(q.segment_a, q0.segment_a, k) == "");
      CHECK(scaled_mismatch<T>(q.segment_b, q0.segment_b, k) == "");
      Points<T> out, ref;
      d.deform(out);
      d0.deform(scaled(q, -k), ref);  // the targets as rounded, divided back: exact
      CHECK(scaled_mismatch<T>(out, ref, k) == "");
    }
  }
}

TEMPLATE_TEST_CASE("scale: point fits leave rotation and scale unchanged and scale the translation",
                   "[scale][point_fit]", float, double) {
  using T = TestType;
  std::mt19937_64 g(9);
  const Points<T> p = quantised_points<T>(g, 20), q = quantised_points<T>(g, 20);
  Eigen::Matrix<T, Eigen::Dynamic, 1> w(20);
  for (Eigen::Index i = 0; i < 20; ++i) w[i] = T(1 + i % 4);
  for (const RotationMethod m : all_rotation_methods)
    for (const bool similarity : {false, true}) {
      const auto fit = [&](const Points<T>& a, const Points<T>& b) {
        return similarity ? fit_similarity<T>(a, b, w, m) : fit_rigid<T>(a, b, w, m);
      };
      const SimilarityTransform<T> f0 = fit(p, q);
      for (const int k : exponents<T>()) {
        INFO(type_name<T>() << " " << to_string(m) << (similarity ? " similarity" : " rigid") << ", scale 2^" << k);
        const SimilarityTransform<T> f = fit(scaled(p, k), scaled(q, k));
        CHECK(f.rotation == f0.rotation);
        CHECK(f.scale == f0.scale);
        CHECK(scaled_mismatch<T>(Points<T>(f.translation.transpose()), Points<T>(f0.translation.transpose()), k) == "");
      }
      // p and q at different scales: the rotation is that of H up to a positive factor, the scale follows.
      for (const int k : {-kMaxExponent<T> / 2, kMaxExponent<T> / 2}) {
        INFO("q scaled by 2^" << k);
        const SimilarityTransform<T> f = fit(p, scaled(q, k));
        CHECK(f.rotation == f0.rotation);
        if (similarity) CHECK(f.scale == std::ldexp(f0.scale, k));
      }
    }
}

TEMPLATE_TEST_CASE("scale: what T cannot represent is refused with the reason, never returned", "[scale][errors]",
                   float, double) {
  using T = TestType;
  const T big = std::numeric_limits<T>::max() / 256, tiny = std::numeric_limits<T>::min();
  INFO(type_name<T>());
  std::mt19937_64 g(5);
  const RandomScene<T> sc = random_scene<T>(g, 20, 0);
  SECTION("a scene smaller than the smallest normal number") {
    // Its local frame would need the factor 2^-e beyond T's range. The scene's diagonal is below 3.5.
    const T s = tiny / 8;
    REQUIRE_THROWS_WITH((Deformer<T>(sc.vertices * s, {sc.rest.points * s, {}, {}})),
                        Catch::Matchers::ContainsSubstring("too small for the precision"));
  }
  SECTION("targets further from the scene than its local frame holds") {
    // A scene of diagonal about 2^-99 (local frame 2^e, e = -99) and a target 2^-100 max(T) / 8 from the
    // origin, beyond the limit 2^e max(T) / 64 (data.hpp, Units).
    const T s = std::ldexp(T(1), -100);
    const Deformer<T> d(sc.vertices * s, {sc.rest.points * s, {}, {}});
    Handles<T> m{sc.moved.points * s, {}, {}};
    m.points(0, 0) = std::numeric_limits<T>::max() / 8 * s;
    Points<T> out;
    REQUIRE_THROWS_WITH(d.deform(m, out),
                        Catch::Matchers::ContainsSubstring("coordinate too large in moved handles points") &&
                            Catch::Matchers::ContainsSubstring("times the scene's size"));
  }
  SECTION("a deformed position beyond the range of T") {
    // Similarity: two handles 2^-10 apart pulled max(T) / 256 apart scale the scene by 2^10 max(T) / 256;
    // the vertex 1 away from them lands near 4 max(T).
    Points<T> v(3, 3);
    v << 0, 0, 0, T(1) / 1024, 0, 0, 1, T(0.5), 0;
    const Handles<T> rest{v.topRows(2), {}, {}};
    Options o;
    o.transform = Transform::similarity;
    for (const int arap : {0, 2}) {
      INFO("arap_iterations " << arap);
      o.arap_iterations = arap;
      Triangles f(1, 3);
      f << 0, 1, 2;
      const Deformer<T> d(v, f, rest, o);
      Handles<T> m = rest;
      m.points(1, 0) = big;
      Points<T> out = Points<T>::Constant(3, 3, T(7));
      REQUIRE_THROWS_WITH(d.deform(m, out), Catch::Matchers::ContainsSubstring("vertex 2") &&
                                                Catch::Matchers::ContainsSubstring("overflows"));
      if (arap > 0) CHECK(out == Points<T>::Constant(3, 3, T(7)));  // untouched
    }
  }
  SECTION("a point fit whose scale or translation is beyond the range of T") {
    const Points<T> p = sc.vertices, q = scaled(sc.vertices, kMaxExponent<T> + 5);
    const Points<T> p_small = scaled(p, -kMaxExponent<T> - 5);
    const Eigen::Matrix<T, Eigen::Dynamic, 1> w;
    REQUIRE_THROWS_WITH(fit_similarity<T>(p_small, q, w),
                        Catch::Matchers::StartsWith("fit_similarity: the scale overflows"));
    CHECK_NOTHROW(fit_rigid<T>(p_small, q, w));  // no scale: R and t are representable
    // All p at x = 3/4 max(T), all q at -3/4 max(T): R = I and t = -3/2 max(T).
    Points<T> far = Points<T>::Zero(4, 3), far_q = Points<T>::Zero(4, 3);
    far.col(0).setConstant(std::numeric_limits<T>::max() / 4 * 3);
    far_q.col(0).setConstant(-std::numeric_limits<T>::max() / 4 * 3);
    REQUIRE_THROWS_WITH(fit_rigid<T>(far, far_q, w), Catch::Matchers::StartsWith("fit_rigid: the translation"));
  }
}
