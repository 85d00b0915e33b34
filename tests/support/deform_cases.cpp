// See deform_cases.hpp.
#include "tests/support/deform_cases.hpp"

#include "tests/support/meshes.hpp"

#include <cmath>
#include <numbers>
#include <utility>

namespace mlsdeform::testing {

Points<double> twist(const Points<double>& rest_vertices, const Points<double>& handles) {
  const Eigen::Vector3d lo = rest_vertices.colwise().minCoeff(), hi = rest_vertices.colwise().maxCoeff();
  int axis;
  const double length = (hi - lo).maxCoeff(&axis);
  const Eigen::Vector3d centre = (lo + hi) / 2;
  const int u = (axis + 1) % 3, w = (axis + 2) % 3;
  Points<double> q = handles;
  for (Eigen::Index i = 0; i < handles.rows(); ++i) {
    const double t = length > 0 ? (handles(i, axis) - lo(axis)) / length : 0.0;  // 0 .. 1 along the axis
    const double angle = std::numbers::pi / 2 * t;
    const double x = handles(i, u) - centre(u), y = handles(i, w) - centre(w);
    q(i, u) = centre(u) + std::cos(angle) * x - std::sin(angle) * y + 0.1 * length * t * t;
    q(i, w) = centre(w) + std::sin(angle) * x + std::cos(angle) * y;
  }
  return q;
}

DeformCase<double> twisted_mesh_case(std::string name, Points<double> vertices, Eigen::Index handle_count,
                                     std::uint64_t seed) {
  DeformCase<double> s;
  s.name = std::move(name);
  s.rest.points = random_subset(vertices, handle_count, seed);
  s.moved.points = twist(vertices, s.rest.points);
  s.vertices = std::move(vertices);
  return s;
}

}  // namespace mlsdeform::testing
