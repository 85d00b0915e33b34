// Rotating handle groups (Deformer::transform_handles): a group of handles moved as one rigid body.
// A group of every handle moves the whole mesh by that rigid motion (to a bound derived below), a group of
// one handle sets exactly what set_point_target / set_segment_target would, the rotation check accepts the
// rotations users build in T and refuses the rest, and a refused call changes nothing.
#include "tests/test_deformer_common.hpp"

#include "core/src/deformer/validation.hpp"

#include <Eigen/Geometry>

#include <array>
#include <cstdio>
#include <vector>

using namespace deformer_test;

namespace {

template <class T>
constexpr double eps = std::numeric_limits<T>::epsilon();

std::vector<Eigen::Index> all_indices(Eigen::Index n) {
  std::vector<Eigen::Index> v(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) v[static_cast<std::size_t>(i)] = i;
  return v;
}

/// The image the documentation promises, written out: (((R_i0 d_0 + R_i1 d_1) + R_i2 d_2) + pivot_i) + t_i
/// with d = x - pivot, in T.
template <class T>
Vector3<T> documented_image(const Vector3<T>& x, const Matrix3<T>& R, const Vector3<T>& t, const Vector3<T>& c) {
  const Vector3<T> d(x[0] - c[0], x[1] - c[1], x[2] - c[2]);
  Vector3<T> y;
  for (int i = 0; i < 3; ++i) y[i] = (((R(i, 0) * d[0] + R(i, 1) * d[1]) + R(i, 2) * d[2]) + c[i]) + t[i];
  return y;
}

template <class T>
bool same_targets(const Handles<T>& a, const Handles<T>& b) {
  return a.points == b.points && a.segment_a == b.segment_a && a.segment_b == b.segment_b;
}

}  // namespace

TEMPLATE_TEST_CASE("a group of every handle moves the mesh by that rigid motion", "[deformer][groups]", float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  for (int trial = 0; trial < 4; ++trial) {
    const DeformCase<T> sc = random_case<T>(g, 200, 8);
    const Mat3d R = random_rotation(g);  // the exact motion: R in double, c and t in T
    const Vector3<T> c = random_vector(g, -2, 2).cast<T>(), t = random_vector(g, -2, 2).cast<T>();
    const Vec3d cd = c.template cast<double>(), td = t.template cast<double>();
    const auto motion = [&](const Vec3d& x) { return Vec3d(R * (x - cd) + cd + td); };
    for (Transform tr : {Transform::rigid, Transform::similarity}) {
      INFO(name(tr) << " trial " << trial);
      Options o;
      o.transform = tr;
      Deformer<T> def(sc.vertices, sc.rest, o);
      const std::vector<Eigen::Index> points = all_indices(sc.rest.point_count());
      def.transform_handles(points, {}, R.cast<T>(), t, c);
      const Handles<T>& q = def.targets();

      // The targets, against the exact motion of the rest handles. Each coordinate is x - c (one rounding),
      // three products and two sums with R rounded to T (gamma_3 + 2 u over a unit row of R: 5 u |x - c|),
      // then + c and + t (one rounding each, on values below |x - c| + |c| + |t|): at most
      // 7 u (|x - c| + |c| + |t|) < 4 eps (...) per coordinate, so delta = 4 sqrt(3) eps (...) in norm.
      double delta = 0;
      for (Eigen::Index j = 0; j < sc.rest.point_count(); ++j) {
        const Vec3d x = sc.rest.points.row(j).transpose().template cast<double>();
        const double dj = 4 * std::sqrt(3.0) * eps<T> * ((x - cd).norm() + cd.norm() + td.norm());
        const double dev = (q.points.row(j).transpose().template cast<double>() - motion(x)).norm();
        INFO("handle " << j << " deviation " << dev << " bound " << dj);
        REQUIRE(dev <= dj);
        delta = std::max(delta, dj);
      }

      // The mesh. |out - motion(v)| <= |out - direct| + |direct - motion(v)|, direct = the exact MLS of the
      // targets as they are (tests/support/mls_reference.hpp: eps(T) bound_unit, plus eps(double) bound_unit
      // for the reference's own rounding). MLS reproduces rigid motions, so direct - motion(v) is the effect
      // of the targets' errors |delta_j| <= delta, to first order: q* moves by at most delta (a convex
      // combination); each qhat_j by at most 2 delta, so |dH|_F <= 2 delta sum_j (w_j / S) |phat_j|
      // <= 2 delta sqrt(trace G) <= 2 delta sqrt(3 s1) (Cauchy-Schwarz; G = sum (w_j / S) phat_j phat_j^T,
      // whose eigenvalues are H's singular values); R turns by |dR|_F <= 2 |dH|_F / gap (as in the reference's
      // bound) and, for similarity, mu = trace(R^T H) / D moves by at most sqrt(3) |dH|_F / D (stationary in R).
      // v' = q* + mu R vhat then moves by delta + (|dR| + |dmu|) |vhat|. The expected motion, evaluated in
      // double, adds 8 eps(double) (|v - c| + |c| + |t|).
      const double l = scene_size(sc.vertices, sc.rest);
      Points<T> out;
      def.deform(out);
      double worst = 0;
      for (Eigen::Index i = 0; i < sc.vertices.rows(); ++i) {
        const Vec3d v = sc.vertices.row(i).transpose().template cast<double>();
        const DirectVertex d = direct_vertex(v, sc.rest, q, o, l);
        REQUIRE(d.well_posed);
        const double dH = 2 * delta * std::sqrt(3 * d.s1);
        const double dR = 2 * dH / d.gap, dmu = tr == Transform::similarity ? std::sqrt(3.0) * dH / d.D : 0;
        const double bound = (eps<T> + eps<double>)*d.bound_unit + delta + (dR + dmu) * d.vhat_norm +
                             8 * eps<double> * ((v - cd).norm() + cd.norm() + td.norm());
        const double dev = (out.row(i).transpose().template cast<double>() - motion(v)).norm();
        INFO("vertex " << i << " deviation " << dev << " bound " << bound);
        REQUIRE(dev <= bound);
        worst = std::max(worst, dev / bound);
      }
      std::printf("[groups] %s %s trial %d: max deviation / bound %.3g\n", type_name<T>(), name(tr), trial, worst);
    }
  }
}

TEMPLATE_TEST_CASE("a quarter turn about the origin is exact: every transform reproduces it", "[deformer][groups]",
                   float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  // Entries 0 and +-1, pivot and t zero: every product and sum is exact, so the targets are exactly R p and
  // the reference's own bound applies unchanged (with the double reference's rounding).
  Matrix3<T> R;
  R << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  const DeformCase<T> sc = random_case<T>(g, 200, 8, 2);
  for (Transform tr : all_transforms) {
    INFO(name(tr));
    Options o;
    o.transform = tr;
    Deformer<T> def(sc.vertices, sc.rest, o);
    def.transform_handles(all_indices(sc.rest.point_count()), all_indices(sc.rest.segment_count()), R,
                          Vector3<T>::Zero(), Vector3<T>::Zero());
    CHECK(def.targets().points == (sc.rest.points * R.transpose()).eval());
    CHECK(def.targets().segment_a == (sc.rest.segment_a * R.transpose()).eval());
    CHECK(def.targets().segment_b == (sc.rest.segment_b * R.transpose()).eval());
    Points<T> out;
    def.deform(out);
    const double l = scene_size(sc.vertices, sc.rest);
    for (Eigen::Index i = 0; i < sc.vertices.rows(); ++i) {
      const Vec3d v = sc.vertices.row(i).transpose().template cast<double>();
      const DirectVertex d = direct_vertex(v, sc.rest, def.targets(), o, l);
      if (!d.well_posed) continue;  // affine: fewer than four handles of non-negligible weight
      const double bound = (eps<T> + eps<double>)*d.bound_unit;
      const double dev = (out.row(i).transpose().template cast<double>() - R.template cast<double>() * v).norm();
      INFO("vertex " << i << " deviation " << dev << " bound " << bound);
      REQUIRE(dev <= bound);
    }
  }
}

TEMPLATE_TEST_CASE("a group of one handle sets what set_point_target / set_segment_target would", "[deformer][groups]",
                   float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  const DeformCase<T> sc = random_case<T>(g, 100, 5, 3);
  Deformer<T> a(sc.vertices, sc.rest, {}), b(sc.vertices, sc.rest, {});
  // Some targets already moved: a group changes only its own handles.
  const Vector3<T> moved(T(0.25), T(-0.5), T(0.125));
  a.set_point_target(4, moved);
  b.set_point_target(4, moved);
  for (int trial = 0; trial < 8; ++trial) {
    const Matrix3<T> R = random_rotation(g).cast<T>();
    const Vector3<T> t = random_vector(g, -3, 3).cast<T>(), c = random_vector(g, -3, 3).cast<T>();
    const Eigen::Index i = trial % 4, s = trial % 3;
    const std::array<Eigen::Index, 1> pi{i}, si{s};
    a.transform_handles(pi, {}, R, t, c);
    b.set_point_target(i, documented_image<T>(sc.rest.points.row(i).transpose(), R, t, c));
    a.transform_handles({}, si, R, t, c);
    b.set_segment_target(s, documented_image<T>(sc.rest.segment_a.row(s).transpose(), R, t, c),
                         documented_image<T>(sc.rest.segment_b.row(s).transpose(), R, t, c));
    INFO("trial " << trial);
    REQUIRE(same_targets(a.targets(), b.targets()));
  }
  CHECK(a.targets().points.row(4) == moved.transpose());
  Points<T> oa, ob;
  a.deform(oa);
  b.deform(ob);
  CHECK(oa == ob);
  // Rest-based: applying the same motion twice is the same as once; a repeated index is harmless.
  const Matrix3<T> R = random_rotation(g).cast<T>();
  const Vector3<T> t = random_vector(g).cast<T>(), c = random_vector(g).cast<T>();
  const std::array<Eigen::Index, 3> repeated{1, 1, 2};
  a.transform_handles(repeated, {}, R, t, c);
  const Handles<T> once = a.targets();
  a.transform_handles(repeated, {}, R, t, c);
  CHECK(same_targets(a.targets(), once));
}

TEMPLATE_TEST_CASE("rotations built in T pass the rotation check, other matrices do not", "[deformer][groups]", float,
                   double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  const T tol = detail::rotation_tolerance<T>();
  // What a caller builds in T: a double rotation rounded, Eigen's AngleAxis and Quaternion in T, products of
  // two of those, and fit_rotation (every method) of random, rank-2 and rank-1 matrices. The tolerance
  // (validation.hpp: 64 eps, fit_rotation's own guarantee) must accept them all.
  T worst = 0;
  for (int k = 0; k < 20000; ++k) {
    const Mat3d Rd = random_rotation(g);
    const Eigen::AngleAxis<T> aa(T(std::uniform_real_distribution<double>(-4, 4)(g)),
                                 random_vector(g).normalized().cast<T>());
    const Eigen::Quaternion<T> qt = Eigen::Quaterniond(Rd).cast<T>().normalized();
    Matrix3<T> H;
    for (int e = 0; e < 9; ++e) H(e / 3, e % 3) = T(std::normal_distribution<double>()(g));
    if (k % 3 == 1) H.col(2) = H.col(1);
    if (k % 3 == 2) H.col(1) = H.col(2) = H.col(0);
    const RotationMethod method = all_rotation_methods[k % std::size(all_rotation_methods)];
    for (const Matrix3<T>& R :
         {Matrix3<T>(Rd.cast<T>()), aa.toRotationMatrix(), qt.toRotationMatrix(),
          Matrix3<T>(aa.toRotationMatrix() * qt.toRotationMatrix()), fit_rotation<T>(H, method)}) {
      const T e = detail::orthonormality_error<T>(R);
      worst = std::max(worst, e);
      INFO("R =\n" << R << "\n|R^T R - I| = " << e);
      REQUIRE(e <= tol);
    }
  }
  std::printf("[groups] %s: largest |R^T R - I| of rotations built in T: %.2f eps (tolerance 64)\n", type_name<T>(),
              double(worst / std::numeric_limits<T>::epsilon()));

  const DeformCase<T> sc = random_case<T>(g, 20, 3);
  Deformer<T> def(sc.vertices, sc.rest, {});
  const std::array<Eigen::Index, 1> one{0};
  const Vector3<T> zero = Vector3<T>::Zero();
  CHECK_NOTHROW(def.transform_handles(one, {}, Matrix3<T>::Identity(), zero, zero));
  // Scaled by 1 + 40 eps: |R^T R - I| = 80 eps on the diagonal.
  CHECK_THROWS_WITH(def.transform_handles(one, {}, Matrix3<T>::Identity() * T(1 + 40 * eps<T>), zero, zero),
                    Catch::Matchers::ContainsSubstring("not a rotation (largest entry of |R^T R - I|"));
  CHECK_THROWS_WITH(def.transform_handles(one, {}, Matrix3<T>(Vector3<T>(1, 1, -1).asDiagonal()), zero, zero),
                    Catch::Matchers::ContainsSubstring("a reflection"));
}

TEMPLATE_TEST_CASE("a refused group motion changes no target", "[deformer][groups][errors]", float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  const DeformCase<T> sc = random_case<T>(g, 20, 3, 2);
  Deformer<T> def(sc.vertices, sc.rest, {});
  def.set_point_target(1, Vector3<T>(1, 2, 3));
  def.set_segment_target(0, Vector3<T>(1, 2, 3), Vector3<T>(3, 2, 1));
  const Handles<T> before = def.targets();
  const Matrix3<T> I = Matrix3<T>::Identity();
  const Vector3<T> zero = Vector3<T>::Zero();
  const T nan = std::numeric_limits<T>::quiet_NaN(), inf = std::numeric_limits<T>::infinity();
  const T big = std::numeric_limits<T>::max();
  const std::array<Eigen::Index, 2> points{0, 2}, bad_point{0, 3}, negative{1, -1}, segments{0, 1}, bad_segment{1, 2};
  // Valid indices are listed first: a call that fails on a later one must not have moved the earlier ones.
  CHECK_THROWS_WITH(def.transform_handles(bad_point, segments, I, zero, zero),
                    "Deformer::transform_handles: point index 3 but 3 point handles");
  CHECK_THROWS_AS(def.transform_handles(negative, segments, I, zero, zero), std::out_of_range);
  CHECK_THROWS_WITH(def.transform_handles(points, bad_segment, I, zero, zero),
                    "Deformer::transform_handles: segment index 2 but 2 segment handles");
  Matrix3<T> with_nan = I;
  with_nan(1, 2) = nan;
  CHECK_THROWS_WITH(def.transform_handles(points, segments, with_nan, zero, zero),
                    Catch::Matchers::ContainsSubstring("the rotation has a non-finite entry"));
  CHECK_THROWS_WITH(def.transform_handles(points, segments, T(2) * I, zero, zero),
                    Catch::Matchers::ContainsSubstring("not a rotation"));
  CHECK_THROWS_WITH(def.transform_handles(points, segments, I, Vector3<T>(0, inf, 0), zero),
                    Catch::Matchers::ContainsSubstring("non-finite translation"));
  CHECK_THROWS_WITH(def.transform_handles(points, segments, I, zero, Vector3<T>(nan, 0, 0)),
                    Catch::Matchers::ContainsSubstring("non-finite pivot"));
  // Images beyond the coordinate limit (max / 64), or overflowing to infinity.
  CHECK_THROWS_WITH(
      def.transform_handles(points, segments, I, Vector3<T>(0, 0, detail::coordinate_limit<T>() * 2), zero),
      "Deformer::transform_handles: the image of point handle 0 has a non-finite or too large coordinate");
  const Matrix3<T> half_turn = Vector3<T>(-1, -1, 1).asDiagonal();  // about z: x -> 2 pivot - x overflows
  CHECK_THROWS_WITH(
      def.transform_handles({}, segments, half_turn, zero, Vector3<T>(big, 0, 0)),
      Catch::Matchers::ContainsSubstring("the image of segment handle 0 has a non-finite or too large coordinate"));
  CHECK(same_targets(def.targets(), before));
  // The same calls with valid input do change the targets.
  def.transform_handles(points, segments, I, Vector3<T>(0, 0, 1), zero);
  CHECK_FALSE(same_targets(def.targets(), before));
}
