// Frames on and near handles (core/src/deformer/near_handles.hpp): a rigid, similarity or affine motion of every
// handle gives that transform's frame, and its position, at vertices on point handles in every weight storage, on
// segment handles (ends and interior) with either segment weight, and at every distance 10^-k (k = 1 .. 12) of the
// handle spacing from a point or a segment handle, in float and double, on every ISA. The oracle is the motion
// itself (every vertex must get it); the tolerances are the fit's bound with the conditioning of each vertex's own
// limit, computed here in long double from the rest geometry (not from the library's coefficients).
#include "tests/support/catch.hpp"
#include "tests/support/deform_cases.hpp"
#include "tests/support/isa_guard.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

using namespace mlsdeform;
using mlsdeform::testing::IsaGuard;

namespace {

using LD = long double;
using Vec3L = Eigen::Matrix<LD, 3, 1>;
using Mat3L = Eigen::Matrix<LD, 3, 3>;

/// a b^T, by loops (Eigen's product assignment with long double draws gcc's -Wmaybe-uninitialized at -O1).
Mat3L outer(const Vec3L& a, const Vec3L& b) {
  Mat3L m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = a[r] * b[c];
  return m;
}

/// Every frame output for n vertices, filled with a sentinel.
template <class T>
struct AllFrames {
  std::vector<T> q, r, s, l;
  explicit AllFrames(Eigen::Index n, bool affine)
      : q(affine ? 0 : 4 * std::size_t(n), T(-7)),
        r(affine ? 0 : 9 * std::size_t(n), T(-7)),
        s(affine ? 0 : std::size_t(n), T(-7)),
        l(9 * std::size_t(n), T(-7)) {}
  FramesOut<T> out() { return {q, r, s, l}; }
  Eigen::Matrix3d matrix(const std::vector<T>& m, Eigen::Index i) const {
    Eigen::Matrix3d M;
    for (int e = 0; e < 9; ++e) M(e / 3, e % 3) = double(m[9 * std::size_t(i) + std::size_t(e)]);
    return M;
  }
};

/// The rest geometry's conditioning at a point p_ref for the limit of the fit there, from the handles other than
/// `own` (a point index, or k + a segment index), in long double: C = sum_j w_j d_j d_j^T with w_j = |d_j|^-u
/// (d_j = p_j - p_ref; another segment: its integral by composite Simpson over 4,096 pieces, the integrand smooth
/// away from p_ref), and a = sum_j w_j |d_j| (the size of the coefficients that multiply the targets' rounding).
struct Conditioning {
  Mat3L C = Mat3L::Zero();
  LD a = 0;
};

template <class T>
Conditioning conditioning(const Handles<T>& rest, const Vec3L& p_ref, Eigen::Index own, double u, bool constant) {
  Conditioning c;
  const Eigen::Index k = rest.point_count();
  for (Eigen::Index j = 0; j < k; ++j) {
    if (j == own) continue;
    const Vec3L d = rest.points.row(j).transpose().template cast<LD>() - p_ref;
    const LD w = std::pow(d.norm(), -LD(u));
    c.C += w * outer(d, d);
    c.a += w * d.norm();
  }
  for (Eigen::Index q = 0; q < rest.segment_count(); ++q) {
    if (k + q == own) continue;
    const Vec3L a = rest.segment_a.row(q).transpose().template cast<LD>(),
                b = rest.segment_b.row(q).transpose().template cast<LD>();
    const int N = 4096;
    // paper_constant: the weight is constant along the segment, d^-u with d its distance from p_ref.
    LD dmin = std::numeric_limits<LD>::infinity();
    for (int i = 0; i <= N; ++i) dmin = std::min(dmin, (a + (b - a) * (LD(i) / N) - p_ref).norm());
    for (int i = 0; i <= N; ++i) {
      const LD t = LD(i) / N, sw = (i == 0 || i == N ? 1 : i % 2 ? 4 : 2) / (3 * LD(N));
      const Vec3L d = a + t * (b - a) - p_ref;
      const LD w = sw * std::pow(constant ? dmin : d.norm(), -LD(u));
      c.C += w * outer(d, d);
      c.a += w * d.norm();
    }
  }
  return c;
}

/// x -> M x + t for every handle, rounded once to T.
template <class T>
Handles<T> moved_by(const Handles<T>& rest, const Eigen::Matrix3d& M, const Eigen::Vector3d& t) {
  return testing::transformed(rest, M, t);
}

/// The largest |q| of the moved handles.
template <class T>
double largest_target(const Handles<T>& h) {
  double m = 0;
  for (const Points<T>* p : {&h.points, &h.segment_a, &h.segment_b})
    for (Eigen::Index i = 0; i < p->rows(); ++i) m = std::max(m, p->row(i).template cast<double>().norm());
  return m;
}

const Eigen::Matrix3d kGeneral = (Eigen::Matrix3d() << 1.3, 0.4, -0.2, -0.3, 0.8, 0.5, 0.25, -0.6, 1.1).finished();

}  // namespace

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

namespace {

/// The direct evaluation of the fit at v in long double (Sec. 3, 6.2), the conditioning the fit's bound needs:
/// omega_j, p*, M = sum_j omega_j phat_j phat_j^T (a segment: its integral, composite Simpson over 8,192 pieces
/// graded towards the closest point so that peaked weights are resolved), a = sum_j omega_j |phat_j| (segments:
/// the integral of the weight times |phat|), and for the nearest segment (`own`) its share of the second moment
/// about the closest point, m |e|^2 with m = int w (t - tc)^2 / S, to judge the band (near_handles.hpp).
struct Direct {
  Mat3L M = Mat3L::Zero();
  LD a = 0;
  Vec3L p_star = Vec3L::Zero();
  LD own_second = 0;  ///< m |e|^2 of segment `own`
  LD own_across = 0;  ///< tr(Z^T M' Z): the others' spread across the own segment (M' = M - m e e^T)
};

template <class T>
Direct direct(const Handles<T>& rest, const Vec3L& v, double u, bool constant, Eigen::Index own_segment) {
  struct Node {
    Vec3L p;
    LD w;
  };
  std::vector<Node> nodes;
  for (Eigen::Index j = 0; j < rest.point_count(); ++j) {
    const Vec3L p = rest.points.row(j).transpose().template cast<LD>();
    nodes.push_back({p, std::pow((p - v).norm(), -LD(u))});
  }
  std::vector<std::pair<std::size_t, std::size_t>> own_nodes;  // [begin, end) of the own segment's nodes
  Vec3L own_e = Vec3L::Zero();
  LD own_tc = 0;
  for (Eigen::Index q = 0; q < rest.segment_count(); ++q) {
    const Vec3L a = rest.segment_a.row(q).transpose().template cast<LD>(),
                b = rest.segment_b.row(q).transpose().template cast<LD>(), e = b - a;
    const LD tc = std::clamp((v - a).dot(e) / e.squaredNorm(), LD(0), LD(1));
    const LD dmin = (a + tc * e - v).norm();
    const std::size_t begin = nodes.size();
    // Simpson on [0, tc] and [tc, 1], each graded geometrically towards tc: t = tc -+ len * x^4 (x uniform).
    const int N = 4096;
    for (int side = -1; side <= 1; side += 2) {
      const LD len = side < 0 ? tc : 1 - tc;
      if (!(len > 0)) continue;
      for (int i = 0; i <= N; ++i) {
        const LD x = LD(i) / N, sw = (i == 0 || i == N ? 1 : i % 2 ? 4 : 2) / (3 * LD(N));
        const LD t = tc + side * len * x * x * x * x, dt = len * 4 * x * x * x;  // dt/dx
        const Vec3L p = a + t * e;
        const LD d = constant ? dmin : (p - v).norm();
        nodes.push_back({p, sw * dt * std::pow(d, -LD(u))});
      }
    }
    if (q == own_segment) {
      own_nodes.emplace_back(begin, nodes.size());
      own_e = e;
      own_tc = tc;
    }
  }
  LD S = 0;
  for (const Node& n : nodes) S += n.w;
  Direct r;
  for (const Node& n : nodes) r.p_star += n.w / S * n.p;
  for (const Node& n : nodes) {
    const Vec3L ph = n.p - r.p_star;
    r.M += n.w / S * outer(ph, ph);
    r.a += n.w / S * ph.norm();
  }
  if (!own_nodes.empty()) {
    const Vec3L a = rest.segment_a.row(own_segment).transpose().template cast<LD>();
    LD m = 0;
    for (std::size_t i = own_nodes[0].first; i < own_nodes[0].second; ++i) {
      const LD dt = (nodes[i].p - a).dot(own_e) / own_e.squaredNorm() - own_tc;
      m += nodes[i].w / S * dt * dt;
    }
    r.own_second = m * own_e.squaredNorm();
    const Mat3L Mp = r.M - m * outer(own_e, own_e);
    const Vec3L un = own_e.normalized();
    r.own_across = Mp.trace() - un.dot(Mp * un);
  }
  return r;
}

}  // namespace

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
