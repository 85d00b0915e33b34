// Segment handles in the deformer (paper Sec. 6.2): the paper's constant-weight formulas against the direct
// evaluation, and the exact integral against the same segments densely sampled as point handles. The weight
// moments themselves are tested in test_deformer_segment_moments.cpp.
#include "tests/test_deformer_common.hpp"

#include "core/src/deformer/weights.hpp"
#include "kernels/contract.hpp"

#include <iostream>

using namespace deformer_test;

namespace {
// Vertices of the first test's cases and of the segment scene. The direct evaluation (mls_reference.cpp) costs
// O(J^2) per vertex, J the pseudo-handles: 516 in the first test, up to 3 x 256 sampled points in the second.
// Fewer under AddressSanitizer (the sanitizer build of tools/dev.sh) and under an emulator (a cross build's ctest,
// MLSDEFORM_TEST_EMULATED: 17-36x slower than natively, a minute per precision and test with 300 vertices):
// every check is per vertex, so fewer vertices check the same bounds on a smaller sample.
#if defined(MLSDEFORM_TEST_EMULATED)
constexpr int kCaseVertices = 75, kArmVertices = 40;
#elif defined(__SANITIZE_ADDRESS__)
constexpr int kCaseVertices = 300, kArmVertices = 40;
#else
constexpr int kCaseVertices = 300, kArmVertices = 150;
#endif
}  // namespace

TEMPLATE_TEST_CASE("paper_constant segments agree with the paper's W_i and midpoint centroids (direct evaluation)",
                   "[deformer][segment]", float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  for (Transform tr : all_transforms) {
    // 510 points and 3 segments: 516 pseudo-handles, more than a frame computes once (kCachedTargets), so each
    // batch forms its targets itself (kernels/contract.hpp, for_each_target).
    static_assert(510 + 2 * 3 > mlsdeform::kernels::kCachedTargets);
    for (Eigen::Index k : {0, 3, 510}) {
      INFO(name(tr) << ", " << k << " point handles");
      const DeformCase<T> sc = random_case<T>(g, kCaseVertices, k, 3);
      Options o;
      o.transform = tr;
      o.segment_weight = SegmentWeight::paper_constant;
      const Handles<T> moved =
          transformed(sc.rest, random_rotation(g) * (Mat3d::Identity() + 0.3 * Mat3d(random_vector(g).asDiagonal())),
                      random_vector(g));
      Points<T> out;
      Deformer<T>(sc.vertices, sc.rest, o).deform(moved, out);
      const Comparison c = compare_with_direct(out, sc.vertices, sc.rest, moved, o);
      INFO("max deviation " << c.max_dev << ", max deviation / bound " << c.max_ratio << ", ill-posed " << c.ill_posed);
      CHECK(c.failures == 0);
      CHECK(c.ill_posed == 0);
    }
  }
}

namespace {

/// Three disjoint, non-coplanar segments and a moved pose (a rotation, a stretch and a bend of each end).
struct SegmentScene {
  Handles<double> rest, moved;
  Points<double> vertices;
};

SegmentScene segment_scene(std::mt19937_64& g) {
  SegmentScene s;
  s.rest.segment_a.resize(3, 3);
  s.rest.segment_b.resize(3, 3);
  s.rest.segment_a << -1, 0, 0, 0, -1, 0.3, 0.2, 0.1, -1;
  s.rest.segment_b << 1, 0.1, 0, 0.1, 1, 0.2, 0.1, 0.2, 1;
  const Mat3d R = random_rotation(g);
  auto move = [&](const Points<double>& p) {
    Points<double> q(p.rows(), 3);
    for (Eigen::Index i = 0; i < p.rows(); ++i)
      q.row(i) = (1.2 * R * p.row(i).transpose() + 0.3 * random_vector(g)).transpose();
    return q;
  };
  s.moved.segment_a = move(s.rest.segment_a);
  s.moved.segment_b = move(s.rest.segment_b);
  // Vertices at least half a segment length (>= 1) from every segment: the sampling error estimate below
  // assumes the weight varies on the scale of that distance.
  std::vector<Vec3d> v;
  while (v.size() < kArmVertices) {
    const Vec3d x = random_vector(g, -2.5, 2.5);
    bool ok = true;
    for (int i = 0; i < 3; ++i)
      ok = ok &&
           detail::segment_geometry(x, s.rest.segment_a.row(i).transpose(), s.rest.segment_b.row(i).transpose()).d >=
               1.0;
    if (ok) v.push_back(x);
  }
  s.vertices.resize(kArmVertices, 3);
  for (int i = 0; i < kArmVertices; ++i) s.vertices.row(i) = v[i].transpose();
  return s;
}

/// The segments sampled at the midpoints t_k = (k + 1/2) / N as point handles (rest and moved), from the end
/// points rounded to E (as the segment deformer in precision E sees them), in precision T.
template <class T, class E>
std::pair<Handles<T>, Handles<T>> sampled(const SegmentScene& s, int N) {
  Handles<T> r, m;
  r.points.resize(3 * N, 3);
  m.points.resize(3 * N, 3);
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < N; ++k) {
      const double t = (k + 0.5) / N;
      auto at = [&](const Points<double>& a, const Points<double>& b) {
        const Vec3d pa(rounded_to<E>(a(i, 0)), rounded_to<E>(a(i, 1)), rounded_to<E>(a(i, 2)));
        const Vec3d pb(rounded_to<E>(b(i, 0)), rounded_to<E>(b(i, 1)), rounded_to<E>(b(i, 2)));
        return Vec3d((1 - t) * pa + t * pb);
      };
      r.points.row(i * N + k) = at(s.rest.segment_a, s.rest.segment_b).template cast<T>().transpose();
      m.points.row(i * N + k) = at(s.moved.segment_a, s.moved.segment_b).template cast<T>().transpose();
    }
  return {r, m};
}

template <class T, class S>
Handles<T> cast(const Handles<S>& h) {
  return {h.points.template cast<T>(), h.segment_a.template cast<T>(), h.segment_b.template cast<T>()};
}

}  // namespace

TEMPLATE_TEST_CASE("exact_integral segments agree with the segments densely sampled as point handles",
                   "[deformer][segment]", float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  const SegmentScene s = segment_scene(g);
  const Points<T> vertices = s.vertices.cast<T>();
  const Points<double> vertices_d = rounded_points<T>(s.vertices);
  const Handles<T> rest = cast<T>(s.rest), moved = cast<T>(s.moved);
  const auto rounded = [](const Handles<double>& h) {
    return Handles<double>{rounded_points<T>(h.points), rounded_points<T>(h.segment_a), rounded_points<T>(h.segment_b)};
  };
  const Handles<double> rest_d = rounded(s.rest), moved_d = rounded(s.moved);
  constexpr int N = 64;
  const double eps_d = std::numeric_limits<double>::epsilon(), eps_t = std::numeric_limits<T>::epsilon();
  for (Transform tr : all_transforms)
    for (double u : {2.0, 3.0}) {
      INFO(name(tr) << " u " << u);
      Options o;
      o.transform = tr;
      o.weight_exponent = u;
      o.segment_weight = SegmentWeight::exact_integral;
      // The N-point midpoint rule replaces every integral of Sec. 6.2 by (1/N) sum_k f(t_k), and the 1/N
      // cancels in the normalised weights: the sampled deformer is the segment deformer with midpoint-rule
      // moments. Euler-Maclaurin: error(N) = -(1/24N^2)[f']_0^1 + (7/5760N^4)[f''']_0^1 - ..., so the output
      // difference e(N) = sampled(N) - exact is a/N^2 + b/N^4 + O(N^-6), and the Richardson residual
      // r(N) = e(2N) - e(N)/4 = -3b/(16N^4) + O(N^-6). If the segment deformer's limit were off by delta,
      // r(N) would tend to -3 delta/4 instead of 0. Two checks:
      //  (1) r decays like N^-4: max_v |r(2N)| <= 1.25 max_v |r(N)| / 16 (the N^-6 term is <= ~1e-3 of the
      //      N^-4 one here, see (2); the 25% also covers the rounding floor);
      //  (2) r is as small as the N^-4 term can be: with f ~ dist^-u and dist >= L/2 (L <= 2 the segment
      //      length), |f'''/f'| <= (u+1)(u+2)(L/dist)^2, so per integral the N^-4 term is at most
      //      (7/240)(u+1)(u+2) 4/N^2 = 5.7e-4 (u = 3, N = 64) of the N^-2 one. A vertex mixes several
      //      integrals whose N^-2 terms may cancel (its own |e(N)| can be small), so we measure against the
      //      largest error, max_v |e(N)|: |r_v(N)| <= 0.01 max_v |e(N)| + rounding (17x margin; the output's
      //      nonlinearity in the moments adds O(max |e(N)| / size) relative, ~1e-4).
      //  Rounding: the bound of test_deformer_common.hpp for the sampled runs (J = 3N handles), which also
      //  covers the segment run (same weights in the limit, J = 6).
      Points<double> seg_d, pts_d[3];
      Deformer<double>(vertices_d, rest_d, o).deform(moved_d, seg_d);
      std::vector<double> bound_pts[3];
      for (int r = 0; r < 3; ++r) {
        const auto [rp, mp] = sampled<double, T>(s, N << r);
        Deformer<double>(vertices_d, rp, o).deform(mp, pts_d[r]);
        for (int i = 0; i < kArmVertices; ++i)
          bound_pts[r].push_back(
              direct_vertex(vertices_d.row(i).transpose().eval(), rp, mp, o, scene_size(vertices_d, rp)).bound_unit);
      }
      const Points<double> e0 = pts_d[0] - seg_d, e1 = pts_d[1] - seg_d, e2 = pts_d[2] - seg_d;
      const Points<double> r0 = e1 - e0 / 4, r1 = e2 - e1 / 4;
      const double max_e0 = e0.rowwise().norm().maxCoeff();
      double max_r0 = 0, max_r1 = 0, max_rounding = 0;
      for (int i = 0; i < kArmVertices; ++i) {
        const double rounding = 2 * eps_d * (bound_pts[0][i] + bound_pts[1][i] + bound_pts[2][i]);
        INFO("vertex " << i << " |e(N)| " << e0.row(i).norm() << " |e(2N)| " << e1.row(i).norm() << " |r(N)| "
                       << r0.row(i).norm() << " |r(2N)| " << r1.row(i).norm());
        CHECK(r0.row(i).norm() <= 0.01 * max_e0 + rounding);
        max_r0 = std::max(max_r0, r0.row(i).norm());
        max_r1 = std::max(max_r1, r1.row(i).norm());
        max_rounding = std::max(max_rounding, rounding);
      }
      CHECK(max_r1 <= 1.25 * max_r0 / 16 + max_rounding);
      std::cout << "[segment sampling] " << type_name<T>() << " " << name(tr) << " u=" << u
                << ": max |e(N)| for N = " << N << ", " << 2 * N << ", " << 4 * N << ": " << max_e0 << ", "
                << e1.rowwise().norm().maxCoeff() << ", " << e2.rowwise().norm().maxCoeff()
                << "; max Richardson residual " << max_r0 << " -> " << max_r1 << " (ratio " << max_r0 / max_r1
                << ", 16 expected)\n";
      if constexpr (sizeof(T) == 4) {
        // In float: the segment deformer and the sampled one (4N) are each within their rounding bound of
        // their double counterparts, which differ by e(4N).
        const auto [rp, mp] = sampled<T, T>(s, 4 * N);
        Points<T> seg_t, pts_t;
        Deformer<T>(vertices, rest, o).deform(moved, seg_t);
        Deformer<T>(vertices, rp, o).deform(mp, pts_t);
        for (int i = 0; i < kArmVertices; ++i) {
          const double tol = e2.row(i).norm() + 2 * (eps_t + eps_d) * bound_pts[2][i];
          CHECK((seg_t.row(i) - pts_t.row(i)).template cast<double>().norm() <= tol);
        }
      }
    }
}

TEMPLATE_TEST_CASE("exact_integral differs from paper_constant, and segments interpolate where the map's limit does",
                   "[deformer][segment]", float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  const SegmentScene s = segment_scene(g);
  const Handles<T> rest = cast<T>(s.rest), moved = cast<T>(s.moved);
  Points<T> vertices = s.vertices.cast<T>();
  // A vertex on the interior of segment 0 (t = 1/4) maps to (3/4) c + (1/4) d with exact_integral weights,
  // and with paper_constant ones for similarity and affine; rigid paper_constant takes the rigid fit to the
  // segment alone there (deformer/data.hpp), which interpolates only if the move keeps the segment's length.
  vertices.row(0) = T(0.75) * rest.segment_a.row(0) + T(0.25) * rest.segment_b.row(0);
  for (Transform tr : all_transforms) {
    Points<T> a, b;
    Options o;
    o.transform = tr;
    o.segment_weight = SegmentWeight::paper_constant;
    Deformer<T>(vertices, rest, o).deform(moved, a);
    o.segment_weight = SegmentWeight::exact_integral;
    Deformer<T>(vertices, rest, o).deform(moved, b);
    const Vector3<T> target =
        T(0.75) * moved.segment_a.row(0).transpose() + T(0.25) * moved.segment_b.row(0).transpose();
    // t is the closest-point parameter of the rounded vertex: a few eps of the coordinates (|x| <= 3); the
    // paper_constant limit adds the rank-1 fit (16 eps |vhat|, |vhat| <= 3) and the rounding of q* + mu R vhat.
    const T tol = 16 * std::numeric_limits<T>::epsilon() * 3;
    if (tr != Transform::rigid) CHECK((a.row(0).transpose() - target).norm() <= 3 * tol);
    CHECK((b.row(0).transpose() - target).norm() <= tol);
    CHECK((a - b).rowwise().norm().maxCoeff() > T(1e-3));  // different weights, visibly different shapes
  }
}

TEST_CASE("paper_constant vs exact_integral: the numbers quoted in docs/api.md", "[deformer][segment]") {
  // One unit segment a = (0,0,0) -> b = (1,0,0) and a vertex at (0.1, 0.1, 0), u = 2: the segment's weight
  // and the centroid parameter of its weight (where p* and q* put it).
  const detail::SegmentGeometry g = detail::segment_geometry(Vec3d(0.1, 0.1, 0), Vec3d::Zero(), Vec3d::UnitX());
  const double dm2 = 1 / (g.d * g.d);
  const detail::SegmentMoments pc = detail::segment_moments_constant(g, g.d, 2),
                               ex = detail::segment_moments_exact(g, g.d, 2);
  const double w_pc = pc.I0 + 2 * pc.I1 + pc.I2, w_ex = ex.I0 + 2 * ex.I1 + ex.I2;
  // Closed form: int_0^1 dt / (h^2 + (t - 0.1)^2) = (atan(9) + atan(1)) / h with h = 0.1.
  CHECK(std::abs(w_ex * dm2 - (std::atan(9.0) + std::atan(1.0)) / 0.1) <= 1e-13 * w_ex * dm2);
  std::printf(
      "[segment example] vertex (0.1, 0.1, 0), segment (0,0,0)-(1,0,0), u = 2: weight %.4g (paper) vs %.4g "
      "(exact), centroid at t = %.4g (paper) vs %.4g (exact)\n",
      w_pc * dm2, w_ex * dm2, (pc.I1 + pc.I2) / w_pc, (ex.I1 + ex.I2) / w_ex);

  // A two-bone arm: vertices on a cylinder of radius 0.15 around x in [0, 2], bones [0, 1] and [1, 2] and a
  // "hand" bone (2, 0, 0) -> (2, 0.3, 0) as segments (the hand makes the handles span a plane, so that every
  // vertex's rotation is unique: with collinear handles the turn about their line is arbitrary); the forearm
  // and the hand turn 90 degrees about z at the elbow (1, 0, 0).
  Points<double> v(41 * 24, 3);
  for (int i = 0; i <= 40; ++i)
    for (int k = 0; k < 24; ++k) {
      const double phi = 2 * M_PI * k / 24;
      v.row(i * 24 + k) << 0.05 * i, 0.15 * std::cos(phi), 0.15 * std::sin(phi);
    }
  Handles<double> rest, moved;
  rest.segment_a.resize(3, 3);
  rest.segment_b.resize(3, 3);
  rest.segment_a << 0, 0, 0, 1, 0, 0, 2, 0, 0;
  rest.segment_b << 1, 0, 0, 2, 0, 0, 2, 0.3, 0;
  moved = rest;
  moved.segment_b.row(1) << 1, 1, 0;
  moved.segment_a.row(2) << 1, 1, 0;
  moved.segment_b.row(2) << 0.7, 1, 0;
  const Mat3d Rz = rotation_about(Vec3d::UnitZ(), M_PI / 2);
  Points<double> out[2];
  const SegmentWeight kinds[2] = {SegmentWeight::paper_constant, SegmentWeight::exact_integral};
  double upper[2] = {0, 0}, fore[2] = {0, 0};
  for (int m = 0; m < 2; ++m) {
    Options o;
    o.segment_weight = kinds[m];
    o.method = RotationMethod::svd;  // any method: the rotations are unique here
    Deformer<double>(v, rest, o).deform(moved, out[m]);
    REQUIRE(out[m].allFinite());
    // Ideal: the upper arm (x <= 0.5) stays, the far forearm (x >= 1.5) turns rigidly with its bone.
    for (Eigen::Index i = 0; i < v.rows(); ++i) {
      const Vec3d p = v.row(i).transpose(), q = out[m].row(i).transpose();
      if (p.x() <= 0.5) upper[m] = std::max(upper[m], (q - p).norm());
      if (p.x() >= 1.5) fore[m] = std::max(fore[m], (q - (Vec3d(1, 0, 0) + Rz * (p - Vec3d(1, 0, 0)))).norm());
    }
  }
  const double diff = (out[0] - out[1]).rowwise().norm().maxCoeff();
  std::printf(
      "[segment example] two-bone arm with a hand (length 2, radius 0.15), forearm bent 90 degrees, rigid, "
      "u = 2: "
      "max |paper - exact| = %.3g; largest deviation from the ideal: upper arm %.3g (paper) vs %.3g (exact), "
      "far forearm %.3g (paper) vs %.3g (exact)\n",
      diff, upper[0], upper[1], fore[0], fore[1]);
  CHECK(diff > 0);
}
