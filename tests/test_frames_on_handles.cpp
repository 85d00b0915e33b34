// Frames on handles (core/src/deformer/near_handles.hpp): a rigid, similarity or affine motion of every handle gives
// that transform's frame at vertices on point handles in every weight storage, and on segment handles (ends and
// interior) with either segment weight, in float and double, on every ISA. The oracle is the motion itself; the
// tolerances are the fit's bound with the conditioning of each vertex's own limit, computed in long double from the
// rest geometry (tests/support/limit_reference.hpp). Near handles, at every distance: test_frames_near_handles.cpp.
#include "tests/support/catch.hpp"
#include "tests/support/deform_cases.hpp"
#include "tests/support/isa_guard.hpp"
#include "tests/support/limit_reference.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

using namespace mlsdeform;
using mlsdeform::testing::IsaGuard;
using namespace mlsdeform::testing::limits;

// On a point handle. The limit's H = M C (M = s R0, or the affine A) with C as `conditioning`; the session sums it
// in double from targets rounded to T, so |dH|_F <= 2 eps(T) Q a (each q_j - q_n off by eps(T) (|q_j| + |q_n|) <=
// 2 eps(T) Q, times |A_j| = w_j |d_j|) plus double's rounding of its J-term sum, 2 (J + 16) eps_d Q a, and the fit's
// bound |dR|_F <= 2 (|dH|_F + 16 eps_d |H|_F) / gap with gap = s (lambda_1 + lambda_2) of C
// (tests/support/mls_reference.hpp), then R rounded to T
// (|dR|_F <= 3 eps(T)). Similarity: mu = tr(R^T H) / tr(C) within s (|dR|_F sqrt(3) |C|_F + |dH|_F sqrt(3)) / tr C.
// Affine: L = H C^-1, |dL|_F <= |dH|_F / lambda_min(C) + 3 |A|_F eps(T).
TEMPLATE_TEST_CASE("near handles: a vertex on a point handle gets the motion's frame in every storage",
                   "[frames][near_handles]", float, double) {
  using T = TestType;
  const IsaGuard guard;
  std::mt19937_64 g(21);
  testing::DeformCase<T> c = testing::random_case<T>(g, 150, 8);
  const Eigen::Index k = c.rest.point_count();
  for (Eigen::Index j = 0; j < k; ++j) c.vertices.row(3 * j) = c.rest.points.row(j);  // vertex 3j on handle j
  const double eps = std::numeric_limits<T>::epsilon(), eps_d = std::numeric_limits<double>::epsilon();
  const Eigen::Vector3d axis = Eigen::Vector3d(0.4, -0.7, 0.2).normalized(), shift(0.3, -0.5, 0.8);
  int checked = 0;
  for (Isa isa : supported_isas())
    for (Transform tr : {Transform::rigid, Transform::similarity, Transform::affine})
      for (WeightStorage ws : {WeightStorage::precomputed, WeightStorage::on_the_fly,
                               WeightStorage::precomputed_weights, WeightStorage::automatic})
        for (double angle : {0.7, 2.6, std::numbers::pi}) {
          const bool affine = tr == Transform::affine;
          if (affine && (ws == WeightStorage::on_the_fly || ws == WeightStorage::precomputed_weights)) continue;
          const double s = tr == Transform::similarity ? 1.9 : 1.0;
          const Eigen::Matrix3d R0 = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
          const Eigen::Matrix3d M = affine ? Eigen::Matrix3d(kGeneral * R0) : Eigen::Matrix3d(s * R0);
          INFO("isa " << to_string(isa) << " transform " << int(tr) << " storage " << int(ws) << " angle " << angle);
          Options o;
          o.isa = isa;
          o.transform = tr;
          o.weight_storage = ws;
          o.affine_frames = affine;
          const Handles<T> moved = moved_by(c.rest, M, shift);
          const Deformer<T> d(c.vertices, c.rest, o);
          Points<T> out, plain;
          AllFrames<T> f(d.vertex_count(), affine);
          d.deform(moved, out, f.out());
          d.deform(moved, plain);
          CHECK(out == plain);  // the positions do not depend on the frames
          const double Q = largest_target(moved);
          for (Eigen::Index n = 0; n < k; ++n) {
            const Eigen::Index v = 3 * n;
            CHECK(out.row(v) == moved.points.row(n));  // on the handle: its target, exactly
            const Conditioning cd =
                conditioning(c.rest, c.rest.points.row(n).transpose().template cast<LD>(), n, 2, true);
            const Eigen::SelfAdjointEigenSolver<Mat3L> es(cd.C);
            const double dH = double(2 * (eps + double(k + 16) * eps_d) * Q * cd.a);
            const Eigen::Matrix3d L = f.matrix(f.l, v);
            if (affine) {
              const double tol = dH / double(es.eigenvalues()(0)) + 3 * M.norm() * eps;
              INFO("vertex " << v << " |L - A| " << (L - M).norm() << " bound " << tol);
              CHECK((L - M).norm() <= tol);
            } else {
              const double gap = s * double(es.eigenvalues()(0) + es.eigenvalues()(1));
              const double tol_R = 2 * (dH + 16 * eps_d * s * double(cd.C.norm())) / gap + 3 * eps;
              const Eigen::Matrix3d R = f.matrix(f.r, v);
              const double mu = double(f.s[std::size_t(v)]);
              const double tol_mu =
                  (s * tol_R * std::sqrt(3.0) * double(cd.C.norm()) + std::sqrt(3.0) * dH) / double(cd.C.trace()) +
                  2 * s * eps;
              INFO("vertex " << v << " |R - R0| " << (R - R0).norm() << " bound " << tol_R << " mu " << mu);
              CHECK((R - R0).norm() <= tol_R);
              CHECK(std::abs(mu - s) <= tol_mu);
              CHECK((L - s * R0).norm() <= s * tol_R + std::sqrt(3.0) * tol_mu + 3 * s * eps);
              const Eigen::Quaterniond q0(R0);
              const Eigen::Vector4d q(f.q[4 * std::size_t(v)], f.q[4 * std::size_t(v) + 1], f.q[4 * std::size_t(v) + 2],
                                      f.q[4 * std::size_t(v) + 3]);
              const Eigen::Vector4d e0(q0.w(), q0.x(), q0.y(), q0.z());
              CHECK(std::min((q - e0).norm(), (q + e0).norm()) <= tol_R / 2 + 3 * tol_R + 10 * eps);
            }
            ++checked;
          }
        }
  CHECK(checked > 0);
}

// On a segment handle (ends and interior), both segment weights, u = 2 and 4: the frame is the motion's. The
// limit (near_handles.hpp) with others C (conditioning, weights relative to 1) and the own segment's weight m:
//   dominated (paper_constant; exact_integral with u >= 3): R e^ = f^ and the twist from H' = M C. f = q_b - q_a
//   from targets rounded to T: its direction off by at most 2 eps(T) Q / |f|, which turns R by at most sqrt(2)
//   times that; the twist theta = atan2(s, c) with c >= s tr(Z^T C Z) (Z across e) and |ds| <= 2 |dH'|_F, so R
//   turns about f^ by at most 2 |dH'|_F / (s tr(Z^T C Z)), |dR|_F <= sqrt(2) times that. mu = |f| / |e| within
//   s 2 eps(T) Q / |f| + 2 s eps(T). Affine: L = (f / |e|)(e^^T - e^^T C P) + H' P, P = Z (Z^T C Z)^-1 Z^T:
//   |dL|_F <= (2 eps(T) Q / |e|)(1 + |C|_F / l_min) + |dH'|_F / l_min, l_min C's smallest eigenvalue across e.
//   exact_integral, u = 2: H = H' + m f e^T with m = |e|^-2 (t + (1 - t)) / 1 = |e|^-2: the fit's bound with the
//   gap of C + m e e^T, |dH|_F <= |dH'|_F + m |e| 2 eps(T) Q; mu = tr(R^T H) / tr(C + m e e^T); L = H G^-1.
// |dH'|_F <= 2 (eps(T) + (J + 16) eps_d) Q a, as on a point handle; every result rounded to T (3 eps(T)).
TEMPLATE_TEST_CASE("near handles: a vertex on a segment handle gets the motion's frame", "[frames][near_handles]",
                   float, double) {
  using T = TestType;
  const IsaGuard guard;
  std::mt19937_64 g(33);
  testing::DeformCase<T> c = testing::random_case<T>(g, 90, 6, 2);
  const std::vector<double> ts = {0.0, 0.2, 0.5, 0.85, 1.0};
  // Vertices 0-4 on segment 0, 5-9 on segment 1, at ts (rounded to T: the closest point is then within eps of
  // the line; the session snaps them, snap.hpp).
  for (Eigen::Index q = 0; q < 2; ++q)
    for (std::size_t i = 0; i < ts.size(); ++i) {
      const Eigen::Vector3d a = c.rest.segment_a.row(q).template cast<double>().transpose(),
                            b = c.rest.segment_b.row(q).template cast<double>().transpose();
      const Eigen::Vector3d p = (1 - ts[i]) * a + ts[i] * b;
      c.vertices.row(Eigen::Index(5 * q) + Eigen::Index(i)) = p.transpose().template cast<T>();
    }
  const double eps = std::numeric_limits<T>::epsilon(), eps_d = std::numeric_limits<double>::epsilon();
  const double J = double(c.rest.point_count() + 2 * c.rest.segment_count());
  const Eigen::Vector3d axis = Eigen::Vector3d(-0.2, 0.9, 0.4).normalized(), shift(-0.4, 0.2, 0.6);
  int checked = 0;
  for (Isa isa : supported_isas())
    for (SegmentWeight sw : {SegmentWeight::paper_constant, SegmentWeight::exact_integral})
      for (double u : {2.0, 4.0})
        for (Transform tr : {Transform::rigid, Transform::similarity, Transform::affine})
          for (double angle : {0.9, std::numbers::pi}) {
            const bool affine = tr == Transform::affine, constant = sw == SegmentWeight::paper_constant;
            const bool dominated = constant || u >= 3;
            const double s = tr == Transform::similarity ? 0.7 : 1.0;
            const Eigen::Matrix3d R0 = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
            const Eigen::Matrix3d M = affine ? Eigen::Matrix3d(kGeneral * R0) : Eigen::Matrix3d(s * R0);
            INFO("isa " << to_string(isa) << " weight " << int(sw) << " u " << u << " transform " << int(tr)
                        << " angle " << angle);
            Options o;
            o.isa = isa;
            o.transform = tr;
            o.segment_weight = sw;
            o.weight_exponent = u;
            o.affine_frames = affine;
            const Handles<T> moved = moved_by(c.rest, M, shift);
            const Deformer<T> d(c.vertices, c.rest, o);
            Points<T> out;
            AllFrames<T> f(d.vertex_count(), affine);
            d.deform(moved, out, f.out());
            const double Q = largest_target(moved);
            for (Eigen::Index q = 0; q < 2; ++q)
              for (std::size_t i = 0; i < ts.size(); ++i) {
                const Eigen::Index v = Eigen::Index(5 * q) + Eigen::Index(i);
                const Vec3L a = c.rest.segment_a.row(q).transpose().template cast<LD>(),
                            b = c.rest.segment_b.row(q).transpose().template cast<LD>(), e = b - a;
                const Vec3L p = a + LD(ts[i]) * e;
                const Conditioning cd = conditioning(c.rest, p, c.rest.point_count() + q, u, constant);
                const double dHp = double(2 * (eps + (J + 16) * eps_d) * Q * cd.a);
                const double len = double(e.norm());
                const Eigen::Vector3d fm = M * e.template cast<double>();  // f exactly
                const Vec3L un = e.normalized();
                Eigen::Matrix<LD, 3, 2> Z;
                Z.col(0) = un.unitOrthogonal(), Z.col(1) = un.cross(Z.col(0));
                const Eigen::Matrix<LD, 2, 2> C22 = Z.transpose() * cd.C * Z;
                const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<LD, 2, 2>> e22(C22);
                const double across = double(C22.trace()), l_min = double(e22.eigenvalues()(0));
                const Eigen::Matrix3d L = f.matrix(f.l, v);
                double tol_R = 0, tol_mu = 0, tol_L = 0;
                const double df = 2 * eps * Q / fm.norm();  // the moved direction's angle
                if (dominated) {
                  tol_R = std::sqrt(2.0) * (df + 2 * dHp / (s * across)) + 3 * eps;
                  tol_mu = s * (df + 2 * eps);
                  tol_L = affine ? (2 * eps * Q / len) * (1 + double(cd.C.norm()) / l_min) + dHp / l_min +
                                       3 * M.norm() * eps
                                 : s * tol_R + std::sqrt(3.0) * tol_mu + 3 * s * eps;
                } else {
                  const LD m = std::pow(LD(len), -LD(u)) *
                               (std::pow(LD(ts[i]), 3 - LD(u)) + std::pow(1 - LD(ts[i]), 3 - LD(u))) / (3 - LD(u));
                  const Mat3L G = cd.C + m * outer(e, e);
                  const Eigen::SelfAdjointEigenSolver<Mat3L> es(G);
                  const double dH = dHp + double(m) * len * 2 * eps * Q;
                  const double gap = s * double(es.eigenvalues()(0) + es.eigenvalues()(1));
                  tol_R = 2 * (dH + 16 * eps_d * s * double(G.norm())) / gap + 3 * eps;
                  tol_mu = (s * tol_R * std::sqrt(3.0) * double(G.norm()) + std::sqrt(3.0) * dH) / double(G.trace()) +
                           2 * s * eps;
                  tol_L = affine ? dH / double(es.eigenvalues()(0)) + 3 * M.norm() * eps
                                 : s * tol_R + std::sqrt(3.0) * tol_mu + 3 * s * eps;
                }
                INFO("segment " << q << " t " << ts[i] << " |L - M| " << (L - M).norm() << " bound " << tol_L);
                CHECK((L - M).norm() <= tol_L);
                if (!affine) {
                  const Eigen::Matrix3d R = f.matrix(f.r, v);
                  INFO("|R - R0| " << (R - R0).norm() << " bound " << tol_R << " mu " << f.s[std::size_t(v)]);
                  CHECK((R - R0).norm() <= tol_R);
                  CHECK(std::abs(double(f.s[std::size_t(v)]) - s) <= tol_mu);
                }
                ++checked;
              }
          }
  CHECK(checked > 0);
}
