// See quality.hpp.
#include "tests/support/quality.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace mlsdeform::testing {

std::vector<std::vector<int>> one_rings(Eigen::Index vertex_count, const Triangles& triangles) {
  std::vector<std::vector<int>> ring(static_cast<std::size_t>(vertex_count));
  for (Eigen::Index f = 0; f < triangles.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = triangles(f, c), b = triangles(f, (c + 1) % 3);
      ring[static_cast<std::size_t>(a)].push_back(b);
      ring[static_cast<std::size_t>(b)].push_back(a);
    }
  for (auto& r : ring) {
    std::sort(r.begin(), r.end());
    r.erase(std::unique(r.begin(), r.end()), r.end());
  }
  return ring;
}

std::vector<std::pair<int, int>> unique_edges(const Triangles& triangles) {
  std::vector<std::pair<int, int>> e;
  e.reserve(static_cast<std::size_t>(3 * triangles.rows()));
  for (Eigen::Index f = 0; f < triangles.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = triangles(f, c), b = triangles(f, (c + 1) % 3);
      e.emplace_back(std::min(a, b), std::max(a, b));
    }
  std::sort(e.begin(), e.end());
  e.erase(std::unique(e.begin(), e.end()), e.end());
  return e;
}

double quantile(std::vector<double> values, double p) {
  if (values.empty()) throw std::invalid_argument("quantile: no values");
  std::sort(values.begin(), values.end());
  const double pos = p * static_cast<double>(values.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (pos - static_cast<double>(lo)) * (values[hi] - values[lo]);
}

ShapeQuality shape_quality(const PointsD& rest, const PointsD& deformed, const Triangles& triangles) {
  if (rest.rows() != deformed.rows())
    throw std::invalid_argument("shape_quality: rest and deformed vertex counts differ");
  const auto ring = one_rings(rest.rows(), triangles);
  ShapeQuality q;
  q.triangles = triangles.rows();
  std::vector<Eigen::Matrix3d> R(ring.size(), Eigen::Matrix3d::Identity());
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    double rest_sq = 0;
    for (const int j : ring[i]) {
      const Eigen::Vector3d e = (rest.row(j) - rest.row(ii)).transpose();
      const Eigen::Vector3d ed = (deformed.row(j) - deformed.row(ii)).transpose();
      H += ed * e.transpose();
      rest_sq += e.squaredNorm();
    }
    if (rest_sq == 0) continue;
    R[i] = fit_rotation(H);
    double residual_sq = 0;
    for (const int j : ring[i]) {
      const Eigen::Vector3d e = (rest.row(j) - rest.row(ii)).transpose();
      const Eigen::Vector3d ed = (deformed.row(j) - deformed.row(ii)).transpose();
      residual_sq += (ed - R[i] * e).squaredNorm();
    }
    q.rigidity.push_back(std::sqrt(residual_sq / rest_sq));
  }
  for (const auto& [a, b] : unique_edges(triangles)) {
    const double l = (rest.row(b) - rest.row(a)).norm();
    if (l > 0) q.edge_ratio.push_back((deformed.row(b) - deformed.row(a)).norm() / l);
  }
  auto normal = [&](const PointsD& x, Eigen::Index f) {
    const Eigen::Vector3d a = x.row(triangles(f, 0)).transpose(), b = x.row(triangles(f, 1)).transpose(),
                          c = x.row(triangles(f, 2)).transpose();
    return Eigen::Vector3d((b - a).cross(c - a));
  };
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    const Eigen::Vector3d n = normal(rest, f), nd = normal(deformed, f);
    int against = 0;
    for (int c = 0; c < 3; ++c) against += nd.dot(R[static_cast<std::size_t>(triangles(f, c))] * n) < 0;
    q.flipped += against >= 2;
  }
  return q;
}

std::vector<double> dihedral_change(const PointsD& rest, const PointsD& deformed, const Triangles& triangles) {
  const auto normal = [&](const PointsD& v, Eigen::Index f) -> Eigen::Vector3d {
    const Eigen::Vector3d a = v.row(triangles(f, 0)), b = v.row(triangles(f, 1)), c = v.row(triangles(f, 2));
    return (b - a).cross(c - a).normalized();
  };
  // atan2 of |m x n| and m . n: accurate at every angle, where acos loses half the digits near 0.
  const auto angle = [](const Eigen::Vector3d& m, const Eigen::Vector3d& n) {
    return std::atan2(m.cross(n).norm(), m.dot(n)) * 180 / std::numbers::pi;
  };
  std::vector<std::pair<std::pair<int, int>, Eigen::Index>> edge_face;
  edge_face.reserve(static_cast<std::size_t>(3 * triangles.rows()));
  for (Eigen::Index f = 0; f < triangles.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = triangles(f, c), b = triangles(f, (c + 1) % 3);
      edge_face.push_back({{std::min(a, b), std::max(a, b)}, f});
    }
  std::sort(edge_face.begin(), edge_face.end());
  std::vector<double> out;
  for (std::size_t i = 0; i < edge_face.size();) {
    std::size_t k = i;
    while (k < edge_face.size() && edge_face[k].first == edge_face[i].first) ++k;
    if (k - i == 2) {
      const Eigen::Index f = edge_face[i].second, g = edge_face[i + 1].second;
      out.push_back(
          std::abs(angle(normal(deformed, f), normal(deformed, g)) - angle(normal(rest, f), normal(rest, g))));
    }
    i = k;
  }
  return out;
}

}  // namespace mlsdeform::testing
