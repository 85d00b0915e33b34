// Bad input: std::invalid_argument with a message naming the problem, and `out` left
// untouched (bitwise, size included).
#include "tests/test_deformer_common.hpp"

#include <algorithm>
#include <limits>
#include <vector>

using namespace deformer_test;

namespace {

template <class T>
void expect_ctor_error(const Points<T>& v, const Handles<T>& h, const Options& o, const std::string& what) {
  INFO("expected message containing: " << what);
  CHECK_THROWS_AS(Deformer<T>(v, h, o), std::invalid_argument);
  CHECK_THROWS_WITH(Deformer<T>(v, h, o), Catch::Matchers::ContainsSubstring(what));
}

/// deform with bad handles must throw and leave both an empty and a correctly sized `out` as they were.
template <class T>
void expect_deform_error(const Deformer<T>& def, const Handles<T>& moved, const std::string& what) {
  INFO("expected message containing: " << what);
  Points<T> empty;
  CHECK_THROWS_WITH(def.deform(moved, empty), Catch::Matchers::ContainsSubstring(what));
  CHECK(empty.rows() == 0);
  Points<T> out = Points<T>::Constant(def.vertex_count(), 3, T(42));
  CHECK_THROWS_AS(def.deform(moved, out), std::invalid_argument);
  CHECK(out.rows() == def.vertex_count());
  CHECK((out.array() == T(42)).all());
  PointsRowMajor<T> buffer = PointsRowMajor<T>::Constant(def.vertex_count(), 3, T(7));
  CHECK_THROWS_AS(def.deform(moved, InterleavedView<T>(buffer.data(), def.vertex_count(), 3)), std::invalid_argument);
  CHECK((buffer.array() == T(7)).all());
}

}  // namespace

TEMPLATE_TEST_CASE("bad rest input is rejected with a message naming the problem", "[deformer][errors]", float,
                   double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  const DeformCase<T> sc = random_case<T>(g, 50, 5, 2);
  const T nan = std::numeric_limits<T>::quiet_NaN(), inf = std::numeric_limits<T>::infinity();
  Options o;
  SECTION("no handles") { expect_ctor_error(sc.vertices, Handles<T>{}, o, "no handles"); }
  SECTION("non-finite coordinates") {
    Points<T> v = sc.vertices;
    v(3, 1) = nan;
    expect_ctor_error(v, sc.rest, o, "non-finite coordinate in rest vertices");
    Handles<T> h = sc.rest;
    h.points(2, 0) = inf;
    expect_ctor_error(sc.vertices, h, o, "non-finite coordinate in rest handles points");
    h = sc.rest;
    h.segment_b(1, 2) = -inf;
    expect_ctor_error(sc.vertices, h, o, "non-finite coordinate in rest handles segment_b");
  }
  SECTION("mismatched segment end points") {
    Handles<T> h = sc.rest;
    h.segment_b.conservativeResize(1, 3);
    expect_ctor_error(sc.vertices, h, o, "segment start points (segment_a) but 1 end points");
  }
  SECTION("weight exponent") {
    for (double u : {0.99, 0.0, -2.0, double(nan), double(inf)}) {
      o.weight_exponent = u;
      expect_ctor_error(sc.vertices, sc.rest, o, "weight_exponent must be a finite real >= 1");
    }
    o.weight_exponent = 1.0;  // the boundary is allowed
    CHECK_NOTHROW(Deformer<T>(sc.vertices, sc.rest, o));
  }
  SECTION("zero-length segments (documented: rejected, use a point handle)") {
    Handles<T> h = sc.rest;
    h.segment_b.row(1) = h.segment_a.row(1);
    expect_ctor_error(sc.vertices, h, o, "segment handle 1 has zero length");
  }
  SECTION("a segment is a point when shorter than the snapping distance at its end, whatever the vertices") {
    // deformer/snap.hpp: |b - a| <= 64 eps(T) times the distance from a to the nearest other handle. Handles
    // (0,0,0) and a segment from (1,0,0), so that distance is 1; a vertex far away changes nothing.
    const T eps = std::numeric_limits<T>::epsilon();
    Handles<T> h;
    h.points = Points<T>::Zero(1, 3);
    h.segment_a = Points<T>(1, 3);
    h.segment_a << 1, 0, 0;
    h.segment_b = h.segment_a;
    Points<T> v = sc.vertices;
    v.row(0) << T(1e4), T(0), T(0);  // before: 64 eps(T) times the scene's diagonal (1e4) made 1e-3 a point
    h.segment_b(0, 1) = T(32 * eps);
    expect_ctor_error(v, h, o, "segment handle 0 has zero length");
    for (T len : {T(128 * eps), T(1e-3)}) {
      h.segment_b(0, 1) = len;
      CHECK_NOTHROW(Deformer<T>(v, h, o));
    }
    // A lone segment has no other handle to measure against: only a zero length is refused.
    Handles<T> lone;
    lone.segment_a = h.segment_a;
    lone.segment_b = h.segment_a;
    expect_ctor_error(v, lone, o, "segment handle 0 has zero length");
    lone.segment_b(0, 1) = std::numeric_limits<T>::epsilon();
    CHECK_NOTHROW(Deformer<T>(v, lone, o));
  }
  SECTION("affine with handles that do not span 3D") {
    o.transform = Transform::affine;
    Handles<T> h;
    h.points = random_points<T>(g, 3);
    expect_ctor_error(sc.vertices, h, o, "needs handles spanning 3D");
    // Coplanar (z = 0.5) and collinear point sets, and segments in a plane.
    h.points = random_points<T>(g, 8);
    h.points.col(2).setConstant(T(0.5));
    expect_ctor_error(sc.vertices, h, o, "coplanar");
    const Points<T> base = random_points<T>(g, 1), dir = random_points<T>(g, 1);
    for (Eigen::Index i = 0; i < 8; ++i) h.points.row(i) = base + T(i) * dir;
    expect_ctor_error(sc.vertices, h, o, "collinear");
    Handles<T> s;
    s.segment_a = random_points<T>(g, 3);
    s.segment_b = random_points<T>(g, 3);
    s.segment_a.col(0).setZero();
    s.segment_b.col(0).setZero();
    expect_ctor_error(sc.vertices, s, o, "coplanar");
    // Rigid and similarity accept such handles (a rotation about the line or the plane normal is still
    // defined by the fit), and affine accepts four non-coplanar points.
    o.transform = Transform::rigid;
    CHECK_NOTHROW(Deformer<T>(sc.vertices, h, o));
    o.transform = Transform::affine;
    Handles<T> tet;
    tet.points.resize(4, 3);
    tet.points << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
    CHECK_NOTHROW(Deformer<T>(sc.vertices, tet, o));
  }
  SECTION("options out of range") {
    o.threads = -1;
    expect_ctor_error(sc.vertices, sc.rest, o, "threads must be >= 0");
    o.threads = 0;
    o.method = static_cast<RotationMethod>(99);
    expect_ctor_error(sc.vertices, sc.rest, o, "unknown RotationMethod");
    o.method = RotationMethod::axis_angle;
    o.isa = static_cast<Isa>(99);
    expect_ctor_error(sc.vertices, sc.rest, o, "unknown Isa value 99");
    // An instruction set this CPU lacks is refused at construction, not when a frame would run it.
    o.isa = std::nullopt;
    const std::vector<Isa> runs = supported_isas();
    for (const Isa isa : {Isa::scalar, Isa::sse4_2, Isa::avx2, Isa::avx512, Isa::neon}) {
      o.isa = isa;
      if (std::find(runs.begin(), runs.end(), isa) == runs.end())
        expect_ctor_error(sc.vertices, sc.rest, o, "this CPU cannot run it");
      else
        CHECK_NOTHROW(Deformer<T>(sc.vertices, sc.rest, o));
    }
  }
  SECTION("reset_rest_pose validates too and keeps the session on error") {
    Deformer<T> def(sc.vertices, sc.rest, o);
    Handles<T> h = sc.rest;
    h.points(0, 0) = nan;
    CHECK_THROWS_WITH(def.reset_rest_pose(sc.vertices, h), Catch::Matchers::ContainsSubstring("non-finite"));
    CHECK(def.vertex_count() == sc.vertices.rows());
    Points<T> out;
    def.deform(sc.rest, out);
    CHECK(out.allFinite());
  }
}

TEMPLATE_TEST_CASE("bad moved handles are rejected and leave out untouched", "[deformer][errors]", float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  const DeformCase<T> sc = random_case<T>(g, 50, 5, 2);
  for (Transform tr : all_transforms) {
    INFO(name(tr));
    Options o;
    o.transform = tr;
    const Deformer<T> def(sc.vertices, sc.rest, o);
    Handles<T> m = sc.rest;
    m.points.conservativeResize(4, 3);
    expect_deform_error(def, m, "5 point handles at rest but 4 moved point handles");
    m = sc.rest;
    m.segment_a.conservativeResize(3, 3);
    m.segment_b.conservativeResize(3, 3);
    m.segment_a.row(2).setZero();
    m.segment_b.row(2).setOnes();
    expect_deform_error(def, m, "2 segment handles at rest but 3 moved segment_a and 3 moved segment_b");
    m = sc.rest;
    m.segment_b.conservativeResize(1, 3);
    expect_deform_error(def, m, "moved segment_b");
    m = sc.rest;
    m.points(1, 1) = std::numeric_limits<T>::quiet_NaN();
    expect_deform_error(def, m, "non-finite coordinate in moved handles points (row 1)");
    m = sc.rest;
    m.segment_a(0, 2) = std::numeric_limits<T>::infinity();
    expect_deform_error(def, m, "non-finite coordinate in moved handles segment_a (row 0)");
    m = sc.rest;
    m.points(0, 0) = std::numeric_limits<T>::max() / 2;  // would overflow H
    expect_deform_error(def, m, "coordinate too large in moved handles points");
    // A wrongly sized interleaved buffer cannot be resized: rejected, untouched.
    PointsRowMajor<T> small = PointsRowMajor<T>::Constant(49, 3, T(7));
    CHECK_THROWS_WITH(
        def.deform(sc.rest, InterleavedView<T>(small.data(), 49, 3)),
        Catch::Matchers::ContainsSubstring("interleaved output has 49 rows but the model has 50 vertices"));
    CHECK((small.array() == T(7)).all());
  }
}

TEMPLATE_TEST_CASE("stateful targets validate their index and coordinates", "[deformer][errors]", float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  const DeformCase<T> sc = random_case<T>(g, 20, 3, 1);
  Deformer<T> def(sc.vertices, sc.rest, {});
  CHECK_THROWS_AS(def.set_point_target(3, Vector3<T>::Zero()), std::out_of_range);
  CHECK_THROWS_AS(def.set_point_target(-1, Vector3<T>::Zero()), std::out_of_range);
  CHECK_THROWS_AS(def.set_segment_target(1, Vector3<T>::Zero(), Vector3<T>::Ones()), std::out_of_range);
  CHECK_THROWS_AS(def.set_point_target(0, Vector3<T>::Constant(std::numeric_limits<T>::quiet_NaN())),
                  std::invalid_argument);
  CHECK(def.targets().points == sc.rest.points);  // unchanged by the failed calls
}

TEMPLATE_TEST_CASE("the stateful session writes interleaved output like the column-major one", "[deformer]", float,
                   double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  const DeformCase<T> sc = random_case<T>(g, 50, 4, 1);
  Deformer<T> def(sc.vertices, sc.rest, {});
  def.set_point_target(1, sc.rest.points.row(1).transpose() + Vector3<T>(T(0.25), 0, 0));
  Points<T> expected;
  def.deform(expected);
  PointsRowMajor<T> buffer(def.vertex_count(), 3);
  def.deform(InterleavedView<T>(buffer.data(), buffer.rows(), 3));
  CHECK(buffer == PointsRowMajor<T>(expected));  // the same kernel, only the output strides differ
  PointsRowMajor<T> small = PointsRowMajor<T>::Constant(def.vertex_count() - 1, 3, T(7));
  CHECK_THROWS_AS(def.deform(InterleavedView<T>(small.data(), small.rows(), 3)), std::invalid_argument);
  CHECK((small.array() == T(7)).all());
}

TEMPLATE_TEST_CASE("a moved-from session throws std::logic_error instead of crashing", "[deformer][errors]", float,
                   double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  const DeformCase<T> sc = random_case<T>(g, 20, 3);
  Deformer<T> a(sc.vertices, sc.rest, {});
  Deformer<T> b(std::move(a));
  Points<T> out;
  PointsRowMajor<T> buffer(20, 3);
  CHECK_THROWS_AS(a.deform(out), std::logic_error);
  CHECK_THROWS_AS(a.deform(sc.rest, out), std::logic_error);
  CHECK_THROWS_AS(a.deform(sc.rest, InterleavedView<T>(buffer.data(), 20, 3)), std::logic_error);
  CHECK_THROWS_AS(a.set_point_target(0, Vector3<T>::Zero()), std::logic_error);
  CHECK_THROWS_AS(a.targets(), std::logic_error);
  CHECK_THROWS_AS(a.vertex_count(), std::logic_error);
  CHECK_THROWS_AS(a.memory_bytes(), std::logic_error);
  CHECK_THROWS_WITH(a.options(), Catch::Matchers::ContainsSubstring("moved from"));
  CHECK(out.rows() == 0);
  b.deform(out);  // the new owner works
  CHECK(out.rows() == 20);
  a = std::move(b);  // assigning a live session makes it usable again
  CHECK(a.vertex_count() == 20);
  CHECK_THROWS_AS(b.vertex_count(), std::logic_error);
}

TEMPLATE_TEST_CASE("point handles at one rest position must keep one target", "[deformer][errors]", float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  DeformCase<T> sc = random_case<T>(g, 30, 5);
  sc.rest.points.row(3) = sc.rest.points.row(1);  // handles 1 and 3 coincide
  Deformer<T> def(sc.vertices, sc.rest, {});
  Handles<T> moved = transformed(sc.rest, random_rotation(g), random_vector(g));
  Points<T> out;
  def.deform(moved, out);  // moved together: fine
  CHECK(out.allFinite());
  moved.points(3, 0) += T(0.5);
  expect_deform_error(def, moved, "point handles 1 and 3 share their rest position");
  // The stateful session checks the same when it deforms.
  def.set_point_target(1, Vector3<T>(1, 2, 3));
  CHECK_THROWS_WITH(def.deform(out), Catch::Matchers::ContainsSubstring("different targets"));
  def.set_point_target(3, Vector3<T>(1, 2, 3));
  CHECK_NOTHROW(def.deform(out));
}

// The finiteness check runs on each thread's own blocks (deformer.cpp, run); the error must still name the
// smallest overflowing vertex, whichever thread found it first, for either output layout. Similarity: two
// handles 2^-10 apart pulled max(T) / 256 apart scale the scene by 2^10 max(T) / 256, so a vertex 1 away from
// them lands near 4 max(T) and overflows, while one at a handle's rest position lands on its target.
TEMPLATE_TEST_CASE("an overflowing deformed position is named by its smallest vertex on any thread count",
                   "[deformer][errors]", float, double) {
  using T = TestType;
  constexpr Eigen::Index n = 200;  // 13 blocks of 16, cut between two threads near the middle
  for (const std::vector<Eigen::Index>& far :
       {std::vector<Eigen::Index>{41, 77, 150, 199}, std::vector<Eigen::Index>{150, 199},
        std::vector<Eigen::Index>{0, 120}}) {
    Points<T> v = Points<T>::Zero(n, 3);  // at the first handle
    for (const Eigen::Index i : far) v.row(i) << 1, T(0.5), 0;
    Points<T> hp(2, 3);
    hp << 0, 0, 0, T(1) / 1024, 0, 0;
    const Handles<T> rest{hp, {}, {}};
    Handles<T> moved = rest;
    moved.points(1, 0) = std::numeric_limits<T>::max() / 256;
    for (const int threads : {1, 2}) {
      Options o;
      o.transform = Transform::similarity;
      o.threads = threads;
      const Deformer<T> d(v, rest, o);
      const std::string want = "vertex " + std::to_string(far.front()) + "'s deformed position overflows";
      INFO(threads << " threads, " << want);
      Points<T> out;
      CHECK_THROWS_WITH(d.deform(moved, out), Catch::Matchers::ContainsSubstring(want));
      PointsRowMajor<T> buffer(n, 3);
      CHECK_THROWS_WITH(d.deform(moved, InterleavedView<T>(buffer.data(), n, 3)),
                        Catch::Matchers::ContainsSubstring(want));
    }
  }
}
