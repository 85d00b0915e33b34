// The long-double references of the frames-on-and-near-handles tests (tests/test_frames_on_handles.cpp,
// tests/test_frames_near_handles.cpp): the conditioning of the fit's limit at a handle and the direct evaluation of
// the fit at a vertex, from the rest geometry alone (never from the library's coefficients), and the frame outputs
// the tests fill. Header-only: test support shared by those two files.
#pragma once

#include "tests/support/deform_cases.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

namespace mlsdeform::testing::limits {

using LD = long double;
using Vec3L = Eigen::Matrix<LD, 3, 1>;
using Mat3L = Eigen::Matrix<LD, 3, 3>;

/// a b^T, by loops (Eigen's product assignment with long double draws gcc's -Wmaybe-uninitialized at -O1).
inline Mat3L outer(const Vec3L& a, const Vec3L& b) {
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

inline const Eigen::Matrix3d kGeneral =
    (Eigen::Matrix3d() << 1.3, 0.4, -0.2, -0.3, 0.8, 0.5, 0.25, -0.6, 1.1).finished();

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

}  // namespace mlsdeform::testing::limits
