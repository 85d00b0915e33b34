// See mls_reference.hpp.
#include "tests/support/mls_reference.hpp"

#include "tests/support/deform_cases.hpp"  // scene_size

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <limits>

namespace mlsdeform::testing {

namespace {
using Vec3d = Eigen::Vector3d;
using Mat3d = Eigen::Matrix3d;
}  // namespace

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
  r.s1 = sv[0];
  r.norm_H = H.norm();
  if (!(r.gap > 0)) {
    r.well_posed = false;
    return r;
  }
  double sum_wq = 0, Habs = 0, scale = 0;
  for (std::size_t j = 0; j < J; ++j) {
    sum_wq += w[j] / S * ph[j].q.norm();
    Habs += ((ph[j].q - c).norm() + ph[j].q.norm()) * A[j].norm();
    scale += A[j].norm() * (qhat[j].norm() + ph[j].q.norm());
  }
  r.sum_scale = scale / r.norm_H;
  const double dH = m * Habs;
  r.dH_unit = dH;
  r.mu = mu;
  r.D = D;
  r.vhat_norm = vhat.norm();
  r.q_star_norm = q_star.norm();
  const double dR = 2 * (dH + 16 * r.norm_H) / r.gap;
  double dmu = 0;
  if (o.transform == Transform::similarity && D > 0) dmu = mu * m + (std::sqrt(3.0) * dH + 16 * r.norm_H) / D;
  const double vn = vhat.norm();
  r.bound_unit = m * sum_wq + mu * dR * vn + dmu * vn + mu * m * (vn + l) + 8 * (q_star.norm() + mu * vn);
  return r;
}

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

template DirectVertex direct_vertex<float>(const Vec3d&, const Handles<float>&, const Handles<float>&, const Options&,
                                           double);
template DirectVertex direct_vertex<double>(const Vec3d&, const Handles<double>&, const Handles<double>&,
                                            const Options&, double);
template Comparison compare_with_direct<float>(const Points<float>&, const Points<float>&, const Handles<float>&,
                                               const Handles<float>&, const Options&);
template Comparison compare_with_direct<double>(const Points<double>&, const Points<double>&, const Handles<double>&,
                                                const Handles<double>&, const Options&);

SampledReference sampled_reference(const Points<double>& vertices, const Points<double>& p, const Points<double>& q,
                                   const std::vector<Eigen::Index>& rows, double u) {
  SampledReference r;
  const std::size_t m = rows.size();
  r.out.resize(static_cast<Eigen::Index>(m), 3);
  r.kappa.assign(m, 0);
  r.sum_scale.assign(m, 0);
  r.arm.assign(m, 0);
  r.diameter = (vertices.colwise().maxCoeff() - vertices.colwise().minCoeff()).norm();
  r.handles = p.rows();
  Handles<double> rest, moved;
  rest.points = p;
  moved.points = q;
  Options o;
  o.transform = Transform::rigid;
  o.weight_exponent = u;
  const double l = scene_size(vertices, rest);
  for (std::size_t s = 0; s < m; ++s) {
    const DirectVertex d = direct_vertex(Vec3d(vertices.row(rows[s]).transpose()), rest, moved, o, l);
    r.out.row(static_cast<Eigen::Index>(s)) = d.out.transpose();
    if (d.snapped) continue;  // kappa 0: on a handle
    if (!d.well_posed) {
      r.kappa[s] = std::numeric_limits<double>::infinity();
      continue;
    }
    r.kappa[s] = d.s1 / d.gap;
    r.sum_scale[s] = d.sum_scale;
    r.arm[s] = d.vhat_norm;
  }
  return r;
}

SampledReference rbf_centroid_reference(const SampledReference& mls, const Points<double>& vertices,
                                        const Points<double>& p, const Points<double>& q,
                                        const std::vector<Eigen::Index>& rows) {
  SampledReference r = mls;
  const Eigen::Index J = p.rows(), size = J + 4;
  const Vec3d mean = p.colwise().mean().transpose();
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(size, size);
  for (Eigen::Index i = 0; i < J; ++i) {
    for (Eigen::Index j = 0; j < J; ++j) M(i, j) = (p.row(i) - p.row(j)).norm();
    M(i, J) = M(J, i) = 1;
    for (int c = 0; c < 3; ++c) M(i, J + 1 + c) = M(J + 1 + c, i) = p(i, c) - mean[c];
  }
  const Eigen::FullPivLU<Eigen::MatrixXd> lu(M);
  const auto sv = Eigen::JacobiSVD<Eigen::MatrixXd>(M).singularValues();
  const double kappa = sv(0) / sv(size - 1), Q = q.cwiseAbs().maxCoeff();
  r.rbf_unit.assign(rows.size(), 0);
  r.rbf_abs.assign(rows.size(), 0);
  for (std::size_t s = 0; s < rows.size(); ++s) {
    if (mls.kappa[s] == 0) continue;  // on a handle: the target, as with MLS
    const Vec3d v = vertices.row(rows[s]).transpose();
    Vec3d ps = Vec3d::Zero(), qs = Vec3d::Zero();
    double W = 0;
    for (Eigen::Index j = 0; j < J; ++j) {
      const double w = 1 / (p.row(j).transpose() - v).squaredNorm();
      ps += w * p.row(j).transpose(), qs += w * q.row(j).transpose(), W += w;
    }
    ps /= W, qs /= W;
    Eigen::VectorXd rhs(size);
    for (Eigen::Index j = 0; j < J; ++j) rhs(j) = (ps - p.row(j).transpose()).norm();
    rhs(J) = 1;
    rhs.tail(3) = ps - mean;
    const Eigen::VectorXd beta = lu.solve(rhs);
    const Vec3d g = q.transpose() * beta.head(J);
    r.out.row(static_cast<Eigen::Index>(s)) += (g - qs).transpose();
    const double B = beta.head(J).cwiseAbs().sum();
    r.rbf_unit[s] = double(J + 2) * B * Q;
    r.rbf_abs[s] = double(J + 4) * std::numeric_limits<double>::epsilon() * kappa * B * Q;
  }
  return r;
}

double deform_tolerance(const SampledReference& r, std::size_t s, double eps) {
  constexpr double c = 32;
  const double rbf = r.rbf_unit.empty() ? 0.0 : eps * r.rbf_unit[s] + r.rbf_abs[s];
  if (r.kappa[s] == 0) return c * eps * r.diameter;  // on a handle
  if (!std::isfinite(r.kappa[s]) || !std::isfinite(r.sum_scale[s])) return std::numeric_limits<double>::infinity();
  const double turn = (c + static_cast<double>(r.handles)) * eps * r.sum_scale[s] * (2 + std::sqrt(3.0) * r.kappa[s]);
  return c * eps * r.diameter + std::min(turn, 2.0) * r.arm[s] + rbf;
}

std::vector<Eigen::Index> check_rows(Eigen::Index n, Eigen::Index max_rows) {
  std::vector<Eigen::Index> rows;
  if (n <= max_rows) {
    for (Eigen::Index i = 0; i < n; ++i) rows.push_back(i);
  } else {
    for (Eigen::Index s = 0; s < max_rows; ++s) rows.push_back(s * n / max_rows);
  }
  return rows;
}

}  // namespace mlsdeform::testing
