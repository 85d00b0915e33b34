// Frames near handles (core/src/deformer/near_handles.hpp): at every distance 10^-k (k = 1 .. 12) of the handle
// spacing from a point or a segment handle, a rigid or similarity motion of every handle gives that transform's
// frame and position, in float and double, on every ISA. The oracle is the motion itself; the tolerances are the
// fit's bound with each vertex's own conditioning, computed in long double from the rest geometry
// (tests/support/limit_reference.hpp). On handles: test_frames_on_handles.cpp.
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

// Near a handle: vertices at 10^-k (k = 1 .. 12) of the handle spacing from a point handle (every storage) and
// from a segment's interior (the table), both weights, float and double. The motion x -> M x + t must come out at
// every vertex: the position within (J + 16) 4 eps(T) Q + |dL|_F |v - p*| (the sums' rounding, and the frame's error
// times vhat), the frame within the fit's bound with the vertex's own conditioning (Direct: gap = s (lambda_1 +
// lambda_2) of M, |dH|_F <= 2 (J + 16) eps(T) Q a), or, in the band beside a segment where the segment's own term
// swamps the others' (the others' spread across it below 2^-14 of its own: near_handles.hpp computes those in
// double, apart), the bound of the limit at the segment's closest point as above. Between 2^-14 and 2^-6 (the band's
// edge, 2^-10, lies there) the vertex is only counted: which path takes it is the library's choice.
TEMPLATE_TEST_CASE("near handles: at every distance from a handle the motion's frame and position",
                   "[frames][near_handles]", float, double) {
  using T = TestType;
  const IsaGuard guard;
  std::mt19937_64 g(45);
  testing::DeformCase<T> c = testing::random_case<T>(g, 40, 6, 1);
  // Spacing: the smallest distance between two handles (the segment: its nearest point).
  const Eigen::Vector3d a0 = c.rest.segment_a.row(0).template cast<double>().transpose(),
                        b0 = c.rest.segment_b.row(0).template cast<double>().transpose();
  double spacing = std::numeric_limits<double>::infinity();
  for (Eigen::Index i = 0; i < 6; ++i)
    for (Eigen::Index j = 0; j < 6; ++j)
      if (i != j)
        spacing = std::min(spacing, (c.rest.points.row(i) - c.rest.points.row(j)).template cast<double>().norm());
  const Eigen::Vector3d p0 = c.rest.points.row(0).template cast<double>().transpose();
  const Eigen::Vector3d e0 = b0 - a0, across = e0.unitOrthogonal(), other = e0.normalized().cross(across);
  std::vector<Eigen::Vector3d> extra;
  for (int k = 1; k <= 12; ++k) {
    const double delta = std::pow(10.0, -k) * spacing;
    extra.push_back(p0 + delta * Eigen::Vector3d(0.48, -0.6, 0.64));
    extra.push_back(a0 + 0.4 * e0 + delta * (0.8 * across + 0.6 * other));
  }
  Points<T> vertices(c.vertices.rows() + Eigen::Index(extra.size()), 3);
  vertices.topRows(c.vertices.rows()) = c.vertices;
  for (std::size_t i = 0; i < extra.size(); ++i)
    vertices.row(c.vertices.rows() + Eigen::Index(i)) = extra[i].transpose().template cast<T>();
  Handles<T> points_only;
  points_only.points = c.rest.points;
  const double eps = std::numeric_limits<T>::epsilon();
  const Eigen::Vector3d axis = Eigen::Vector3d(0.6, 0.3, -0.74).normalized(), shift(0.2, 0.7, -0.3);
  int checked = 0, in_band = 0, edge = 0;
  for (Isa isa : supported_isas())
    for (int scene = 0; scene < 2; ++scene)
      for (WeightStorage ws :
           {WeightStorage::precomputed, WeightStorage::on_the_fly, WeightStorage::precomputed_weights})
        for (SegmentWeight sw : {SegmentWeight::paper_constant, SegmentWeight::exact_integral})
          for (Transform tr : {Transform::rigid, Transform::similarity}) {
            const Handles<T>& rest = scene == 0 ? points_only : c.rest;
            if (scene == 1 && ws != WeightStorage::precomputed) continue;     // segments: the table only
            if (scene == 0 && sw == SegmentWeight::exact_integral) continue;  // no segment to weigh
            const double u = 2, s = tr == Transform::similarity ? 1.3 : 1.0,
                         J = double(rest.point_count() + 2 * rest.segment_count());
            const bool constant = sw == SegmentWeight::paper_constant;
            const Eigen::Matrix3d R0 = Eigen::AngleAxisd(2.2, axis).toRotationMatrix(), M = s * R0;
            INFO("isa " << to_string(isa) << " scene " << scene << " storage " << int(ws) << " weight " << int(sw)
                        << " transform " << int(tr));
            Options o;
            o.isa = isa;
            o.transform = tr;
            o.weight_storage = ws;
            o.segment_weight = sw;
            const Handles<T> moved = moved_by(rest, M, shift);
            const Deformer<T> d(vertices, rest, o);
            Points<T> out;
            AllFrames<T> f(d.vertex_count(), false);
            d.deform(moved, out, f.out());
            const double Q = largest_target(moved);
            for (Eigen::Index v = 0; v < vertices.rows(); ++v) {
              const Vec3L x = vertices.row(v).transpose().template cast<LD>();
              // Rounded to T, the nearest vertices to a point handle may land on it: then the limit there, as on a
              // point handle (the first test case's bound).
              Eigen::Index on = -1;
              for (Eigen::Index j = 0; j < rest.point_count(); ++j)
                if (rest.points.row(j).transpose().template cast<LD>() == x) on = j;
              if (on >= 0) {
                const Conditioning cd = conditioning(rest, x, on, u, constant);
                const Eigen::SelfAdjointEigenSolver<Mat3L> el(cd.C);
                const double dH = double(2 * (eps + (J + 16) * std::numeric_limits<double>::epsilon()) * Q * cd.a);
                const double tol_R = 2 * (dH + 16 * std::numeric_limits<double>::epsilon() * s * double(cd.C.norm())) /
                                         (s * double(el.eigenvalues()(0) + el.eigenvalues()(1))) +
                                     3 * eps;
                const Eigen::Matrix3d R = f.matrix(f.r, v);
                INFO("vertex " << v << " on point handle " << on << " |R - R0| " << (R - R0).norm() << " bound "
                               << tol_R);
                CHECK((R - R0).norm() <= tol_R);
                CHECK(out.row(v) == moved.points.row(on));
                ++checked;
                continue;
              }
              const Direct dv = direct(rest, x, u, constant, 0);
              const Eigen::SelfAdjointEigenSolver<Mat3L> es(dv.M);
              const double gap = s * double(es.eigenvalues()(0) + es.eigenvalues()(1)),
                           ratio = double(dv.own_second) > 0 ? double(dv.own_across / dv.own_second) : 1.0;
              double tol_R;
              if (ratio >= 0x1p-6) {
                const double dH = 2 * (J + 16) * eps * Q * double(dv.a);
                tol_R = 2 * (dH + 16 * eps * s * double(dv.M.norm())) / gap + 3 * eps;
              } else if (ratio < 0x1p-14) {
                ++in_band;
                const Vec3L a = rest.segment_a.row(0).transpose().template cast<LD>(),
                            e = rest.segment_b.row(0).transpose().template cast<LD>() - a;
                const LD tc = std::clamp((x - a).dot(e) / e.squaredNorm(), LD(0), LD(1));
                const Conditioning cd = conditioning(rest, Vec3L(a + tc * e), rest.point_count(), u, constant);
                const Vec3L un = e.normalized();
                const double acr = double(cd.C.trace() - un.dot(cd.C * un));
                const double dHp = 2 * (eps + (J + 16) * std::numeric_limits<double>::epsilon()) * Q * double(cd.a);
                const double df = 2 * eps * Q / (M * e.template cast<double>()).norm();
                // The limit's own error (the tilt it leaves out, at most the ratio) besides the rounding.
                tol_R = std::sqrt(2.0) * (df + 2 * dHp / (s * acr)) + 3 * eps + 4 * ratio;
              } else {
                ++edge;
                continue;
              }
              const Eigen::Matrix3d R = f.matrix(f.r, v);
              const Eigen::Vector3d want = M * x.template cast<double>() + shift;
              const double vhat = double((x - dv.p_star).norm());
              // Snapping (snap.hpp) moves a vertex within 64 eps(T) d_2 of a handle onto it: d_2 is at most the
              // cube's diagonal, 2 sqrt(3).
              const double tol_p =
                  4 * (J + 16) * eps * Q + (s * tol_R + 2 * s * eps) * vhat + 64 * eps * s * 2 * std::sqrt(3.0);
              const double dp = (out.row(v).template cast<double>().transpose() - want).norm();
              INFO("vertex " << v << " ratio " << ratio << " |R - R0| " << (R - R0).norm() << " bound " << tol_R
                             << " |dp| " << dp << " bound " << tol_p);
              CHECK((R - R0).norm() <= tol_R);
              CHECK(dp <= tol_p);
              ++checked;
            }
          }
  INFO("checked " << checked << " in the band " << in_band << " at its edge " << edge);
  CHECK(in_band > 0);
  CHECK(edge <= checked / 10);
}
