// Weighted point-set fits (point_fit.hpp): fit_rigid and fit_similarity recover known transforms, honour
// the weights, and reject bad input with a message. Every method, float and double.
//
// Tolerances, derived as in tests/support/accuracy_bounds.hpp (c_b, c_o), with the extra rounding of the
// point pipeline. Let P = max_i |p_i|, Q = max_i |q_i|, sigma_p, sigma_q the weighted RMS spreads about the
// centroids, rho = P / sigma_p + Q / sigma_q (how far the data sit from their centroid, in spreads), n the
// number of points. q is rounded once to T (eps/2 per coordinate); each centroid is an n-term weighted sum
// (error <= n eps P, resp. Q, the classical recursive-summation bound), the centred coordinates add one
// rounding, and H is another n-term sum. Relative to ||H||_F (which is s sigma_p^2 up to the anisotropy of
// the cloud, accounted for by kappa below), the backward error of H is therefore at most
//   beta = (c_b + 2 n + 8) eps rho,
// and the bounds of accuracy_bounds.hpp become, with kappa of the exact H:
//   angle       <= 2 sqrt(3) beta kappa + (3/2) c_o eps
//   scale (rel) <= (2 sqrt(3) + 1) beta + (3/2) c_o eps   (numerator trace(R^T H), denominator sum w |phat|^2)
//   translation <= (n + 2) eps (Q + s P) + s |p*| (scale tol + angle tol) + 2 eps |t|   (t = q* - s R p*)
#include "tests/support/rotation_cases.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#include <Eigen/LU>

#include <cmath>
#include <limits>
#include <numbers>
#include <string>

using namespace mlsdeform;
using namespace mlsdeform::testing;

namespace {

constexpr long double c_b = 16;
constexpr long double c_o = 64;

template <class T>
using Vec = Eigen::Matrix<T, Eigen::Dynamic, 1>;
using PointsL = Eigen::Matrix<long double, Eigen::Dynamic, 3>;
using VecL = Eigen::Matrix<long double, Eigen::Dynamic, 1>;

/// A known similarity applied to random points; p is generated directly in T (exact), q = s R p + t is
/// computed in long double and rounded once.
template <class T>
struct Problem {
  Points<T> p, q;
  Vec<T> w;
  Matrix3L R;
  long double s = 1;
  Vector3L t;
  // Bounds (see the top of the file).
  long double tol_angle = 0, tol_scale = 0, tol_translation = 0;
};

template <class T>
Problem<T> make_problem(Rng& rng, int n, bool with_scale, bool reflect = false, long double unit = 1) {
  constexpr long double eps = std::numeric_limits<T>::epsilon();
  Problem<T> pr;
  pr.R = rng.rotation();
  pr.s = with_scale ? std::pow(10.0L, rng.uniform(-1, 1)) : 1.0L;
  pr.t = unit * Vector3L(3 * rng.gaussian(), 3 * rng.gaussian(), 3 * rng.gaussian());
  const Vector3L offset(2 * rng.gaussian(), 2 * rng.gaussian(), 2 * rng.gaussian());
  pr.p.resize(n, 3);
  pr.w.resize(n);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) pr.p(i, k) = static_cast<T>(unit * (offset(k) + rng.gaussian()));
    pr.w(i) = static_cast<T>(rng.uniform(0.1L, 1));
  }
  Matrix3L M = pr.R;
  if (reflect) M = pr.R * Vector3L(1, 1, -1).asDiagonal();
  const PointsL pl = pr.p.template cast<long double>();
  const PointsL ql = ((pr.s * (pl * M.transpose())).rowwise() + pr.t.transpose());
  pr.q = ql.template cast<T>();
  // Bounds.
  const VecL wl = pr.w.template cast<long double>();
  const long double sw = wl.sum();
  const Vector3L p_star = pl.transpose() * wl / sw, q_star = ql.transpose() * wl / sw;
  const long double sigma_p =
      std::sqrt(((pl.rowwise() - p_star.transpose()).rowwise().squaredNorm().transpose() * wl)(0) / sw);
  const long double sigma_q =
      std::sqrt(((ql.rowwise() - q_star.transpose()).rowwise().squaredNorm().transpose() * wl)(0) / sw);
  const long double P = pl.rowwise().norm().maxCoeff(), Q = ql.rowwise().norm().maxCoeff();
  const long double rho = P / sigma_p + Q / sigma_q;
  const long double beta = (c_b + 2 * n + 8) * eps * rho;
  const Reference ref = reference(correlation_matrix(pl, ql, wl));
  const long double sqrt3 = std::numbers::sqrt3_v<long double>;
  pr.tol_angle = 2 * sqrt3 * beta * ref.kappa + 1.5L * c_o * eps;
  pr.tol_scale = (2 * sqrt3 + 1) * beta + 1.5L * c_o * eps;
  pr.tol_translation =
      (n + 2) * eps * (Q + pr.s * P) + pr.s * p_star.norm() * (pr.tol_scale + pr.tol_angle) + 2 * eps * pr.t.norm();
  return pr;
}

template <class T>
long double angle_to(const Matrix3<T>& R, const Matrix3L& R_true) {
  return rotation_angle(R.template cast<long double>(), R_true);
}

template <class T>
long double distance(const Vector3<T>& a, const Vector3L& b) {
  return (a.template cast<long double>() - b).norm();
}

template <class T>
void check_transform(const SimilarityTransform<T>& x, const Problem<T>& pr, long double s_true) {
  INFO("angle " << double(angle_to(x.rotation, pr.R)) << " (tol " << double(pr.tol_angle) << "), scale "
                << double(x.scale) << " vs " << double(s_true) << ", translation error "
                << double(distance(x.translation, pr.t)) << " (tol " << double(pr.tol_translation) << ")");
  CHECK(x.rotation.allFinite());
  CHECK(x.translation.allFinite());
  CHECK(angle_to(x.rotation, pr.R) <= pr.tol_angle);
  CHECK(std::abs(x.scale - s_true) <= pr.tol_scale * s_true);
  CHECK(distance(x.translation, pr.t) <= pr.tol_translation);
  CHECK(x.rotation.template cast<long double>().determinant() > 0);
}

}  // namespace

TEMPLATE_TEST_CASE("fit_rigid and fit_similarity recover a known transform", "[point_fit]", float, double) {
  using T = TestType;
  Rng rng(kDefaultSeed);
  for (RotationMethod m : all_rotation_methods) {
    for (int trial = 0; trial < 100; ++trial) {
      const int n = rng.integer(4, 32);
      INFO(to_string(m) << " trial " << trial << " n " << n);
      const Problem<T> rigid = make_problem<T>(rng, n, false);
      check_transform(fit_rigid<T>(rigid.p, rigid.q, rigid.w, m), rigid, 1.0L);
      // fit_similarity on rigid data finds scale 1.
      check_transform(fit_similarity<T>(rigid.p, rigid.q, rigid.w, m), rigid, 1.0L);
      const Problem<T> sim = make_problem<T>(rng, n, true);
      check_transform(fit_similarity<T>(sim.p, sim.q, sim.w, m), sim, sim.s);
    }
  }
}

TEMPLATE_TEST_CASE("point fits: weights", "[point_fit]", float, double) {
  using T = TestType;
  Rng rng(kDefaultSeed + 1);
  for (RotationMethod m : all_rotation_methods) {
    INFO(to_string(m));
    const int n = 12;
    const Problem<T> pr = make_problem<T>(rng, n, true);

    {  // an empty weight vector means all ones
      const SimilarityTransform<T> ones = fit_similarity<T>(pr.p, pr.q, Vec<T>::Ones(n), m);
      const SimilarityTransform<T> empty = fit_similarity<T>(pr.p, pr.q, Vec<T>(), m);
      CHECK(empty.rotation == ones.rotation);
      CHECK(empty.translation == ones.translation);
      CHECK(empty.scale == ones.scale);
    }

    {  // a point with weight 0 is ignored, wherever it is
      Points<T> p(n + 1, 3), q(n + 1, 3);
      p << pr.p, Eigen::Matrix<T, 1, 3>(T(1e3), T(-7), T(5));
      q << pr.q, Eigen::Matrix<T, 1, 3>(T(-4e3), T(2), T(9));
      Vec<T> w(n + 1);
      w << pr.w, T(0);
      const SimilarityTransform<T> x = fit_similarity<T>(p, q, w, m);
      // The outlier contributes exact zeros (0 * x) to every weighted sum, so only the summation order may
      // differ: the known-transform bounds of the problem without it apply.
      check_transform(x, pr, pr.s);
    }

    {  // weight 2 is the same as the point given twice
      Points<T> p(n + 1, 3), q(n + 1, 3);
      p << pr.p, pr.p.row(0);
      q << pr.q, pr.q.row(0);
      Vec<T> w_dup(n + 1), w2 = pr.w;
      w_dup << pr.w, pr.w(0);
      w2(0) *= 2;
      const SimilarityTransform<T> a = fit_similarity<T>(p, q, w_dup, m), b = fit_similarity<T>(pr.p, pr.q, w2, m);
      // Both solve the same problem; each is within the known-transform bounds of it.
      CHECK(rotation_angle(a.rotation.template cast<long double>(), b.rotation.template cast<long double>()) <=
            2 * pr.tol_angle);
      CHECK(std::abs(a.scale - b.scale) <= 2 * pr.tol_scale * pr.s);
      CHECK((a.translation - b.translation).template cast<long double>().norm() <= 2 * pr.tol_translation);
    }

    {  // scaling all weights changes nothing beyond rounding
      // The weights are normalised by their sum, which changes each by at most a rounding: within the
      // known-transform bounds.
      for (T factor : {T(1e-30), T(1e20)}) {
        INFO("weights times " << double(factor));
        const Vec<T> w = pr.w / pr.w.maxCoeff() * factor;
        check_transform(fit_similarity<T>(pr.p, pr.q, w, m), pr, pr.s);
      }
    }
  }
}

// Regression: point_fit.cpp once divided the weights by their sum, which overflows to infinity for large
// finite weights (e.g. 12 weights of max()/4): every weight became 0, H = 0, and the fit silently returned
// the identity with scale 1 and a wrong translation.
TEMPLATE_TEST_CASE("point fits: huge weights whose sum overflows", "[point_fit]", float, double) {
  using T = TestType;
  Rng rng(kDefaultSeed + 1);
  for (RotationMethod m : all_rotation_methods) {
    INFO(to_string(m));
    const Problem<T> pr = make_problem<T>(rng, 12, true);
    for (T factor : {std::numeric_limits<T>::max() / T(4), std::numeric_limits<T>::max()}) {
      INFO("weights scaled to a largest weight of " << double(factor));
      const Vec<T> w = pr.w / pr.w.maxCoeff() * factor;
      REQUIRE(w.allFinite());
      check_transform(fit_similarity<T>(pr.p, pr.q, w, m), pr, pr.s);
    }
  }
}

TEMPLATE_TEST_CASE("point fits: coordinates from 1e-15 to 1e15 (float), 1e-100 to 1e100 (double)", "[point_fit]", float,
                   double) {
  using T = TestType;
  // Millimetres and kilometres: the correlation matrix scales as the square of the unit, which stays in T's
  // range over these units; every bound scales with the unit or not at all (see the top of the file).
  const int range = std::is_same_v<T, float> ? 15 : 100;
  Rng rng(kDefaultSeed + 3);
  for (RotationMethod m : all_rotation_methods) {
    for (int e : {-range, -range / 3, range / 3, range}) {
      INFO(to_string(m) << " unit 1e" << e);
      const Problem<T> pr = make_problem<T>(rng, 10, true, false, std::pow(10.0L, e));
      check_transform(fit_similarity<T>(pr.p, pr.q, pr.w, m), pr, pr.s);
    }
  }
}

TEMPLATE_TEST_CASE("point fits: degenerate but valid input", "[point_fit]", float, double) {
  using T = TestType;
  for (RotationMethod m : all_rotation_methods) {
    INFO(to_string(m));
    // One point: H = 0, the rotation is the identity, the translation takes p to q, the scale is 1.
    Points<T> p(1, 3), q(1, 3);
    p << 1, 2, 3;
    q << -4, 5, 0.5;
    const SimilarityTransform<T> one = fit_similarity<T>(p, q, Vec<T>(), m);
    CHECK(one.rotation == Matrix3<T>::Identity());
    CHECK(one.scale == T(1));
    CHECK(one.translation == Vector3<T>(-5, 3, -2.5));
    CHECK(fit_rigid<T>(p, q, Vec<T>(), m).translation == Vector3<T>(-5, 3, -2.5));
    // All p coincide: scale 1 (documented), a proper rotation, finite.
    Points<T> pc(4, 3), qc(4, 3);
    pc.rowwise() = Eigen::Matrix<T, 1, 3>(1, 1, 1);
    qc << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
    const SimilarityTransform<T> co = fit_similarity<T>(pc, qc, Vec<T>(), m);
    CHECK(co.scale == T(1));
    CHECK(co.rotation.allFinite());
    CHECK(co.translation.allFinite());
    // Mirrored data: still a proper rotation (det +1).
    Rng rng(kDefaultSeed + 2);
    const Problem<T> mirrored = make_problem<T>(rng, 10, false, true);
    const SimilarityTransform<T> x = fit_rigid<T>(mirrored.p, mirrored.q, mirrored.w, m);
    CHECK(x.rotation.template cast<long double>().determinant() > 0.5L);
  }
}

TEMPLATE_TEST_CASE("point fits reject bad input with a message", "[point_fit]", float, double) {
  using T = TestType;
  const T nan = std::numeric_limits<T>::quiet_NaN(), inf = std::numeric_limits<T>::infinity();
  Points<T> p = Points<T>::Random(5, 3), q = Points<T>::Random(5, 3);
  const Vec<T> w = Vec<T>::Ones(5);
  for (auto fit : {&fit_rigid<T>, &fit_similarity<T>}) {
    CHECK_THROWS_WITH(fit(Points<T>(0, 3), Points<T>(0, 3), Vec<T>(), RotationMethod::axis_angle),
                      Catch::Matchers::ContainsSubstring("no points"));
    CHECK_THROWS_WITH(fit(p, Points<T>::Random(4, 3), w, RotationMethod::axis_angle),
                      Catch::Matchers::ContainsSubstring("5 points but q has 4"));
    CHECK_THROWS_WITH(fit(p, q, Vec<T>::Ones(3), RotationMethod::axis_angle),
                      Catch::Matchers::ContainsSubstring("5 points but 3 weights"));
    Points<T> bad = p;
    bad(2, 1) = nan;
    CHECK_THROWS_WITH(fit(bad, q, w, RotationMethod::svd), Catch::Matchers::ContainsSubstring("non-finite"));
    bad(2, 1) = inf;
    CHECK_THROWS_WITH(fit(p, bad, w, RotationMethod::svd), Catch::Matchers::ContainsSubstring("non-finite"));
    Vec<T> wb = w;
    wb(3) = nan;
    CHECK_THROWS_WITH(fit(p, q, wb, RotationMethod::kanatani), Catch::Matchers::ContainsSubstring("non-finite"));
    wb(3) = T(-1);
    CHECK_THROWS_WITH(fit(p, q, wb, RotationMethod::horn_matrix),
                      Catch::Matchers::ContainsSubstring("negative weight"));
    CHECK_THROWS_WITH(fit(p, q, Vec<T>::Zero(5), RotationMethod::horn_quaternion),
                      Catch::Matchers::ContainsSubstring("sum to zero"));
    CHECK_THROWS_AS(fit(p, q, Vec<T>::Zero(5), RotationMethod::axis_angle), std::invalid_argument);
  }
}
