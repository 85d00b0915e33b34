#include "core/src/deformer/rbf_centroids.hpp"

#include "core/src/deformer/validation.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdio>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>

namespace mlsdeform::detail {

namespace {
// phi(r) = r rather than r^3, by `bench_quality --centroids` (the tables: docs/notes/rbf_centroids.md):
// - conditioning: kappa(M) is 3.3e3 against 6.4e6 on Fig. 8's plane, 91 against 4.2e3 on the human, 6.7e4
//   against 1.4e9 on the bar's 578 cap handles, and grows faster with r^3 as handles crowd (halving the
//   caps' spacing: x7 with r, x30 with r^3). The weights' error bound (J + 4) eps kappa(M) is 9e-9 against
//   2e-4 on the bar, and with its caps cut 1.5 times finer (1250 handles, 0.67 units apart) r^3's rcond
//   falls below the 1e-10 at which the constructor below refuses the handles.
// - shape, human bend: r is better on every measure (local rigidity median / p95 0.195 / 0.426 against
//   0.252 / 0.529; dihedral-angle change p95 / max 12.1 / 69 against 15.2 / 89 degrees).
// - shape, Fig. 8's plane: r^3 is smoother (dihedral p95 / max 12.7 / 47.5 against 14.7 / 51.9 degrees;
//   MLS centroids: 17.1 / 100.4). Bar twist: equal within 6% either way. Fish (4 handles): identical, g is
//   the affine map there whatever the kernel.
// - per-frame time: the same (the weights are precomputed; the solve per vertex has the same size).
std::atomic<RbfKernel> g_kernel{RbfKernel::r};
}  // namespace

RbfKernel rbf_kernel() { return g_kernel.load(std::memory_order_relaxed); }
void set_rbf_kernel(RbfKernel kernel) { g_kernel.store(kernel, std::memory_order_relaxed); }

RbfCentroids::RbfCentroids(const std::vector<Eigen::Vector3d>& P, RbfKernel kernel) : kernel_(kernel) {
  std::map<std::array<double, 3>, std::size_t> seen;
  for (std::size_t j = 0; j < P.size(); ++j) {
    const auto [it, added] = seen.try_emplace({P[j][0], P[j][1], P[j][2]}, centres_.size());
    if (added) centres_.push_back(P[j]), owner_.push_back(j);
    centre_of_.push_back(it->second);
  }
  const auto m = Eigen::Index(centres_.size());
  mean_ = Eigen::Vector3d::Zero();
  for (const auto& c : centres_) mean_ += c;
  mean_ /= double(m);
  // The span of the centred centres: singular directions above the usual rank tolerance.
  Eigen::Matrix<double, Eigen::Dynamic, 3> X(m, 3);
  for (Eigen::Index i = 0; i < m; ++i) X.row(i) = (centres_[std::size_t(i)] - mean_).transpose();
  Eigen::Matrix3d V;
  const Eigen::Vector3d sv = singular_values(X, &V);
  const double tol = double(std::max<Eigen::Index>(m, 3)) * std::numeric_limits<double>::epsilon() * sv(0);
  Eigen::Index rank = 0;
  while (rank < 3 && sv(rank) > tol) ++rank;
  basis_ = V.leftCols(rank);
  lu_.compute(matrix());
  const double rcond = lu_.rcond();
  if (!(rcond > 1e-10)) {
    char msg[256];
    std::snprintf(msg, sizeof msg,
                  "Deformer: Centroids::rbf needs handles that are not nearly coincident (the interpolant's matrix "
                  "has reciprocal condition %.3g, below 1e-10)",
                  rcond);
    throw std::invalid_argument(msg);
  }
}

Eigen::MatrixXd RbfCentroids::matrix() const {
  const auto m = Eigen::Index(centres_.size()), rank = basis_.cols();
  const Eigen::Index size = m + 1 + rank;
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(size, size);
  for (Eigen::Index i = 0; i < m; ++i) {
    for (Eigen::Index j = 0; j < m; ++j)
      M(i, j) = phi(kernel_, (centres_[std::size_t(i)] - centres_[std::size_t(j)]).norm());
    M(i, m) = M(m, i) = 1;
    const Eigen::VectorXd y = basis_.transpose() * (centres_[std::size_t(i)] - mean_);
    for (Eigen::Index c = 0; c < rank; ++c) M(i, m + 1 + c) = M(m + 1 + c, i) = y(c);
  }
  return M;
}

void RbfCentroids::weights(const Eigen::Vector3d& p_star, std::vector<double>& beta, Eigen::VectorXd& rhs) const {
  const auto m = Eigen::Index(centres_.size()), rank = basis_.cols();
  rhs.resize(m + 1 + rank);
  for (Eigen::Index i = 0; i < m; ++i) rhs(i) = phi(kernel_, (p_star - centres_[std::size_t(i)]).norm());
  rhs(m) = 1;
  rhs.tail(rank) = basis_.transpose() * (p_star - mean_);
  const Eigen::VectorXd w = lu_.solve(rhs);
  beta.assign(centre_of_.size(), 0.0);
  for (Eigen::Index i = 0; i < m; ++i) beta[owner_[std::size_t(i)]] = w(i);
}

}  // namespace mlsdeform::detail
