// Centroids::rbf (paper Sec. 7-8), q* = g(p*): the interpolant g alone (interpolation, affine reproduction,
// coincident centres), and in the deformer (identity, interpolation, affine maps, SIMD against scalar,
// threads, the kernel a Deformer takes), with each kernel of core/src/deformer/rbf_centroids.hpp. The bounds
// and their derivation are in test_rbf_common.hpp; a motion of the whole scene is in
// test_rbf_centroids_motion.cpp.
#include "tests/test_rbf_common.hpp"

#include <cstring>
#include <random>
#include <vector>

using namespace rbf_test;

namespace {

std::vector<Vec3d> random_centres(std::mt19937_64& g, int J) {
  std::vector<Vec3d> P;
  for (int j = 0; j < J; ++j) P.push_back(random_vector(g));
  return P;
}

}  // namespace

TEST_CASE("RBF centroids: g interpolates the handles and reproduces affine maps", "[rbf]") {
  std::mt19937_64 g(seed());
  for (int J : {1, 2, 3, 4, 7, 20}) {
    for (RbfKernel kernel : {RbfKernel::r, RbfKernel::r3}) {
      const std::vector<Vec3d> P = random_centres(g, J);
      const RbfCentroids rbf(P, kernel);
      const double kappa = double(kappa_of(P, kernel));
      INFO("J = " << J << ", kernel " << kernel_name(kernel) << ", kappa(M) = " << kappa);
      std::vector<double> beta;
      Eigen::VectorXd rhs;
      // Interpolation: beta(p_i) = e_i to the solve's accuracy, (J + 4) eps kappa(M) relative to sum |beta|.
      for (int i = 0; i < J; ++i) {
        rbf.weights(P[std::size_t(i)], beta, rhs);
        double B = 0;
        for (double x : beta) B += std::abs(x);
        for (int j = 0; j < J; ++j)
          CHECK(std::abs(beta[std::size_t(j)] - (i == j ? 1.0 : 0.0)) <=
                (J + 4) * std::numeric_limits<double>::epsilon() * kappa * B);
      }
      // Affine reproduction at points of the centres' convex hull (where p* lies): sum_j beta_j (A p_j + b) = A x + b.
      Mat3d A;
      for (int c = 0; c < 3; ++c) A.col(c) = random_vector(g);
      const Vec3d b = random_vector(g);
      for (int trial = 0; trial < 5; ++trial) {
        Vec3d x = Vec3d::Zero();
        double W = 0;
        for (int j = 0; j < J; ++j) {
          const double w = std::uniform_real_distribution<double>(0, 1)(g);
          x += w * P[std::size_t(j)], W += w;
        }
        x /= W;
        rbf.weights(x, beta, rhs);
        Vec3d q = Vec3d::Zero();
        double B = 0;
        for (int j = 0; j < J; ++j)
          q += beta[std::size_t(j)] * (A * P[std::size_t(j)] + b), B += std::abs(beta[std::size_t(j)]);
        const double scale = (A.norm() * 2 + b.norm()) * B;
        CHECK((q - (A * x + b)).norm() <= (J + 4) * std::numeric_limits<double>::epsilon() * kappa * scale * 4);
      }
    }
  }
}

TEST_CASE("RBF centroids: coincident handles share a centre, nearly coincident ones are refused", "[rbf]") {
  std::vector<Vec3d> P = {Vec3d(0, 0, 0), Vec3d(1, 0, 0), Vec3d(0, 1, 0), Vec3d(1, 0, 0)};
  const RbfCentroids rbf(P);
  std::vector<double> beta;
  Eigen::VectorXd rhs;
  rbf.weights(Vec3d(1, 0, 0), beta, rhs);
  CHECK(beta[3] == 0.0);  // the second handle at (1, 0, 0) gets no weight: the first one's target counts
  // Two centres d apart give two rows of M that differ by about d (phi is 1-Lipschitz at this scale for r,
  // 3-Lipschitz for r^3; the affine columns differ by d), against entries of order 1: rcond(M) is of order d,
  // so d = 1e-12 falls below the constructor's 1e-10 under either kernel (at d = 1e-9, r's rcond is above it).
  P.push_back(Vec3d(1e-12, 0, 0));
  for (const RbfKernel kernel : {RbfKernel::r, RbfKernel::r3})
    CHECK_THROWS_WITH(RbfCentroids(P, kernel), Catch::Matchers::ContainsSubstring("nearly coincident"));
}

TEMPLATE_TEST_CASE("RBF centroids in the deformer: identity, interpolation, affine maps reproduced", "[rbf][deformer]",
                   float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  const RbfKernel kernel = GENERATE(RbfKernel::r, RbfKernel::r3);
  const mlsdeform::detail::ScopedRbfKernel scoped(kernel);
  INFO("kernel " << kernel_name(kernel));
  for (int trial = 0; trial < 3; ++trial) {
    const DeformCase<T> sc = random_case<T>(g, 250, 6 + 2 * trial, 0);
    const Mat3d R = random_rotation(g);
    const Vec3d t = random_vector(g, -2, 2);
    Mat3d N;
    for (int c = 0; c < 3; ++c) N.col(c) = random_vector(g);
    for (Transform tr : all_transforms) {
      Options o;
      o.transform = tr;
      o.centroids = Centroids::rbf;
      const Deformer<T> def(sc.vertices, sc.rest, o);
      const Mat3d map = tr == Transform::affine ? Mat3d(R * (Mat3d::Identity() + 0.4 * N)) : R;
      for (const Mat3d& M : {Mat3d(Mat3d::Identity()), map}) {
        const Handles<T> moved = transformed(sc.rest, M, t * (M == Mat3d::Identity() ? 0.0 : 1.0));
        const Vec3d shift = M == Mat3d::Identity() ? Vec3d::Zero() : t;
        Points<T> out;
        def.deform(moved, out);
        INFO(name(tr) << " trial " << trial << "\n" << M);
        // Vertices on handles: exactly their targets.
        for (Eigen::Index i = 0; i < sc.rest.points.rows(); ++i)
          for (Eigen::Index v = 0; v < sc.vertices.rows(); ++v)
            if (sc.vertices.row(v) == sc.rest.points.row(i)) CHECK(out.row(v) == moved.points.row(i));
        const double extra =
            rbf_extra(sc, moved) + 8 * std::numeric_limits<double>::epsilon() * (M.norm() * 2 + shift.norm());
        const double l = scene_size(sc.vertices, sc.rest);
        for (Eigen::Index i = 0; i < sc.vertices.rows(); ++i) {
          const Vec3d v = sc.vertices.row(i).transpose().template cast<double>();
          const DirectVertex d = direct_vertex(v, sc.rest, moved, o, l);
          const double bound = std::numeric_limits<T>::epsilon() * d.bound_unit + extra;
          const double dev = (out.row(i).transpose().template cast<double>() - (M * v + shift)).norm();
          INFO("vertex " << i << " deviation " << dev << " bound " << bound);
          REQUIRE(dev <= bound);
        }
      }
    }
  }
}

TEMPLATE_TEST_CASE("RBF centroids: SIMD agrees with scalar, threads bitwise, on-the-fly refused", "[rbf][deformer]",
                   float, double) {
  using T = TestType;
  std::mt19937_64 g(seed() + 1);
  const DeformCase<T> sc = random_case<T>(g, 700, 9, 0);
  Handles<T> moved = sc.rest;
  moved.points.row(0).array() += T(0.8);  // a large move: where RBF and MLS centroids differ most
  Options o;
  o.centroids = Centroids::rbf;
  o.isa = Isa::scalar;
  Points<T> scalar, simd, mls, two;
  Deformer<T>(sc.vertices, sc.rest, o).deform(moved, scalar);
  o.isa = std::nullopt;
  o.threads = 1;
  Deformer<T>(sc.vertices, sc.rest, o).deform(moved, simd);
  o.threads = 2;
  Deformer<T>(sc.vertices, sc.rest, o).deform(moved, two);
  CHECK(std::memcmp(simd.data(), two.data(), sizeof(T) * std::size_t(simd.size())) == 0);
  // q* is the same sum in both paths; the rotations differ as in the SIMD deformer test (256 eps there,
  // derived in tests/test_deformer_simd.cpp).
  CHECK((simd - scalar).cwiseAbs().maxCoeff() <= T(256) * std::numeric_limits<T>::epsilon());
  o.centroids = Centroids::mls;
  Deformer<T>(sc.vertices, sc.rest, o).deform(moved, mls);
  CHECK((simd - mls).cwiseAbs().maxCoeff() > T(1e-3));  // the option changes the result
  o.centroids = Centroids::rbf;
  o.weight_storage = WeightStorage::on_the_fly;
  CHECK_THROWS_WITH(Deformer<T>(sc.vertices, sc.rest, o), Catch::Matchers::ContainsSubstring("Centroids::rbf"));
}

TEST_CASE("RBF centroids: a Deformer takes the kernel set when it is constructed", "[rbf][deformer]") {
  std::mt19937_64 g(seed() + 2);
  const DeformCase<double> sc = random_case<double>(g, 300, 7, 0);
  Handles<double> moved = sc.rest;
  moved.points.row(0).array() += 0.8;
  Options o;
  o.centroids = Centroids::rbf;
  const RbfKernel before = mlsdeform::detail::rbf_kernel();
  CHECK(before == RbfKernel::r);  // the library's kernel (rbf_centroids.cpp)
  Points<double> r, r3, again;
  Deformer<double>(sc.vertices, sc.rest, o).deform(moved, r);
  {
    const mlsdeform::detail::ScopedRbfKernel scoped(RbfKernel::r3);
    const Deformer<double> d(sc.vertices, sc.rest, o);
    mlsdeform::detail::set_rbf_kernel(RbfKernel::r);  // read at construction only: d keeps r^3
    d.deform(moved, r3);
  }
  CHECK(mlsdeform::detail::rbf_kernel() == before);
  Deformer<double>(sc.vertices, sc.rest, o).deform(moved, again);
  CHECK((r - r3).cwiseAbs().maxCoeff() > 1e-3);  // the kernels give different q*
  CHECK(std::memcmp(again.data(), r.data(), sizeof(double) * std::size_t(r.size())) == 0);
}
