// Continuity of the MLS map at the handles: a vertex walked towards a handle (a point handle, the interior
// and the end of a segment) from 1e-1 to 1e-12 of the scene, and finally onto it, lands ever closer to where
// the vertex on the handle lands. Points and segments, both segment weight rules, all three transforms,
// stretched and shrunk segments, float and double, scalar and SIMD backends.
//
// The bound. Near a handle at x the map is f(x + delta e) - f(x) = delta (a + b log(1 / delta)) + O(delta^2),
// a and b vectors. It is Lipschitz (b = 0) almost everywhere: the other handles' relative weights are
// (d_min / d)^u = O(delta^u); p*, q* and vhat move by O(delta); for rigid segments with paper_constant weights
// the turn about the segment is ill-determined, but it acts on the component of vhat across the segment, which
// is O(delta) too. The exception is exact_integral at u = 2 at a segment's end: the weight |p(t) - v|^-2
// integrated along the segment gives a first moment int s ds / (s^2 + delta^2) that grows as log(1 / delta),
// so p* and q* approach the end as delta log(1 / delta), and where the segment's image is stretched or shrunk
// (q* - q_end differs from R (p* - p_end)) so does the map. a and b may point opposite ways (in about one random
// scene in five), so the slope at one delta bounds nothing below it: with g the slope (f(x + delta e) - f(x)) /
// delta measured at delta_1 = 1e-2 and delta_2 = 1e-3, b = (g_2 - g_1) / log(delta_1 / delta_2), and by the
// triangle inequality every step obeys
//   |f(x + delta e) - f(x)| <= 8 (L + |b| max(0, log(delta_1 / delta))) delta + tau,   L = max(|g_1|, 1),
// the 8 covering the O(delta^2) terms (at delta = 1e-1 the map is not yet first order) and the O(delta_1) error
// of the measured a and b; tau is the rounding of the two results: each carries (J + 16) eps of the per-vertex
// sums and coefficients (test_deformer_common.hpp) and 16 eps |vhat| of the rotation fit, on values of size at
// most Q = max_j |q_j| + the scene's diagonal: tau = 2 (J + 32) eps Q. A jump (the map's value on the handle
// differing from its limit) shows as a fixed difference at delta = 1e-12 that no such bound admits.
#include "tests/test_deformer_common.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

using namespace deformer_test;

namespace {

struct Walk {
  Vec3d x, e;  ///< the point on the handle, the direction of approach
  const char* what;
};

template <class T>
void check_walks(const Handles<T>& rest, const Handles<T>& moved, const std::vector<Walk>& walks, const Options& o,
                 const char* label) {
  constexpr int kSteps = 12;  // delta = 1e-1 ... 1e-12
  Points<T> v(static_cast<Eigen::Index>(walks.size()) * (kSteps + 1), 3);
  for (std::size_t w = 0; w < walks.size(); ++w)
    for (int s = 0; s <= kSteps; ++s) {
      const double delta = s == kSteps ? 0.0 : std::pow(10.0, -(s + 1));
      v.row(static_cast<Eigen::Index>(w) * (kSteps + 1) + s) =
          (walks[w].x + delta * walks[w].e).template cast<T>().transpose();
    }
  Points<T> out;
  Deformer<T>(v, rest, o).deform(moved, out);
  REQUIRE(out.allFinite());
  const double J = double(rest.points.rows() + 2 * rest.segment_a.rows());
  double Q = scene_size(v, moved);
  for (Eigen::Index i = 0; i < moved.points.rows(); ++i) Q = std::max(Q, double(moved.points.row(i).norm()));
  for (Eigen::Index i = 0; i < moved.segment_a.rows(); ++i)
    Q = std::max({Q, double(moved.segment_a.row(i).norm()), double(moved.segment_b.row(i).norm())});
  const double tau = 2 * (J + 32) * double(std::numeric_limits<T>::epsilon()) * Q;
  for (std::size_t w = 0; w < walks.size(); ++w) {
    const Eigen::Index base = static_cast<Eigen::Index>(w) * (kSteps + 1);
    const Vec3d limit = out.row(base + kSteps).transpose().template cast<double>();
    // The rounded vertex sits at delta' = |v - x| from the handle, not exactly delta: use the real distance.
    const Vec3d x = walks[w].x.template cast<T>().template cast<double>();
    auto dist = [&](int s) { return (v.row(base + s).transpose().template cast<double>() - x).norm(); };
    auto step = [&](int s) -> Vec3d { return out.row(base + s).transpose().template cast<double>() - limit; };
    auto jump = [&](int s) { return step(s).norm(); };
    const Vec3d g1 = step(1) / dist(1), g2 = step(2) / dist(2);  // delta = 1e-2, 1e-3
    const double L = std::max(g1.norm(), 1.0);
    const double b = (g2 - g1).norm() / std::log(dist(1) / dist(2));
    for (int s = 0; s < kSteps; ++s) {
      // (A float vertex may round onto x itself: distance 0, bound tau.)
      const double log_ratio = dist(s) > 0 ? std::max(0.0, std::log(dist(1) / dist(s))) : 0.0;
      const double bound = 8 * (L + b * log_ratio) * dist(s) + tau;
      INFO(label << ", " << walks[w].what << ", " << type_name<T>() << ", delta " << dist(s) << ": |f(v) - f(x)| = "
                 << jump(s) << ", bound " << bound << " (L = " << L << ", |b| = " << b << ", tau = " << tau << ")");
      CHECK(jump(s) <= bound);
    }
  }
}

/// Unit scene: four point handles and two segments, one stretched (x1.5) and one shrunk (x0.6) by the move,
/// on top of a rigid motion of everything and some noise on the points.
template <class T>
void scene_and_walks(std::mt19937_64& g, Handles<T>& rest, Handles<T>& moved, std::vector<Walk>& walks) {
  Handles<double> r;
  r.points.resize(4, 3);
  r.points << 0.9, 0.1, 0.2, -0.8, 0.3, -0.1, 0.1, -0.9, 0.4, 0.2, 0.5, -0.9;
  r.segment_a.resize(2, 3);
  r.segment_b.resize(2, 3);
  r.segment_a << -0.5, -0.4, 0.6, 0.4, 0.7, 0.5;
  r.segment_b << 0.3, -0.6, 0.7, 0.6, 0.8, -0.2;
  Handles<double> m = transformed(r, rotation_about(random_vector(g), 0.7), random_vector(g, -0.3, 0.3));
  for (Eigen::Index i = 0; i < 4; ++i) m.points.row(i) += 0.2 * random_vector(g).transpose();
  const double stretch[2] = {1.5, 0.6};
  for (Eigen::Index i = 0; i < 2; ++i) {
    const Vec3d c = m.segment_a.row(i).transpose(), d = m.segment_b.row(i).transpose(), mid = (c + d) / 2;
    m.segment_a.row(i) = (mid + stretch[i] * (c - mid)).transpose();
    m.segment_b.row(i) = (mid + stretch[i] * (d - mid)).transpose();
  }
  rest = {r.points.cast<T>(), r.segment_a.cast<T>(), r.segment_b.cast<T>()};
  moved = {m.points.cast<T>(), m.segment_a.cast<T>(), m.segment_b.cast<T>()};
  walks.clear();
  for (Eigen::Index i = 0; i < 4; ++i)
    walks.push_back({rest.points.row(i).transpose().template cast<double>(), random_vector(g).normalized(), "point"});
  for (Eigen::Index i = 0; i < 2; ++i) {
    const Vec3d a = rest.segment_a.row(i).transpose().template cast<double>();
    const Vec3d b = rest.segment_b.row(i).transpose().template cast<double>();
    const Vec3d axis = (b - a).normalized();
    Vec3d across = random_vector(g);
    across = (across - across.dot(axis) * axis).normalized();
    walks.push_back({a + 0.3 * (b - a), across, i == 0 ? "stretched segment, interior" : "shrunk segment, interior"});
    walks.push_back({a + 0.7 * (b - a), (across + 0.5 * axis).normalized(),
                     i == 0 ? "stretched segment, interior, oblique" : "shrunk segment, interior, oblique"});
    // Beyond the end b: the closest point of the segment is b itself.
    walks.push_back({b, (axis + across).normalized(), i == 0 ? "stretched segment, end" : "shrunk segment, end"});
  }
}

}  // namespace

TEMPLATE_TEST_CASE("the map is continuous at every handle", "[deformer][continuity]", float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  Handles<T> rest, moved;
  std::vector<Walk> walks;
  scene_and_walks(g, rest, moved, walks);
  for (Transform tr : all_transforms)
    for (SegmentWeight sw : {SegmentWeight::paper_constant, SegmentWeight::exact_integral})
      for (double u : {2.0, 3.0})
        for (const std::optional<Isa> be : {std::optional<Isa>(Isa::scalar), std::optional<Isa>()}) {
          Options o;
          o.transform = tr;
          o.segment_weight = sw;
          o.weight_exponent = u;
          o.isa = be;
          char label[160];
          std::snprintf(label, sizeof label, "%s, %s, u = %g, %s", name(tr),
                        sw == SegmentWeight::paper_constant ? "paper_constant" : "exact_integral", u,
                        be ? "scalar" : "simd");
          check_walks(rest, moved, walks, o, label);
        }
}

TEMPLATE_TEST_CASE("rigid paper_constant segments: a vertex on a stretched segment takes the rigid limit",
                   "[deformer][continuity]", float, double) {
  using T = TestType;
  // One segment (0,0,0)-(1,0,0) stretched onto (0,1,0)-(0,3,0) and far point handles: on the segment the map
  // is the rigid fit to the segment alone, q* + R (v - p*) with p*, q* the midpoints and R taking x to y, so
  // the end b = (1,0,0) lands at (0, 2.5, 0), not on the target end (0, 3, 0).
  Handles<T> rest, moved;
  rest.points.resize(2, 3);
  rest.points << 0, 0, 50, 0, 50, 0;
  rest.segment_a.resize(1, 3);
  rest.segment_b.resize(1, 3);
  rest.segment_a << 0, 0, 0;
  rest.segment_b << 1, 0, 0;
  moved = rest;
  moved.segment_a << 0, 1, 0;
  moved.segment_b << 0, 3, 0;
  Points<T> v(2, 3);
  v << 1, 0, 0, 0.25, 0, 0;
  Options o;
  o.method = RotationMethod::axis_angle;
  Points<T> out;
  Deformer<T>(v, rest, o).deform(moved, out);
  // The rank-1 fit gives R (1, 0, 0) = (0, 1, 0) to a few eps; the rest is the rounding of q* + R vhat.
  const T tol = 64 * std::numeric_limits<T>::epsilon() * 4;
  CHECK((out.row(0) - Eigen::Matrix<T, 1, 3>(0, 2.5, 0)).norm() <= tol);
  CHECK((out.row(1) - Eigen::Matrix<T, 1, 3>(0, 1.75, 0)).norm() <= tol);
}
