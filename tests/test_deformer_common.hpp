// Shared helpers of the deformer tests (tests/test_deformer*.cpp): random scenes, an OBJ vertex reader, and
// an independent direct per-vertex MLS evaluation in double with a derived error bound.
//
// Direct evaluation (the reference). For each vertex v, straight from the paper, with no precomputed table:
//   w_i = |p_i - v|^-u (points); segments: the paper's constant d^-u with W_i and midpoint centroids (Sec. 6.2)
//   p*, q* (eq. 2), H = sum w qhat phat^T / S (eq. 6), R = fit_rotation(H, svd), mu = trace(R^T H) / D
//   (Sec. 6.1), v' = q* + mu R (v - p*); affine: v' = q* + H G^-1 (v - p*), G = sum w phat phat^T / S.
// A vertex at distance 0 from a point handle maps to its target; one on a segment takes the map's limit there
// (that segment alone, constant weight).
//
// Error bound of the precomputed path in precision T against the exact result (first order, per vertex;
// eps = eps(T), m = J + 16: J rounded additions of the per-vertex sums plus at most 16 roundings of each
// stored coefficient in the precomputation). The precomputation removes the common rounding error of p* from
// the A_j (deformer.cpp), so each A_j is accurate relative to itself, |dA_j| <= m eps |A_j|; p* and vhat
// carry an absolute error of eps times the scene size l (the local frame):
//   |dq*| <= m eps sum_j omega_j |q_j|                                       (weighted_centroid)
//   |dH|_F <= m eps Habs, Habs = sum_j (|q_j - c| + |q_j|) |A_j|              (correlation_matrix; the |q_j|
//                                                                             term covers targets rounded to T)
//   |dR|_F <= 2 (|dH|_F + 16 eps |H|_F) / gap                                (perturbation of the polar
//            factor, gap = s2 + sign(det H) s3 (Kenney-Laub); 16 eps |H|_F is the fit's own backward error)
//   |dmu| <= mu m eps + (sqrt(3) |dH|_F + 16 eps |H|_F) / D                  (similarity; the optimum
//            trace(R^T H) is stationary in R, so dR enters only at second order)
//   |dv'| <= |dq*| + mu |dR| |vhat| + |dmu| |vhat| + mu m eps (|vhat| + l) + 8 eps (|q*| + mu |vhat|)
// Affine: |dv'| <= m eps sum_j |alpha_j| |q_j| + m eps kappa(G) |x| sum_j |A_j| |q_j - q*| + 8 eps |v'|,
// x = G^-1 vhat: the rounding of the alpha_j to T, and of the double-precision solve that produced them.
// The reference itself obeys the same bound with eps(double); comparisons add both.
#pragma once

#include <mlsdeform/mlsdeform.hpp>

#include <catch2/catch.hpp>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace deformer_test {

using namespace mlsdeform;
using Vec3d = Eigen::Vector3d;
using Mat3d = Eigen::Matrix3d;

inline constexpr Transform all_transforms[] = {Transform::rigid, Transform::similarity, Transform::affine};

inline const char* name(Transform t) {
  return t == Transform::rigid ? "rigid" : t == Transform::similarity ? "similarity" : "affine";
}

template <class T>
const char* type_name() {
  return sizeof(T) == 4 ? "float" : "double";
}

/// The seed of the random tests: Catch's --rng-seed (0 means the fixed default below).
inline unsigned seed() {
  const unsigned s = Catch::rngSeed();
  return s != 0 ? s : 20240611u;
}

/// x rounded to E and back to double. Through a volatile: GCC 12.2 at -O2 (SLP vectorizer) was seen to drop
/// a double -> float -> double round trip written as an expression (wrong code; -fno-tree-slp-vectorize
/// avoids it), which made "the same float-rounded geometry in double" silently not the same.
template <class E>
double rounded_to(double x) {
  volatile E y = static_cast<E>(x);
  return static_cast<double>(y);
}

/// Points rounded to E, returned in double (row by row through rounded_to).
template <class E>
Points<double> rounded_points(const Points<double>& p) {
  Points<double> r(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (Eigen::Index c = 0; c < 3; ++c) r(i, c) = rounded_to<E>(p(i, c));
  return r;
}

inline Vec3d random_vector(std::mt19937_64& g, double lo = -1, double hi = 1) {
  std::uniform_real_distribution<double> d(lo, hi);
  return Vec3d(d(g), d(g), d(g));
}

inline Mat3d random_rotation(std::mt19937_64& g) {
  std::normal_distribution<double> n;
  Eigen::Quaterniond q(n(g), n(g), n(g), n(g));
  q.normalize();
  return q.toRotationMatrix();
}

inline Mat3d rotation_about(const Vec3d& axis, double angle) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

template <class T>
Points<T> random_points(std::mt19937_64& g, Eigen::Index n, double lo = -1, double hi = 1) {
  Points<T> p(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) p.row(i) = random_vector(g, lo, hi).cast<T>().transpose();
  return p;
}

/// Applies x -> M x + t to every row (in double, rounded once to T).
template <class T>
Points<T> transformed(const Points<T>& p, const Mat3d& M, const Vec3d& t) {
  Points<T> q(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    q.row(i) = (M * p.row(i).transpose().template cast<double>() + t).template cast<T>().transpose();
  return q;
}

template <class T>
Handles<T> transformed(const Handles<T>& h, const Mat3d& M, const Vec3d& t) {
  Handles<T> q;
  q.points = transformed(h.points, M, t);
  q.segment_a = transformed(h.segment_a, M, t);
  q.segment_b = transformed(h.segment_b, M, t);
  return q;
}

/// 'v' lines of an OBJ file.
inline Points<double> read_obj_vertices(const std::string& path) {
  std::ifstream in(path);
  REQUIRE(in.good());
  std::vector<Vec3d> v;
  std::string line;
  while (std::getline(in, line)) {
    if (line.size() < 2 || line[0] != 'v' || line[1] != ' ') continue;
    std::istringstream s(line.substr(2));
    Vec3d x;
    s >> x[0] >> x[1] >> x[2];
    v.push_back(x);
  }
  Points<double> p(static_cast<Eigen::Index>(v.size()), 3);
  for (std::size_t i = 0; i < v.size(); ++i) p.row(static_cast<Eigen::Index>(i)) = v[i].transpose();
  return p;
}

/// Bounding-box diagonal of the rest vertices and handles (the scene size l of the bound).
template <class T>
double scene_size(const Points<T>& v, const Handles<T>& h) {
  Vec3d lo = Vec3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  auto add = [&](const Points<T>& p) {
    for (Eigen::Index i = 0; i < p.rows(); ++i) {
      lo = lo.cwiseMin(p.row(i).transpose().template cast<double>());
      hi = hi.cwiseMax(p.row(i).transpose().template cast<double>());
    }
  };
  add(v);
  add(h.points);
  add(h.segment_a);
  add(h.segment_b);
  return (hi - lo).norm();
}

/// One vertex of the direct evaluation, with what the error bound needs.
struct DirectVertex {
  Vec3d out = Vec3d::Zero();
  bool snapped = false;   ///< at distance 0 from a handle
  bool well_posed = true; ///< gap > 0 (rigid, similarity), G invertible (affine)
  double bound_unit = 0;  ///< the bound of the file comment divided by eps (so bound = eps * bound_unit)
  double gap = 0, norm_H = 0;   ///< conditioning of the rotation fit (rigid, similarity)
  double dH_unit = 0;           ///< the bound on |dH|_F divided by eps
  double mu = 1, D = 0, vhat_norm = 0, q_star_norm = 0;
};

/// The direct evaluation of one vertex (double). rest/moved may include segments (paper_constant weights).
template <class T>
DirectVertex direct_vertex(const Vec3d& v, const Handles<T>& rest, const Handles<T>& moved, const Options& o,
                           double scene) {
  const double u = o.weight_exponent;
  const Eigen::Index k = rest.points.rows(), s = rest.segment_a.rows();
  // Pseudo-handles (points, then segment ends) with their weights: omega_j and the moment structure.
  struct PH {
    Vec3d p, q;
  };
  std::vector<PH> ph;
  auto row = [](const Points<T>& m, Eigen::Index i) { return Vec3d(m.row(i).transpose().template cast<double>()); };
  for (Eigen::Index i = 0; i < k; ++i) ph.push_back({row(rest.points, i), row(moved.points, i)});
  for (Eigen::Index i = 0; i < s; ++i) {
    ph.push_back({row(rest.segment_a, i), row(moved.segment_a, i)});
    ph.push_back({row(rest.segment_b, i), row(moved.segment_b, i)});
  }
  const std::size_t J = ph.size();
  DirectVertex r;
  // Distances (segment: to the closest point) and the interpolation case. Weights (d_min / d)^u: the same as
  // d^-u after normalisation, without overflow for large u or tiny d.
  std::vector<double> w(J, 0.0);  // centroid weights (unnormalised)
  std::vector<double> dist(J, 0.0), dseg(static_cast<std::size_t>(s)), tseg(static_cast<std::size_t>(s));
  double d_min = std::numeric_limits<double>::infinity();
  for (Eigen::Index i = 0; i < k; ++i) {
    dist[i] = (ph[i].p - v).norm();
    if (dist[i] == 0) {
      r.out = ph[i].q;
      r.snapped = true;
      return r;
    }
    d_min = std::min(d_min, dist[i]);
  }
  for (Eigen::Index i = 0; i < s; ++i) {
    const Vec3d a = ph[k + 2 * i].p, b = ph[k + 2 * i + 1].p;
    tseg[i] = std::clamp((v - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
    dseg[i] = (a + tseg[i] * (b - a) - v).norm();
    d_min = std::min(d_min, dseg[i]);
  }
  // On a segment (d_min = 0) the map takes its limit there: that segment alone, with constant weight (the
  // others' relative weights vanish). For rigid this is not the interpolation of the segment's targets when
  // the move stretches it; similarity and affine reproduce (1 - t) c + t d.
  const bool on_segment = d_min == 0;
  r.snapped = on_segment;
  if (on_segment && o.transform == Transform::affine) {  // G is singular there; its limit interpolates
    for (Eigen::Index i = 0; i < s; ++i)
      if (dseg[i] == 0) {
        r.out = (1 - tseg[i]) * ph[k + 2 * i].q + tseg[i] * ph[k + 2 * i + 1].q;
        return r;
      }
  }
  for (Eigen::Index i = 0; i < k; ++i) w[i] = on_segment ? 0.0 : std::pow(d_min / dist[i], u);
  bool taken = false;
  for (Eigen::Index i = 0; i < s; ++i) {
    // Now the segment's weight, (d_min / d)^u.
    if (on_segment) {
      dseg[i] = dseg[i] == 0 && !taken ? 1.0 : 0.0;
      taken = taken || dseg[i] == 1.0;
    } else {
      dseg[i] = std::pow(d_min / dseg[i], u);
    }
    w[k + 2 * i] = w[k + 2 * i + 1] = dseg[i] / 2;  // Sec. 6.2: midpoint centroids with weight d^-u
  }
  double S = 0;
  for (double x : w) S += x;
  Vec3d p_star = Vec3d::Zero(), q_star = Vec3d::Zero();
  for (std::size_t j = 0; j < J; ++j) {
    p_star += w[j] / S * ph[j].p;
    q_star += w[j] / S * ph[j].q;
  }
  // phat_j = p_j - p* as sum_k omega_k (p_j - p_k) (sum_k omega_k = 1): no cancellation when one weight
  // dominates (a vertex near a handle), where p_j - p* would carry the absolute rounding of p*. Same for qhat.
  std::vector<Vec3d> phat(J, Vec3d::Zero()), qhat(J, Vec3d::Zero());
  for (std::size_t j = 0; j < J; ++j)
    for (std::size_t m2 = 0; m2 < J; ++m2) {
      phat[j] += w[m2] / S * (ph[j].p - ph[m2].p);
      qhat[j] += w[m2] / S * (ph[j].q - ph[m2].q);
    }
  // H = sum w qhat phat^T / S; segments with W_i = d^-u [[1/3, 1/6], [1/6, 1/3]] (Sec. 6.2).
  Mat3d H = Mat3d::Zero(), G = Mat3d::Zero();
  double D = 0;
  std::vector<Vec3d> A(J);
  for (Eigen::Index i = 0; i < k; ++i) {
    const Vec3d ph_i = phat[i], qh_i = qhat[i];
    H += w[i] / S * qh_i * ph_i.transpose();
    G += w[i] / S * ph_i * ph_i.transpose();
    D += w[i] / S * ph_i.squaredNorm();
    A[i] = w[i] / S * ph_i;
  }
  for (Eigen::Index i = 0; i < s; ++i) {
    const std::size_t jc = k + 2 * i, jd = jc + 1;
    const Vec3d ah = phat[jc], bh = phat[jd];
    const Vec3d ch = qhat[jc], dh = qhat[jd];
    const double W0 = dseg[i] / 3 / S, W1 = dseg[i] / 6 / S;
    H += W0 * ch * ah.transpose() + W1 * ch * bh.transpose() + W1 * dh * ah.transpose() + W0 * dh * bh.transpose();
    G += W0 * ah * ah.transpose() + W1 * (ah * bh.transpose() + bh * ah.transpose()) + W0 * bh * bh.transpose();
    D += W0 * ah.squaredNorm() + 2 * W1 * ah.dot(bh) + W0 * bh.squaredNorm();
    A[jc] = W0 * ah + W1 * bh;
    A[jd] = W1 * ah + W0 * bh;
  }
  const Vec3d vhat = v - p_star;
  Vec3d c = Vec3d::Zero();
  for (const PH& x : ph) c += x.q / double(J);
  const double l = scene;
  const double m = double(J) + 16;
  if (o.transform == Transform::affine) {
    // In units of g = trace G (near a handle G, H and the A_j are all about (d_min / d)^u, maybe 1e-250,
    // and G^-1 vhat would overflow): v' = q* + (H / g) (G / g)^-1 vhat.
    const double g = G.trace();
    if (!(g > 0)) {
      r.well_posed = false;
      return r;
    }
    const Mat3d Gn = G / g;
    const Eigen::SelfAdjointEigenSolver<Mat3d> es(Gn);
    const double lmin = es.eigenvalues()[0], lmax = es.eigenvalues()[2];
    if (!(lmin > 0)) {
      r.well_posed = false;
      return r;
    }
    const Vec3d xn = Gn.ldlt().solve(vhat);  // x = G^-1 vhat = xn / g
    r.out = q_star + (H / g) * xn;
    double sa = 0, sq = 0;
    for (std::size_t j = 0; j < J; ++j) {
      const double alpha = w[j] / S + (A[j] / g).dot(xn);
      sa += std::abs(alpha) * ph[j].q.norm();
      sq += (A[j] / g).norm() * (ph[j].q - q_star).norm();
    }
    r.bound_unit = m * sa + m * (lmax / lmin) * xn.norm() * sq + 8 * r.out.norm();
    return r;
  }
  const Mat3d R = fit_rotation<double>(H, RotationMethod::svd);
  double mu = 1;
  if (o.transform == Transform::similarity && D > 0) mu = (R.transpose() * H).trace() / D;
  r.out = q_star + mu * (R * vhat);
  // Conditioning: gap = s2 + sign(det H) s3.
  const Vec3d sv = Eigen::JacobiSVD<Mat3d>(H).singularValues();
  r.gap = sv[1] + (H.determinant() < 0 ? -sv[2] : sv[2]);
  r.norm_H = H.norm();
  if (!(r.gap > 0)) {
    r.well_posed = false;
    return r;
  }
  double sum_wq = 0, Habs = 0;
  for (std::size_t j = 0; j < J; ++j) {
    sum_wq += w[j] / S * ph[j].q.norm();
    Habs += ((ph[j].q - c).norm() + ph[j].q.norm()) * A[j].norm();
  }
  const double dH = m * Habs;
  r.dH_unit = dH;
  r.mu = mu;
  r.D = D;
  r.vhat_norm = vhat.norm();
  r.q_star_norm = q_star.norm();
  const double dR = 2 * (dH + 16 * r.norm_H) / r.gap;
  double dmu = 0;
  if (o.transform == Transform::similarity && D > 0)
    dmu = mu * m + (std::sqrt(3.0) * dH + 16 * r.norm_H) / D;
  const double vn = vhat.norm();
  r.bound_unit = m * sum_wq + mu * dR * vn + dmu * vn + mu * m * (vn + l) + 8 * (q_star.norm() + mu * vn);
  return r;
}

/// Statistics of a comparison of the deformer's output with the direct evaluation.
struct Comparison {
  double max_dev = 0;         ///< largest |v'_path - v'_direct|
  double max_ratio = 0;       ///< largest deviation / bound
  Eigen::Index worst = -1;    ///< vertex of max_ratio
  Eigen::Index checked = 0, ill_posed = 0, snapped = 0, failures = 0;
};

/// Compares `out` (from the deformer in precision T) with the direct evaluation of every vertex; a vertex
/// fails if its deviation exceeds the bound of T plus the bound of the double reference.
template <class T>
Comparison compare_with_direct(const Points<T>& out, const Points<T>& rest_vertices, const Handles<T>& rest,
                               const Handles<T>& moved, const Options& o) {
  const double l = scene_size(rest_vertices, rest);
  const double eps_t = std::numeric_limits<T>::epsilon(), eps_d = std::numeric_limits<double>::epsilon();
  Comparison c;
  for (Eigen::Index i = 0; i < rest_vertices.rows(); ++i) {
    const Vec3d v = rest_vertices.row(i).transpose().template cast<double>();
    const DirectVertex d = direct_vertex(v, rest, moved, o, l);
    const Vec3d got = out.row(i).transpose().template cast<double>();
    if (!got.allFinite()) {
      ++c.failures;
      continue;
    }
    const double dev = (got - d.out).norm();
    if (d.snapped) {
      ++c.snapped;
      // Interpolation: the target itself, exactly for points; on segments (1-t) c + t d, or the rigid limit
      // q* + R vhat (a rank-1 fit, exact to a few eps), rounded in T.
      if (dev > 8 * eps_t * (d.out.norm() + l)) ++c.failures;
      c.max_dev = std::max(c.max_dev, dev);
      continue;
    }
    // Ill-posed: no unique rotation, or one that rounding of H in T may already change at first order.
    const bool rotation = o.transform != Transform::affine;
    if (!d.well_posed || (rotation && (eps_t + eps_d) * d.dH_unit >= d.gap / 2)) {
      ++c.ill_posed;
      continue;
    }
    ++c.checked;
    const double bound = (eps_t + eps_d) * d.bound_unit;
    c.max_dev = std::max(c.max_dev, dev);
    if (dev / bound > c.max_ratio) c.max_ratio = dev / bound, c.worst = i;
    if (dev > bound) ++c.failures;
  }
  return c;
}

/// A random scene: n vertices in [-1, 1]^3 and `k` point handles spanning 3D.
template <class T>
struct Scene {
  Points<T> vertices;
  Handles<T> handles;
};

template <class T>
Scene<T> random_scene(std::mt19937_64& g, Eigen::Index n, Eigen::Index k, Eigen::Index s = 0) {
  Scene<T> sc;
  sc.vertices = random_points<T>(g, n);
  sc.handles.points = random_points<T>(g, k);
  sc.handles.segment_a = random_points<T>(g, s);
  sc.handles.segment_b = random_points<T>(g, s);
  return sc;
}

}  // namespace deformer_test
