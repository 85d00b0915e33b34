// Frames after the ARAP refinement (FramesOut with Options::arap_iterations > 0): the refined local rotations.
// A rigid motion of every handle of the tube (tests/test_arap_common.hpp) leaves it rigid, so every vertex's
// rotation is that motion's, to a bound derived from the one-ring's deviation from rigidity and its
// conditioning, computed here independently in long double.
#include "tests/support/accuracy_bounds.hpp"
#include "tests/test_arap_common.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

using namespace mlsdeform;
using namespace mlsdeform::arap_test;

TEMPLATE_TEST_CASE("frames: ARAP's refined rotations of a rigid motion are that rotation", "[frames][arap]", float,
                   double) {
  using T = TestType;
  const Tube t = tube(12, 9, 0.02, 3);
  const std::vector<Eigen::Index> c = ends(t);
  const Eigen::Matrix3d R0 = Eigen::AngleAxisd(2.5, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Vector3d shift(0.5, -1, 2);
  Handles<T> rest, moved;
  rest.points.resize(Eigen::Index(c.size()), 3);
  for (std::size_t k = 0; k < c.size(); ++k) rest.points.row(Eigen::Index(k)) = t.v.row(c[k]).template cast<T>();
  moved.points = rest.points;
  for (Eigen::Index k = 0; k < moved.points.rows(); ++k)
    moved.points.row(k) =
        (R0 * rest.points.row(k).template cast<double>().transpose() + shift).template cast<T>().transpose();
  Options o;
  o.arap_iterations = 4;
  const Deformer<T> d(t.v.template cast<T>(), t.f, rest, o);
  Points<T> out, plain;
  const Eigen::Index n = t.v.rows();
  const auto nv = std::size_t(n);
  std::vector<T> q(4 * nv), r(9 * nv), s(nv), l(9 * nv);
  d.deform(moved, out, FramesOut<T>{q, r, s, l});
  d.deform(moved, plain);
  CHECK(std::memcmp(out.data(), plain.data(), std::size_t(out.size()) * sizeof(T)) == 0);
  CHECK(l == r);
  CHECK(std::all_of(s.begin(), s.end(), [](T x) { return x == T(1); }));
  // Quaternions alone (the session's scratch holds R) give the same quaternions.
  std::vector<T> q_alone(q.size());
  d.deform(moved, out, FramesOut<T>{q_alone, {}, {}, {}});
  CHECK(q_alone == q);
  // One thread gives the same bits as all of them.
  Options o1 = o;
  o1.threads = 1;
  std::vector<T> r1(r.size());
  Deformer<T>(t.v.template cast<T>(), t.f, rest, o1).deform(moved, out, FramesOut<T>{{}, r1, {}, {}});
  CHECK(r1 == r);

  // Bound. The refiner's S_i = sum_j w_ij (x_i - x_j)(p_i - p_j)^T, with x the refined positions, is
  // R0 C_i + E_i, C_i = sum_j w_ij p_ij p_ij^T (symmetric, positive semi-definite: its polar factor is I)
  // and E_i = sum_j w_ij e_ij p_ij^T, e_ij = (x_i - x_j) - R0 p_ij the ring's deviation from the motion,
  // measured here from the returned positions. The refiner fits from its own positions in double, which
  // the returned ones round to T: each e_ij is off by at most sqrt(3) eps |x|_max (two roundings of half an
  // eps per coordinate), so |dE_i|_F <= sqrt(3) eps |x|_max sum_j w_ij |p_ij|. S_i is then rounded to T and
  // fitted with the backward error 16 eps |S_i|_F (accuracy_bounds.hpp); so, first order (polar factor
  // perturbation, mls_reference.hpp), with the gap s2 + s3 of C_i,
  //   |R_i - R0|_F <= 2 (|E_i|_F + sqrt(3) eps |x|_max sum_j w_ij |p_ij| + 17 eps |S_i|_F) / gap + 1.5 c_o eps.
  const MatrixLD W = cotangent_weights(t);
  const LD eps = std::numeric_limits<T>::epsilon();
  const LD xmax = LD(out.cwiseAbs().maxCoeff());
  const Eigen::Matrix<LD, 3, 3> R0l = R0.cast<LD>();
  Eigen::Index failures = 0;
  LD worst = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    Eigen::Matrix<LD, 3, 3> C = Eigen::Matrix<LD, 3, 3>::Zero(), E = C;
    LD arm = 0;
    for (Eigen::Index j = 0; j < n; ++j) {
      if (W(i, j) == 0) continue;
      const Eigen::Matrix<LD, 3, 1> p = (t.v.row(i) - t.v.row(j)).transpose().cast<LD>();
      const Eigen::Matrix<LD, 3, 1> x = (out.row(i) - out.row(j)).transpose().template cast<LD>();
      C += W(i, j) * p * p.transpose();
      E += W(i, j) * (x - R0l * p) * p.transpose();
      arm += W(i, j) * p.norm();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<LD, 3, 3>> es(C);
    const LD gap = es.eigenvalues()(1) + es.eigenvalues()(0);  // ascending: s2 + s3
    const LD tol = 2 * (E.norm() + std::sqrt(LD(3)) * eps * xmax * arm + 17 * eps * (R0l * C + E).norm()) / gap +
                   LD(1.5) * testing::c_o * eps;
    Eigen::Matrix<LD, 3, 3> R;
    for (int k = 0; k < 9; ++k) R(k / 3, k % 3) = LD(r[9 * std::size_t(i) + std::size_t(k)]);
    const LD dev = (R - R0l).norm();
    worst = std::max(worst, dev / tol);
    if (!(dev <= tol)) ++failures;
  }
  INFO("worst deviation / bound " << double(worst));
  CHECK(failures == 0);
}
