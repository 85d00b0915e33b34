// cotangent_one_rings (one_rings.hpp).
#include "one_rings.hpp"

#include <Eigen/Geometry>  // cross

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace mlsdeform::detail {

namespace {

using Vec3d = Eigen::Vector3d;

/// cot of the angle at c in the triangle (a, b, c), or 0 for a degenerate triangle (the sine below
/// 2^-40 of |u| |v|: the cotangent would be rounding noise, and huge).
double cotangent(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d u = a - c, v = b - c;
  const double cross = u.cross(v).norm(), scale = u.norm() * v.norm();
  if (!(cross > std::ldexp(scale, -40))) return 0;
  return u.dot(v) / cross;
}

}  // namespace

OneRings cotangent_one_rings(const Eigen::Matrix<double, Eigen::Dynamic, 3>& P, const Triangles& triangles) {
  const Eigen::Index n = P.rows();
  OneRings r;
  // Cotangent weights per undirected edge, as (min, max) pairs, merged over the triangles sharing the edge.
  std::vector<std::pair<std::pair<Eigen::Index, Eigen::Index>, double>> edges;
  edges.reserve(std::size_t(triangles.rows()) * 3);
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    for (int k = 0; k < 3; ++k)
      if (triangles(f, k) < 0 || triangles(f, k) >= n)
        throw std::invalid_argument("ArapRefiner: triangle " + std::to_string(f) + " has vertex index " +
                                    std::to_string(triangles(f, k)) + ", outside [0, " + std::to_string(n) + ")");
    for (int k = 0; k < 3; ++k) {
      const Eigen::Index a = triangles(f, k), b = triangles(f, (k + 1) % 3), c = triangles(f, (k + 2) % 3);
      if (a == b) continue;  // a repeated corner: no edge
      edges.push_back(
          {{std::min(a, b), std::max(a, b)}, a == c || b == c ? 0.0 : 0.5 * cotangent(P.row(a), P.row(b), P.row(c))});
    }
  }
  std::sort(edges.begin(), edges.end());
  std::vector<std::pair<std::pair<Eigen::Index, Eigen::Index>, double>> merged;
  for (const auto& e : edges) {
    if (!merged.empty() && merged.back().first == e.first)
      merged.back().second += e.second;
    else
      merged.push_back(e);
  }
  double sum = 0;
  for (auto& e : merged) {
    if (e.second < 0) ++r.clamped, e.second = 0;
    sum += e.second;
  }
  const double floor = merged.empty() || sum == 0 ? 1.0 : 1e-6 * sum / double(merged.size());
  for (auto& e : merged) e.second += floor;

  // CSR one-rings: both directions of every edge, sorted by (vertex, neighbour).
  std::vector<std::pair<std::pair<Eigen::Index, Eigen::Index>, double>> directed;
  directed.reserve(2 * merged.size());
  for (const auto& e : merged) {
    directed.push_back(e);
    directed.push_back({{e.first.second, e.first.first}, e.second});
  }
  std::sort(directed.begin(), directed.end());
  r.start.assign(std::size_t(n) + 1, 0);
  for (const auto& e : directed) ++r.start[std::size_t(e.first.first) + 1];
  for (std::size_t i = 0; i < std::size_t(n); ++i) r.start[i + 1] += r.start[i];
  for (const auto& e : directed) r.nbr.push_back(e.first.second), r.w.push_back(e.second);
  return r;
}

}  // namespace mlsdeform::detail
