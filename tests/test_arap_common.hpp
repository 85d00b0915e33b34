// The tube the ARAP tests deform, and its reduced cotangent Laplacian's conditioning computed independently
// (dense, long double), from which their bounds are derived.
#pragma once

#include <mlsdeform/mlsdeform.hpp>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace mlsdeform::arap_test {

using LD = long double;

/// A tube along x: `rings` rings of `m` vertices (radius 0.3, length 2), two triangles per quad, with the
/// vertices jittered by `jitter` (so that some angles are obtuse and their cotangents negative).
struct Tube {
  Points<double> v;
  Triangles f;
  int m, rings;
  Eigen::Index at(int ring, int k) const { return Eigen::Index(ring) * m + ((k % m) + m) % m; }
};

inline Tube tube(int m, int rings, double jitter, unsigned seed) {
  Tube t{Points<double>(Eigen::Index(m) * rings, 3), Triangles(2 * Eigen::Index(m) * (rings - 1), 3), m, rings};
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int r = 0; r < rings; ++r)
    for (int k = 0; k < m; ++k) {
      const double a = 2 * std::numbers::pi * k / m, x = 2.0 * r / (rings - 1);
      const bool end = r == 0 || r == rings - 1;
      t.v.row(t.at(r, k)) << x + (end ? 0 : jitter * u(g)), 0.3 * std::cos(a) + jitter * u(g),
          0.3 * std::sin(a) + jitter * u(g);
    }
  Eigen::Index f = 0;
  for (int r = 0; r + 1 < rings; ++r)
    for (int k = 0; k < m; ++k) {
      t.f.row(f++) << int(t.at(r, k)), int(t.at(r + 1, k)), int(t.at(r + 1, k + 1));
      t.f.row(f++) << int(t.at(r, k)), int(t.at(r + 1, k + 1)), int(t.at(r, k + 1));
    }
  return t;
}

/// The two end rings: the constrained vertices.
inline std::vector<Eigen::Index> ends(const Tube& t) {
  std::vector<Eigen::Index> c;
  for (int k = 0; k < t.m; ++k) c.push_back(t.at(0, k));
  for (int k = 0; k < t.m; ++k) c.push_back(t.at(t.rings - 1, k));
  return c;
}

/// Targets: the far end turned by `angle` about x and lifted by `lift`; the near end fixed.
inline Points<double> end_targets(const Tube& t, double angle, double lift) {
  const std::vector<Eigen::Index> c = ends(t);
  Points<double> q(Eigen::Index(c.size()), 3);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitX()).toRotationMatrix();
  for (std::size_t k = 0; k < c.size(); ++k) {
    const Eigen::Vector3d p = t.v.row(c[k]).transpose();
    const Eigen::Vector3d to = k < std::size_t(t.m) ? p : Eigen::Vector3d(R * p + Eigen::Vector3d(0, lift, 0));
    q.row(Eigen::Index(k)) = to.transpose();
  }
  return q;
}

using MatrixLD = Eigen::Matrix<LD, Eigen::Dynamic, Eigen::Dynamic>;

/// The edge weights w_ij of arap.hpp (cotangents halved per triangle, clamped at zero, plus 1e-6 of the mean
/// on every edge), dense n x n, in long double.
inline MatrixLD cotangent_weights(const Tube& t) {
  const Eigen::Index n = t.v.rows();
  Eigen::Matrix<LD, Eigen::Dynamic, Eigen::Dynamic> W = Eigen::Matrix<LD, Eigen::Dynamic, Eigen::Dynamic>::Zero(n, n);
  Eigen::Matrix<LD, Eigen::Dynamic, Eigen::Dynamic> E = W;
  for (Eigen::Index f = 0; f < t.f.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = t.f(f, k), b = t.f(f, (k + 1) % 3), c = t.f(f, (k + 2) % 3);
      const Eigen::Matrix<LD, 3, 1> u = (t.v.row(a) - t.v.row(c)).transpose().cast<LD>(),
                                    w = (t.v.row(b) - t.v.row(c)).transpose().cast<LD>();
      const LD cot = u.dot(w) / u.cross(w).norm();
      W(a, b) += cot / 2, W(b, a) += cot / 2, E(a, b) = E(b, a) = 1;
    }
  LD sum = 0, edges = 0;
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = i + 1; j < n; ++j)
      if (E(i, j) > 0) W(i, j) = W(j, i) = std::max<LD>(W(i, j), 0), sum += W(i, j), ++edges;
  const LD floor = 1e-6L * sum / edges;
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j)
      if (E(i, j) > 0) W(i, j) += floor;
  return W;
}

/// The reduced cotangent Laplacian of the free vertices (all but the end rings), dense, in long double.
inline MatrixLD reduced_laplacian(const Tube& t) {
  const MatrixLD W = cotangent_weights(t);
  std::vector<Eigen::Index> free;
  for (int r = 1; r + 1 < t.rings; ++r)
    for (int k = 0; k < t.m; ++k) free.push_back(t.at(r, k));
  const auto nf = Eigen::Index(free.size());
  Eigen::Matrix<LD, Eigen::Dynamic, Eigen::Dynamic> L(nf, nf);
  for (Eigen::Index a = 0; a < nf; ++a)
    for (Eigen::Index b = 0; b < nf; ++b)
      L(a, b) = a == b ? W.row(free[std::size_t(a)]).sum() : -W(free[std::size_t(a)], free[std::size_t(b)]);
  return L;
}

struct Conditioning {
  LD lambda_min, kappa;
};

inline Conditioning conditioning(const Tube& t) {
  const auto L = reduced_laplacian(t);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<LD, Eigen::Dynamic, Eigen::Dynamic>> es(L);
  return {es.eigenvalues()(0), es.eigenvalues()(L.rows() - 1) / es.eigenvalues()(0)};
}

/// The tube moved rigidly (a fixed rotation and shift), and the constrained vertices' targets on that motion.
struct RigidMotion {
  Points<double> moved, targets;
};

inline RigidMotion rigid_motion(const Tube& t, const std::vector<Eigen::Index>& constrained) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Vector3d shift(0.5, -1, 2);
  RigidMotion m{Points<double>(t.v.rows(), 3), Points<double>(Eigen::Index(constrained.size()), 3)};
  for (Eigen::Index i = 0; i < t.v.rows(); ++i) m.moved.row(i) = (R * t.v.row(i).transpose() + shift).transpose();
  for (std::size_t k = 0; k < constrained.size(); ++k) m.targets.row(Eigen::Index(k)) = m.moved.row(constrained[k]);
  return m;
}

}  // namespace mlsdeform::arap_test
