// Frames out of the deformer (FramesOut, mlsdeform/frames.hpp): positions bitwise those of deform() without
// frames on every ISA, weight source and output form; a rigid (similarity) motion of every handle gives that
// rotation (and scale) at every vertex to the fit's bound of tests/support/mls_reference.hpp; a region's
// frames are its own deformation's, the identity outside; bad outputs are refused before anything is written.
// The ARAP refinement's rotations: tests/test_frames_arap.cpp; the normal and tangent helpers:
// tests/test_frames_helpers.cpp.
#include "tests/support/accuracy_bounds.hpp"
#include "tests/support/deform_cases.hpp"
#include "tests/support/isa_guard.hpp"
#include "tests/support/meshes.hpp"
#include "tests/support/mls_reference.hpp"
#include "tests/support/random.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <cmath>
#include <cstring>
#include <numbers>
#include <random>
#include <set>
#include <vector>

using namespace mlsdeform;
using mlsdeform::testing::IsaGuard;

namespace {

/// Every output of a FramesOut for n vertices, filled with a sentinel (so that a row left unwritten shows).
template <class T>
struct AllFrames {
  std::vector<T> q, r, s, l;
  explicit AllFrames(Eigen::Index n)
      : q(4 * std::size_t(n), T(-7)),
        r(9 * std::size_t(n), T(-7)),
        s(std::size_t(n), T(-7)),
        l(9 * std::size_t(n), T(-7)) {}
  FramesOut<T> out() { return {q, r, s, l}; }
};

template <class T>
bool bitwise_equal(const T* a, const T* b, std::size_t count) {
  return std::memcmp(a, b, count * sizeof(T)) == 0;
}

/// x -> s R0 x + t applied to every handle (in double, rounded once to T).
template <class T>
Handles<T> moved_by(const Handles<T>& rest, double s, const Eigen::Matrix3d& R0, const Eigen::Vector3d& t) {
  return testing::transformed(rest, s * R0, t);
}

/// The distance between unit quaternions as rotations: q and -q are one rotation (near 180 degrees w is
/// near 0 and either sign is the exact one's).
double quaternion_distance(const double* q, const Eigen::Vector4d& q0) {
  const Eigen::Vector4d a(q[0], q[1], q[2], q[3]);
  return std::min((a - q0).norm(), (a + q0).norm());
}

}  // namespace

TEMPLATE_TEST_CASE("frames: the positions are bitwise those of deform() without frames, any thread count", "[frames]",
                   float, double) {
  using T = TestType;
  const IsaGuard guard;
  std::mt19937_64 g(11);
  // 203 vertices: a partial last block; 7 point handles (and segments where the table allows them).
  const testing::DeformCase<T> c = testing::twisted_cube_case<T>(203, 7, 0, false, 1.2, 0.1, 3);
  const testing::DeformCase<T> cs = testing::twisted_cube_case<T>(203, 5, 2, false, 1.2, 0.1, 4);
  for (Isa isa : supported_isas())
    for (const testing::DeformCase<T>* k : {&c, &cs})
      for (WeightStorage ws : {WeightStorage::precomputed, WeightStorage::on_the_fly})
        for (Transform tr : {Transform::rigid, Transform::similarity}) {
          if (ws == WeightStorage::on_the_fly && k->rest.segment_count() > 0) continue;
          INFO("isa " << to_string(isa) << " storage " << int(ws) << " transform " << int(tr) << " segments "
                      << k->rest.segment_count());
          Options o;
          o.isa = isa;
          o.weight_storage = ws;
          o.transform = tr;
          Deformer<T> d(k->vertices, k->rest, o);
          Points<T> plain, with;
          d.deform(k->moved, plain);
          AllFrames<T> f(d.vertex_count());
          d.deform(k->moved, with, f.out());
          CHECK(bitwise_equal(plain.data(), with.data(), std::size_t(plain.size())));
          // Each output alone gives the same bits as all four together.
          AllFrames<T> one(d.vertex_count());
          d.deform(k->moved, with, FramesOut<T>{one.q, {}, {}, {}});
          d.deform(k->moved, with, FramesOut<T>{{}, one.r, {}, {}});
          d.deform(k->moved, with, FramesOut<T>{{}, {}, one.s, {}});
          d.deform(k->moved, with, FramesOut<T>{{}, {}, {}, one.l});
          CHECK((one.q == f.q && one.r == f.r && one.s == f.s && one.l == f.l));
          // The interleaved output and the stateful targets.
          PointsRowMajor<T> buffer(d.vertex_count(), 3);
          AllFrames<T> f2(d.vertex_count());
          d.deform(k->moved, InterleavedView<T>(buffer.data(), buffer.rows(), 3), f2.out());
          CHECK(Points<T>(buffer) == plain);
          CHECK((f2.q == f.q && f2.r == f.r && f2.s == f.s && f2.l == f.l));
          for (Eigen::Index i = 0; i < k->moved.point_count(); ++i)
            d.set_point_target(i, k->moved.points.row(i).transpose());
          for (Eigen::Index i = 0; i < k->moved.segment_count(); ++i)
            d.set_segment_target(i, k->moved.segment_a.row(i).transpose(), k->moved.segment_b.row(i).transpose());
          AllFrames<T> f3(d.vertex_count());
          d.deform(with, f3.out());
          CHECK(with == plain);
          CHECK((f3.q == f.q && f3.l == f.l));
          // One thread gives the same bits as all of them.
          Options o1 = o;
          o1.threads = 1;
          AllFrames<T> f1(d.vertex_count());
          Deformer<T>(k->vertices, k->rest, o1).deform(k->moved, with, f1.out());
          CHECK((f1.q == f.q && f1.r == f.r && f1.s == f.s && f1.l == f.l));
          // Rigid: scale 1 and linear = R exactly (mu = 1 multiplies nothing).
          if (tr == Transform::rigid) {
            CHECK(std::all_of(f.s.begin(), f.s.end(), [](T s) { return s == T(1); }));
            CHECK(f.l == f.r);
          }
        }
}

TEMPLATE_TEST_CASE("frames: a rigid or similarity motion of every handle gives that rotation and scale", "[frames]",
                   float, double) {
  using T = TestType;
  const IsaGuard guard;
  std::mt19937_64 g(5);
  const testing::DeformCase<T> c = testing::random_case<T>(g, 301, 9);
  const double pi = std::numbers::pi;
  const double eps = std::numeric_limits<T>::epsilon();
  const double l = testing::scene_size(c.vertices, c.rest);
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -1, 0.6).normalized(), shift(0.4, -0.2, 0.9);
  for (Isa isa : supported_isas())
    for (WeightStorage ws : {WeightStorage::precomputed, WeightStorage::on_the_fly})
      for (Transform tr : {Transform::rigid, Transform::similarity})
        for (double angle : {0.0, 0.3, 2.0, pi - 1e-3, pi}) {
          const double s = tr == Transform::similarity ? 1.7 : 1.0;
          INFO("isa " << to_string(isa) << " storage " << int(ws) << " transform " << int(tr) << " angle " << angle);
          const Eigen::Matrix3d R0 = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
          // The exact quaternion, from the axis and angle (independent of any matrix-to-quaternion formula).
          const Eigen::Vector4d q0(std::cos(angle / 2), std::sin(angle / 2) * axis.x(), std::sin(angle / 2) * axis.y(),
                                   std::sin(angle / 2) * axis.z());
          Options o;
          o.isa = isa;
          o.weight_storage = ws;
          o.transform = tr;
          const Handles<T> moved = moved_by(c.rest, s, R0, shift);
          Deformer<T> d(c.vertices, c.rest, o);
          Points<T> out;
          AllFrames<T> f(d.vertex_count());
          d.deform(moved, out, f.out());
          Eigen::Index checked = 0, failures = 0;
          double worst = 0;
          for (Eigen::Index i = 0; i < c.vertices.rows(); ++i) {
            const Eigen::Vector3d v = c.vertices.row(i).template cast<double>().transpose();
            const testing::DirectVertex dv = testing::direct_vertex(v, c.rest, moved, o, l);
            if (dv.snapped || !dv.well_posed) continue;
            ++checked;
            // The fit's bound (mls_reference.hpp): |dR|_F <= 2 (|dH|_F + 16 eps |H|_F) / gap, |dH|_F <=
            // dH_unit eps (it counts the targets' rounding to T), plus R's departure from orthonormality
            // (1.5 c_o eps, accuracy_bounds.hpp: |R - nearest rotation|_F). The quaternion of a rotation
            // moved by dR moves by |dR|_F / (2 sqrt(2) cos(theta / 4)) <= |dR|_F / 2; normalising the
            // Shepperd column of a non-orthonormal R adds at most its departure again and ~10 eps of
            // rounding (stages.hpp, rotation_quaternion).
            const double orth = 1.5 * double(testing::c_o) * eps;
            const double tol_R = 2 * (dv.dH_unit + 16 * dv.norm_H) * eps / dv.gap + orth;
            const double tol_q = tol_R / 2 + orth + 10 * eps;
            // mu (Sec. 6.1): |dmu| <= mu (J + 16) eps + (sqrt(3) |dH|_F + 16 eps |H|_F) / D.
            const double tol_mu = tr == Transform::similarity
                                      ? (dv.mu * (9 + 16) + (std::sqrt(3.0) * dv.dH_unit + 16 * dv.norm_H) / dv.D) * eps
                                      : 0.0;
            Eigen::Matrix3d R, L;
            for (int k = 0; k < 9; ++k) {
              R(k / 3, k % 3) = double(f.r[9 * std::size_t(i) + std::size_t(k)]);
              L(k / 3, k % 3) = double(f.l[9 * std::size_t(i) + std::size_t(k)]);
            }
            double q[4];
            for (int k = 0; k < 4; ++k) q[k] = double(f.q[4 * std::size_t(i) + std::size_t(k)]);
            const double dR = (R - R0).norm(), dq = quaternion_distance(q, q0);
            const double dmu = std::abs(double(f.s[std::size_t(i)]) - s);
            // L = mu R: |L - s R0|_F <= s |dR|_F + |dmu| sqrt(3) + rounding of the product (sqrt(3) s eps).
            const double dL = (L - s * R0).norm(), tol_L = s * tol_R + std::sqrt(3.0) * (tol_mu + s * eps);
            worst = std::max({worst, dR / tol_R, dq / tol_q});
            const bool ok = dR <= tol_R && dq <= tol_q && q[0] >= 0 && dmu <= tol_mu && dL <= tol_L &&
                            std::abs(Eigen::Vector4d(q[0], q[1], q[2], q[3]).norm() - 1) <= 4 * eps;
            if (!ok) {
              ++failures;
              if (failures <= 3)
                UNSCOPED_INFO("vertex " << i << " dR " << dR << " / " << tol_R << " dq " << dq << " / " << tol_q
                                        << " dmu " << dmu << " / " << tol_mu << " dL " << dL << " / " << tol_L);
            }
          }
          INFO("checked " << checked << " worst deviation / bound " << worst);
          CHECK(failures == 0);
          CHECK(checked >= c.vertices.rows() * 9 / 10);
        }
}

TEMPLATE_TEST_CASE("frames: a vertex on a point handle takes the fit's limit rotation (precomputed weights)",
                   "[frames]", float, double) {
  using T = TestType;
  const IsaGuard guard;
  std::mt19937_64 g(8);
  testing::DeformCase<T> c = testing::random_case<T>(g, 120, 9);
  const Eigen::Index k = c.rest.point_count();
  for (Eigen::Index j = 0; j < k; ++j) c.vertices.row(j) = c.rest.points.row(j);  // vertex j on handle j
  const double eps = std::numeric_limits<T>::epsilon(), orth = 1.5 * double(testing::c_o) * eps;
  const Eigen::Vector3d axis = Eigen::Vector3d(-0.5, 0.2, 1).normalized(), shift(0.3, 0.1, -0.7);
  for (Isa isa : supported_isas())
    for (Transform tr : {Transform::rigid, Transform::similarity})
      for (double angle : {1.0, std::numbers::pi}) {
        INFO("isa " << to_string(isa) << " transform " << int(tr) << " angle " << angle);
        const double s = tr == Transform::similarity ? 0.6 : 1.0;
        const Eigen::Matrix3d R0 = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
        Options o;
        o.isa = isa;
        o.transform = tr;
        o.weight_storage = WeightStorage::precomputed;
        const Handles<T> moved = moved_by(c.rest, s, R0, shift);
        const Deformer<T> d(c.vertices, c.rest, o);
        Points<T> out, plain;
        AllFrames<T> f(d.vertex_count());
        d.deform(moved, out, f.out());
        d.deform(moved, plain);
        CHECK(out == plain);
        for (Eigen::Index n = 0; n < k; ++n) {
          CHECK(out.row(n) == moved.points.row(n));  // interpolated, as without frames
          // The limit's H = s R0 C, C = sum_{j != n} w_j (p_j - p_n)(p_j - p_n)^T, w_j = |p_j - p_n|^-2 (any
          // positive factor: the fit is scale-invariant), in long double; its gap s2 + s3 is C's. The table
          // rounds each A_j = w_j (p_j - p_n) to T and the kernel sums H over J terms: |dH|_F <= (J + 16) eps
          // sum_j |A_j| (|q_j - c| + |q_j|) <= (J + 16) eps 2 sum_{j != n} |A_j| 3 max |q_j| (A_n = -sum of the
          // others, |c| <= max |q_j|); then the fit's bound as in the rigid-motion case above.
          using LD = long double;
          Eigen::Matrix<LD, 3, 3> C = Eigen::Matrix<LD, 3, 3>::Zero();
          LD a_sum = 0, q_max = 0;
          for (Eigen::Index j = 0; j < k; ++j) {
            q_max = std::max(q_max, LD(moved.points.row(j).template cast<double>().norm()));
            if (j == n) continue;
            const Eigen::Matrix<LD, 3, 1> p =
                (c.rest.points.row(j) - c.rest.points.row(n)).transpose().template cast<LD>();
            C += p * p.transpose() / p.squaredNorm();
            a_sum += 1 / p.norm();
          }
          const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<LD, 3, 3>> es(C);
          const double gap = double(s * (es.eigenvalues()(0) + es.eigenvalues()(1)));
          const double dH = double((k + 16) * 6 * a_sum * q_max) * eps, H = double(s * C.norm());
          const double tol_R = 2 * (dH + 16 * eps * H) / gap + orth;
          Eigen::Matrix3d R;
          for (int e = 0; e < 9; ++e) R(e / 3, e % 3) = double(f.r[9 * std::size_t(n) + std::size_t(e)]);
          INFO("vertex " << n << " |R - R0| " << (R - R0).norm() << " bound " << tol_R);
          CHECK((R - R0).norm() <= tol_R);
          // Its scale (the limit's, s), and the other storages: tests/test_frames_near_handles.cpp.
        }
      }
}

TEMPLATE_TEST_CASE("frames: a region's frames are its own deformation's, the identity outside", "[frames][region]",
                   float, double) {
  using T = TestType;
  const Points<T> v = testing::human().v.cast<T>();
  const Triangles& faces = testing::human().f;
  constexpr Eigen::Index kRightHand = 2445;  // data/human_bend.json
  std::vector<Eigen::Index> region;
  for (Eigen::Index i = 0; i < v.rows(); ++i)
    if ((v.row(i) - v.row(kRightHand)).norm() < T(0.3)) region.push_back(i);
  // The ring as documented (Options::region): outside vertices sharing a triangle with a region vertex.
  std::vector<char> in(std::size_t(v.rows()), 0);
  for (Eigen::Index i : region) in[std::size_t(i)] = 1;
  std::set<Eigen::Index> ring;
  for (Eigen::Index t = 0; t < faces.rows(); ++t)
    if (in[std::size_t(faces(t, 0))] || in[std::size_t(faces(t, 1))] || in[std::size_t(faces(t, 2))])
      for (int k = 0; k < 3; ++k)
        if (!in[std::size_t(faces(t, k))]) ring.insert(faces(t, k));
  REQUIRE(region.size() > 100);
  Handles<T> rest, moved;
  rest.points = v.row(kRightHand);
  moved = rest;
  moved.points.row(0) += Eigen::Matrix<T, 1, 3>(T(0.05), T(0.15), T(0.1));
  // The same deformation by hand (tests/test_deformer_region.cpp): the region's vertices alone, the caller's
  // handle then the ring's rest positions as fixed handles; with on-the-fly weights the same bits.
  Points<T> compact(Eigen::Index(region.size()), 3);
  for (std::size_t r = 0; r < region.size(); ++r) compact.row(Eigen::Index(r)) = v.row(region[r]);
  Handles<T> rest_aug;
  rest_aug.points.resize(1 + Eigen::Index(ring.size()), 3);
  rest_aug.points.row(0) = rest.points.row(0);
  Eigen::Index q = 1;
  for (Eigen::Index i : ring) rest_aug.points.row(q++) = v.row(i);
  Handles<T> moved_aug = rest_aug;
  moved_aug.points.row(0) = moved.points.row(0);
  for (Transform tr : {Transform::rigid, Transform::similarity}) {
    Options o;
    o.transform = tr;
    o.weight_storage = WeightStorage::on_the_fly;
    Options o_region = o;
    o_region.region = region;
    std::shuffle(o_region.region.begin(), o_region.region.end(), std::mt19937(7));  // any order
    const Deformer<T> d(v, faces, rest, o_region);
    Points<T> out, expected;
    AllFrames<T> f(v.rows()), by_hand_f(Eigen::Index(region.size()));
    d.deform(moved, out, f.out());
    const Deformer<T> by_hand(compact, rest_aug, o);
    by_hand.deform(moved_aug, expected, by_hand_f.out());
    const T identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, unit_q[4] = {1, 0, 0, 0};
    Eigen::Index inside_differ = 0, outside_not_identity = 0;
    std::vector<char> seen(std::size_t(v.rows()), 0);
    for (std::size_t r = 0; r < region.size(); ++r) {
      const auto i = std::size_t(region[r]);
      seen[i] = 1;
      if (!bitwise_equal(&f.q[4 * i], &by_hand_f.q[4 * r], 4) || !bitwise_equal(&f.r[9 * i], &by_hand_f.r[9 * r], 9) ||
          !bitwise_equal(&f.s[i], &by_hand_f.s[r], 1) || !bitwise_equal(&f.l[9 * i], &by_hand_f.l[9 * r], 9))
        ++inside_differ;
    }
    for (std::size_t i = 0; i < seen.size(); ++i)
      if (!seen[i] && (!bitwise_equal(&f.q[4 * i], unit_q, 4) || !bitwise_equal(&f.r[9 * i], identity, 9) ||
                       f.s[i] != T(1) || !bitwise_equal(&f.l[9 * i], identity, 9)))
        ++outside_not_identity;
    CHECK(inside_differ == 0);
    CHECK(outside_not_identity == 0);
  }
}

TEMPLATE_TEST_CASE("frames: bad outputs are refused before anything is written", "[frames][errors]", float, double) {
  using T = TestType;
  std::mt19937_64 g(2);
  const testing::DeformCase<T> c = testing::random_case<T>(g, 50, 5);
  Handles<T> moved = c.rest;
  moved.points(0, 0) += T(0.3);
  const Deformer<T> d(c.vertices, c.rest);
  AllFrames<T> f(d.vertex_count());
  std::vector<T> short_q(4 * 49, T(-7));
  Points<T> out = Points<T>::Constant(50, 3, T(-7));
  const auto untouched = [&] {
    return (out.array() == T(-7)).all() && std::all_of(f.r.begin(), f.r.end(), [](T x) { return x == T(-7); });
  };
  CHECK_THROWS_WITH(
      d.deform(moved, out, FramesOut<T>{short_q, f.r, {}, {}}),
      Catch::Matchers::ContainsSubstring("frames.quaternions") && Catch::Matchers::ContainsSubstring("200"));
  CHECK(untouched());
  std::vector<T> long_s(51);
  CHECK_THROWS_WITH(d.deform(moved, out, FramesOut<T>{{}, f.r, long_s, {}}),
                    Catch::Matchers::ContainsSubstring("frames.scales"));
  CHECK(untouched());
  Options affine;
  affine.transform = Transform::affine;
  affine.affine_frames = true;  // linear's table: the other outputs stay refused even so
  const Deformer<T> da(c.vertices, c.rest, affine);
  for (int k = 0; k < 3; ++k) {  // linear is the affine fit's matrix: tests/test_frames_affine.cpp
    FramesOut<T> one;
    (k == 0   ? one.quaternions
     : k == 1 ? one.rotations
     : k == 2 ? one.scales
              : one.linear) = k == 0   ? std::span<T>(f.q)
                              : k == 1 ? std::span<T>(f.r)
                              : k == 2 ? std::span<T>(f.s)
                                       : std::span<T>(f.l);
    CHECK_THROWS_WITH(da.deform(moved, out, one), Catch::Matchers::ContainsSubstring("Transform::affine"));
    CHECK(untouched());
  }
}
