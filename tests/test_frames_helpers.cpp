// transform_normals and transform_tangents (mlsdeform/frames.hpp) against long-double references: a normal
// through L becomes L^-T n renormalised (so it stays perpendicular to every tangent carried by L), tangents L t
// with the bitangent sign flipped by a reflection; degenerate linear parts keep the input; bad input refused.
#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#include <Eigen/Dense>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

using namespace mlsdeform;

namespace {

using LD = long double;
using Mat = Eigen::Matrix<LD, 3, 3>;
using Vec = Eigen::Matrix<LD, 3, 1>;

/// Random linear parts: rotations, scaled rotations, general matrices (some reflections), one per vertex.
std::vector<Mat> random_linear(std::size_t n, std::mt19937_64& g) {
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Mat> L(n);
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Matrix3d M;
    for (int k = 0; k < 9; ++k) M(k / 3, k % 3) = u(g);
    if (i % 3 == 0) M = Eigen::Quaterniond(u(g), u(g), u(g), u(g)).normalized().toRotationMatrix();
    if (i % 3 == 1) M = (2 + u(g)) * Eigen::Quaterniond(u(g), u(g), u(g), u(g)).normalized().toRotationMatrix();
    L[i] = M.cast<LD>();
  }
  return L;
}

}  // namespace

TEMPLATE_TEST_CASE("transform_normals: L^-T n renormalised, against long double", "[frames][normals]", float, double) {
  using T = TestType;
  const LD eps = std::numeric_limits<T>::epsilon();
  std::mt19937_64 g(9);
  std::uniform_real_distribution<double> u(-1, 1);
  const std::size_t n = 300;
  const std::vector<Mat> L = random_linear(n, g);
  std::vector<T> lin(9 * n), nrm(3 * n), out(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 9; ++k) lin[9 * i + std::size_t(k)] = T(L[i](k / 3, k % 3));
    for (int k = 0; k < 3; ++k) nrm[3 * i + std::size_t(k)] = T(u(g));
  }
  transform_normals<T>(lin, nrm, out);
  std::size_t failures = 0;
  for (std::size_t i = 0; i < n; ++i) {
    Mat Lt;  // L as rounded to T: the reference transforms what the function was given
    Vec nin, got;
    for (int k = 0; k < 9; ++k) Lt(k / 3, k % 3) = LD(lin[9 * i + std::size_t(k)]);
    for (int k = 0; k < 3; ++k) nin(k) = LD(nrm[3 * i + std::size_t(k)]), got(k) = LD(out[3 * i + std::size_t(k)]);
    const Vec ref = (Lt.inverse().transpose() * nin).normalized();
    // Bound: cof(L) n in T is a sum of 2-term products, each cofactor within 3 eps of its exact value times
    // |L|^2 (the scaling by a power of two is exact), so |d(cof n)| <= ~6 eps |L|_F^2 |n|; turned by at most
    // that over |cof(L) n| = |det L| |L^-T n|; the normalisation adds ~4 eps.
    const LD len = (Lt.inverse().transpose() * nin).norm() * std::abs(Lt.determinant());
    const LD tol = 8 * eps * Lt.squaredNorm() * nin.norm() / len + 4 * eps;
    if (!((got - ref).norm() <= tol)) ++failures;
    // The defining property: perpendicular to every carried tangent L t, t perpendicular to n.
    const Vec t = nin.cross(Vec(LD(0.3), LD(-0.5), LD(0.8))).normalized();
    CHECK(std::abs(got.dot(Lt * t)) <= tol * (Lt * t).norm());
  }
  CHECK(failures == 0);
  // In place: the same values.
  std::vector<T> in_place = nrm;
  transform_normals<T>(lin, in_place, in_place);
  CHECK(in_place == out);
}

TEMPLATE_TEST_CASE("transform_normals: degenerate linear parts keep the normal, zero stays zero", "[frames][normals]",
                   float, double) {
  using T = TestType;
  const T inf = std::numeric_limits<T>::infinity();
  // Rows: L = 0; rank 1; a non-finite entry; a rank-2 L that collapses onto the xy plane (normal -> +-z);
  // a zero normal under a rotation.
  const std::vector<T> lin = {0, 0,  0, 0, 0,   0, 0, 0, 0,  //
                              1, 2,  3, 2, 4,   6, 0, 0, 0,  //
                              1, 0,  0, 0, inf, 0, 0, 0, 1,  //
                              1, 0,  0, 0, 1,   0, 0, 0, 0,  //
                              0, -1, 0, 1, 0,   0, 0, 0, 1};
  const std::vector<T> nrm = {0, 0, 2, 3, 0, 4, 0, 3, 4, 1, 1, 1, 0, 0, 0};
  std::vector<T> out(nrm.size());
  transform_normals<T>(lin, nrm, out);
  const T e = 4 * std::numeric_limits<T>::epsilon();
  CHECK(std::abs(out[2] - 1) <= e);                                              // kept, unit
  CHECK((std::abs(out[3] - T(0.6)) <= e && std::abs(out[5] - T(0.8)) <= e));     // kept, unit
  CHECK((std::abs(out[7] - T(0.6)) <= e && std::abs(out[8] - T(0.8)) <= e));     // kept, unit
  CHECK((out[9] == 0 && out[10] == 0 && std::abs(std::abs(out[11]) - 1) <= e));  // the collapsed plane's normal
  CHECK((out[12] == 0 && out[13] == 0 && out[14] == 0));                         // zero stays zero
}

TEMPLATE_TEST_CASE("transform_normals and tangents: NaN in L keeps the input, the identity keeps it bit for bit",
                   "[frames][normals]", float, double) {
  using T = TestType;
  const T nan = std::numeric_limits<T>::quiet_NaN();
  // Rows: a NaN entry (the input kept, unit length, as for an infinite one); the identity (kept as it is: a
  // normal of length 5 stays 5, not renormalised, and a tangent's w stays as stored).
  const std::vector<T> lin = {1, 0, 0, 0, nan, 0, 0, 0, 1,  //
                              1, 0, 0, 0, 1,   0, 0, 0, 1};
  const std::vector<T> nrm = {0, 3, 4, 3, 0, T(4.1)};
  std::vector<T> out(nrm.size());
  transform_normals<T>(lin, nrm, out);
  const T e = 4 * std::numeric_limits<T>::epsilon();
  CHECK((std::abs(out[1] - T(0.6)) <= e && std::abs(out[2] - T(0.8)) <= e && out[0] == 0));
  CHECK((out[3] == nrm[3] && out[4] == nrm[4] && out[5] == nrm[5]));
  const std::vector<T> tan = {0, 0, 2, -1, 2, 0, 0, T(-0.5)};
  std::vector<T> tout(tan.size());
  transform_tangents<T>(lin, tan, tout);
  CHECK((tout[2] == 1 && tout[3] == -1));
  CHECK((tout[4] == 2 && tout[5] == 0 && tout[6] == 0 && tout[7] == T(-0.5)));
}

TEMPLATE_TEST_CASE("transform_tangents: L t renormalised, w flipped by a reflection", "[frames][normals]", float,
                   double) {
  using T = TestType;
  const LD eps = std::numeric_limits<T>::epsilon();
  std::mt19937_64 g(4);
  std::uniform_real_distribution<double> u(-1, 1);
  const std::size_t n = 300;
  const std::vector<Mat> L = random_linear(n, g);
  std::vector<T> lin(9 * n), tan(4 * n), out(4 * n);
  for (std::size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 9; ++k) lin[9 * i + std::size_t(k)] = T(L[i](k / 3, k % 3));
    for (int k = 0; k < 3; ++k) tan[4 * i + std::size_t(k)] = T(u(g));
    tan[4 * i + 3] = i % 2 ? T(1) : T(-1);
  }
  transform_tangents<T>(lin, tan, out);
  std::size_t failures = 0;
  for (std::size_t i = 0; i < n; ++i) {
    Mat Lt;
    Vec tin, got;
    for (int k = 0; k < 9; ++k) Lt(k / 3, k % 3) = LD(lin[9 * i + std::size_t(k)]);
    for (int k = 0; k < 3; ++k) tin(k) = LD(tan[4 * i + std::size_t(k)]), got(k) = LD(out[4 * i + std::size_t(k)]);
    const Vec ref = (Lt * tin).normalized();
    // L t: 3-term sums, within 3 eps |L|_F |t| each, turned by that over |L t|; normalising adds ~4 eps.
    const LD tol = 3 * std::sqrt(LD(3)) * eps * Lt.norm() * tin.norm() / (Lt * tin).norm() + 4 * eps;
    const T w = Lt.determinant() < 0 ? -tan[4 * i + 3] : tan[4 * i + 3];
    if (!((got - ref).norm() <= tol) || out[4 * i + 3] != w) ++failures;
  }
  CHECK(failures == 0);
}

TEMPLATE_TEST_CASE("transform_normals and transform_tangents refuse bad input, writing nothing", "[frames][errors]",
                   float, double) {
  using T = TestType;
  std::vector<T> lin(18, T(0)), nrm(6, T(1)), out(6, T(-7)), tan(8, T(1)), tout(8, T(-7));
  std::vector<T> short_lin(17);
  CHECK_THROWS_WITH(transform_normals<T>(short_lin, nrm, out), Catch::Matchers::ContainsSubstring("linear 17"));
  CHECK_THROWS_WITH(transform_normals<T>(lin, nrm, std::span<T>(out).first(5)),
                    Catch::Matchers::ContainsSubstring("out 5"));
  CHECK_THROWS_WITH(transform_tangents<T>(lin, std::span<const T>(tan).first(7), tout),
                    Catch::Matchers::ContainsSubstring("tangents"));
  nrm[4] = std::numeric_limits<T>::quiet_NaN();
  CHECK_THROWS_WITH(transform_normals<T>(lin, nrm, out), Catch::Matchers::ContainsSubstring("row 1 is not finite"));
  CHECK(std::all_of(out.begin(), out.end(), [](T x) { return x == T(-7); }));
  CHECK(std::all_of(tout.begin(), tout.end(), [](T x) { return x == T(-7); }));
}
