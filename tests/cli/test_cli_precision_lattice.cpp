// `--precision double` through the program on a survey-grade lattice (coordinates of magnitude 10^6 with
// millimetre detail) that nothing moves: the handles come back exactly, and every other vertex within the
// bound that the rounding of the double computation allows (tests/support/accuracy_bounds.hpp).
#include "tests/cli/cli_test_util.hpp"
#include "tests/cli/precision_files.hpp"
#include "tests/support/accuracy_bounds.hpp"

#include "core/files/mesh.hpp"

#include "tests/support/catch.hpp"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <limits>

using namespace mlsdeform;
using namespace mlsdeform::files;
using namespace precision_test;
using cli_test::ScratchDir;
using cli_test::write_text;

namespace {

// The spacing of doubles at |x|.
double ulp(double x) { return std::nextafter(std::abs(x), std::numeric_limits<double>::infinity()) - std::abs(x); }

}  // namespace

TEST_CASE("a survey-grade lattice moved by nothing: handles exact and the rest within the rounding bound",
          "[cli][precision]") {
  // A 5 x 5 x 5 lattice near (5e6, 4e6, 100) with its 8 corners as handles at rest: the exact MLS result is
  // every vertex where it was (q_j = p_j: q* = p*, and R = I maximises trace(R^T H) for H = sum w phat phat^T,
  // symmetric positive semi-definite). The computed one differs by
  //   - the rotation's angle error, at most tol_angle(kappa) (tests/support/accuracy_bounds.hpp; kappa =
  //     s1 / (s2 + s3) of this H), which moves the vertex by at most that times |v - p*|;
  //   - q* = sum_j omega_j q_j summed in world coordinates: k products and k - 1 additions of terms up to
  //     max_j |q_j| (omega_j >= 0, sum 1), plus the rounding of omega_j itself (a few eps each): at most
  //     (k + 8) eps max_j |q_j,c| per coordinate c, and a half ulp for q* + R vhat;
  //   - vhat and p* in the deformer's local frame (coordinates up to the bounding-box diagonal): 16 eps diag.
  // Float precision, for scale: floats near 5e6 are 0.5 apart, 10^8 times this bound.
  ScratchDir dir;
  Rows v(125, 3);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> jitter(-0.5, 0.5);
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j)
      for (int k = 0; k < 5; ++k)
        v.row(25 * i + 5 * j + k) << std::round((5000000 + 2.5 * i + jitter(rng)) * 1000) / 1000,
            std::round((4000000 + 2.5 * j + jitter(rng)) * 1000) / 1000,
            std::round((100 + 0.75 * k + 0.2 * jitter(rng)) * 1000) / 1000;
  std::string obj;
  for (Eigen::Index i = 0; i < v.rows(); ++i)
    obj += "v " + shortest(v(i, 0)) + " " + shortest(v(i, 1)) + " " + shortest(v(i, 2)) + "\n";
  write_text(dir / "lattice.obj", obj);
  std::vector<int> corners;
  std::string json = R"({"points": [)";
  for (int i : {0, 4})
    for (int j : {0, 4})
      for (int k : {0, 4}) {
        corners.push_back(25 * i + 5 * j + k);
        json += (corners.size() > 1 ? ", " : "") + std::string(R"({"vertex": )") + std::to_string(corners.back()) + "}";
      }
  write_text(dir / "h.json", json + "]}");
  const auto r =
      deform({"-m", dir / "lattice.obj", "-H", dir / "h.json", "-o", dir / "out.obj", "--precision", "double"});
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const auto out = read_mesh<double>(dir / "out.obj").vertices;

  constexpr double eps = std::numeric_limits<double>::epsilon();
  const double k = double(corners.size());
  const Eigen::RowVector3d lo = v.colwise().minCoeff(), hi = v.colwise().maxCoeff();
  const double diag = (hi - lo).norm();
  Eigen::RowVector3d q_max = Eigen::RowVector3d::Zero();
  for (int c : corners) q_max = q_max.cwiseMax(v.row(c).cwiseAbs());
  for (Eigen::Index i = 0; i < v.rows(); ++i) {
    INFO("vertex " << i);
    if (std::find(corners.begin(), corners.end(), int(i)) != corners.end()) {
      CHECK(out.row(i) == v.row(i));  // put exactly on its target
      continue;
    }
    // The weights w_j = |p_j - v|^-2 (u = 2), p*, and H's singular values (its eigenvalues: H is PSD).
    Eigen::RowVector3d p_star = Eigen::RowVector3d::Zero();
    double w_sum = 0;
    std::vector<double> w;
    for (int c : corners) {
      w.push_back(1 / (v.row(c) - v.row(i)).squaredNorm());
      w_sum += w.back();
      p_star += w.back() * v.row(c);
    }
    p_star /= w_sum;
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    for (std::size_t j = 0; j < corners.size(); ++j) {
      const Eigen::Vector3d ph = (v.row(corners[j]) - p_star).transpose();
      H += w[j] * ph * ph.transpose();
    }
    const Eigen::Vector3d s = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(H).eigenvalues();  // ascending
    const double kappa = s[2] / (s[1] + s[0]);
    const double angle = double(testing::tol_angle<double>(kappa, testing::c_b_uniform));
    for (int c = 0; c < 3; ++c) {
      const double bound =
          angle * (v.row(i) - p_star).norm() + (k + 8) * eps * q_max[c] + 0.5 * ulp(v(i, c)) + 16 * eps * diag;
      const double error = std::abs(out(i, c) - v(i, c));
      INFO("coordinate " << c << ": error " << error << ", bound " << bound << ", kappa " << kappa);
      CHECK(error <= bound);
    }
  }
}
