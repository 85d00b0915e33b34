// See figures.hpp: the centroids that Fig. 5 and Fig. 8 draw.
#include "tools/cli/figures/figures.hpp"

#include <Eigen/QR>

#include <algorithm>
#include <cmath>

namespace mlsdeform::cli {

Points<double> weighted_centroids(const Points<double>& vertices, const Handles<double>& rest,
                                  const Handles<double>& moved_h, double u) {
  Points<double> out(vertices.rows(), 3);
  for (Eigen::Index i = 0; i < vertices.rows(); ++i) {
    const Eigen::Vector3d v = vertices.row(i).transpose();
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double wsum = 0;
    bool exact = false;
    for (Eigen::Index k = 0; k < rest.point_count() && !exact; ++k) {
      const double d = (rest.points.row(k).transpose() - v).norm();
      if (d == 0) {
        out.row(i) = moved_h.points.row(k);
        exact = true;
        break;
      }
      const double w = std::pow(d, -u);
      sum += w * moved_h.points.row(k).transpose();
      wsum += w;
    }
    for (Eigen::Index k = 0; k < rest.segment_count() && !exact; ++k) {
      const Eigen::Vector3d a = rest.segment_a.row(k).transpose(), b = rest.segment_b.row(k).transpose();
      const double t = std::clamp((v - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      const double d = (a + t * (b - a) - v).norm();
      const Eigen::Vector3d mid = (moved_h.segment_a.row(k) + moved_h.segment_b.row(k)).transpose() / 2;  // Sec. 6.2
      if (d == 0) {
        out.row(i) = mid.transpose();
        exact = true;
        break;
      }
      const double w = std::pow(d, -u);
      sum += w * mid;
      wsum += w;
    }
    if (!exact) out.row(i) = (sum / wsum).transpose();
  }
  return out;
}

Points<double> rbf_centroids(const Points<double>& vertices, const Handles<double>& rest,
                             const Handles<double>& moved_h, double u) {
  const Eigen::Index m = rest.point_count();
  const auto phi = [](double r) { return r; };
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(m + 4, m + 4), rhs = Eigen::MatrixXd::Zero(m + 4, 3);
  for (Eigen::Index i = 0; i < m; ++i) {
    for (Eigen::Index j = 0; j < m; ++j) M(i, j) = phi((rest.points.row(i) - rest.points.row(j)).norm());
    M(i, m) = M(m, i) = 1;
    for (int c = 0; c < 3; ++c) M(i, m + 1 + c) = M(m + 1 + c, i) = rest.points(i, c);
    rhs.row(i) = moved_h.points.row(i);
  }
  const Eigen::MatrixXd coef = M.completeOrthogonalDecomposition().solve(rhs);
  const Points<double> p_star = weighted_centroids(vertices, rest, rest, u);
  Points<double> out(vertices.rows(), 3);
  for (Eigen::Index v = 0; v < vertices.rows(); ++v) {
    Eigen::RowVector3d g = coef.row(m) + p_star.row(v) * coef.bottomRows(3);
    for (Eigen::Index j = 0; j < m; ++j) g += phi((p_star.row(v) - rest.points.row(j)).norm()) * coef.row(j);
    out.row(v) = g;
  }
  return out;
}

}  // namespace mlsdeform::cli
