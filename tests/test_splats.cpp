// Splats carried through rigid and similarity motions (mlsdeform/splats.hpp): the covariance turns with the
// transform, the colour seen from R d is the colour formerly seen from d, the identity keeps every bit, two
// motions compose, bad input writes nothing.
#include "core/src/splats/sh_rotation.hpp"
#include "tests/support/splats.hpp"
#include "tests/test_splats_common.hpp"

#include <mlsdeform/splats.hpp>

#include "tests/support/catch.hpp"

#include <cfloat>
#include <cstring>
#include <limits>

using namespace mlsdeform;
using namespace splat_test;
using mlsdeform::testing::Rng;

namespace {

template <class T>
std::vector<T> random_transforms(std::size_t n, Rng& rng) {
  std::vector<T> q(4 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::array<T, 4> r = random_unit_quaternion<T>(rng);
    std::copy(r.begin(), r.end(), q.begin() + std::ptrdiff_t(4 * i));
  }
  return q;
}

// The colour after a rotation, against the colour before at the direction moved back: |f'(R d) - f(d)|.
// Rounding the rotated coefficients to T moves each by <= eps_T / 2 |c'_j|, so the colour by <= eps_T / 2 ||c'||
// ||B(d)|| (Cauchy-Schwarz), where ||c'|| = ||c|| (a rotation is orthogonal on each band) and ||B(d)||^2 =
// sum_l (2 l + 1) / (4 pi) <= 15 / (4 pi) (the addition theorem). Computing in double adds at most 33 roundings
// along one coefficient's path (band 3's: the back-rotated point, its basis, the 7-term band value, the 13-point
// sum; bands 1 and 2, turned in closed form, take fewer),
// weighted by sum_p |P_pj| <= 4 pi max|B_j| <= 9.4: <= 9.4 * 33 eps_d ||c|| per coefficient, times sqrt(15) for
// the colour: under 1,300 eps_d ||c|| ||B(d)||, doubled to 2,600 for the rounding of the rotation matrix.
template <class T>
L colour_bound(L norm_c) {
  const L basis = std::sqrt(15 / (4 * std::numbers::pi_v<L>));
  return (L(std::numeric_limits<T>::epsilon()) / 2 + 2600 * L(std::numeric_limits<double>::epsilon())) * norm_c * basis;
}

// A covariance rebuilt from the rounded outputs: rounding q' to T moves it by <= eps_T (the norm of four
// relative eps_T / 2 errors), R(q) by <= 4 eps_T (R is quadratic in q, each entry a sum of two products), and
// Sigma = R D R^T by <= 8 eps_T lambda_max; a log scale rounded to T after an offset is off by
// eps_T / 2 |log s'|, a relative 2 (eps_T / 2) |log s'| of its variance. lambda_max <= 3 max|Sigma_ij| (the trace).
template <class T>
L covariance_bound(const Matrix3L& reference, L max_log_scale) {
  return 3 * (8 + max_log_scale) * L(std::numeric_limits<T>::epsilon()) * max_abs(reference);
}

}  // namespace

TEST_CASE("splat SH basis is 3DGS's: the real SH with the Condon-Shortley phase", "[splats]") {
  Rng rng(11);
  for (int t = 0; t < 100; ++t) {
    const Vector3L d = rng.unit_vector();
    const std::array<double, 15> b = detail::sh_basis({double(d(0)), double(d(1)), double(d(2))});
    const std::array<L, 15> r = reference_basis(d);
    // 3DGS's constants have 16 significant digits; a basis value is a product of <= 4 factors of size <= 1
    // (|B| <= 3): 8 roundings of double, taken as 16 eps_d relative to 3.
    for (std::size_t j = 0; j < 15; ++j)
      CHECK(std::abs(L(b[j]) - r[j]) <= 48 * L(std::numeric_limits<double>::epsilon()));
  }
}

TEMPLATE_TEST_CASE("rotated SH: the colour seen from R d is the colour formerly seen from d", "[splats]", float,
                   double) {
  using T = TestType;
  const std::uint64_t seed = 21;
  INFO("seed " << seed);
  Rng rng(seed);
  for (int degree = 1; degree <= 3; ++degree) {
    Cloud<T> c = cloud<T>(64, seed + std::uint64_t(degree), degree);
    const std::vector<T> before = c.sh;
    const std::vector<T> q = random_transforms<T>(c.n, rng);
    rotate_splats<T>(c.arrays(), c.n, q.data());
    const int k = (degree + 1) * (degree + 1) - 1;
    for (std::size_t i = 0; i < c.n; ++i) {
      const Matrix3L R = rotation_of(q.data() + 4 * i);
      for (int channel = 0; channel < 3; ++channel) {
        const T* old = before.data() + 3 * std::size_t(k) * i;
        const L bound = colour_bound<T>(norm(old + channel * k, k));
        for (int t = 0; t < 4; ++t) {
          const Vector3L d = rng.unit_vector();
          const L f = colour(old, degree, channel, d);
          const L f_rotated = colour(c.sh.data() + 3 * std::size_t(k) * i, degree, channel, Vector3L(R * d));
          INFO("degree " << degree << " splat " << i << " channel " << channel);
          CHECK(std::abs(f_rotated - f) <= bound);
        }
      }
    }
  }
}

TEMPLATE_TEST_CASE("a rotated splat's covariance is R Sigma R^T, a similarity's s^2 R Sigma R^T", "[splats]", float,
                   double) {
  using T = TestType;
  Rng rng(31);
  Cloud<T> c = cloud<T>(200, 32);
  const Cloud<T> before = c;
  const std::vector<T> q = random_transforms<T>(c.n, rng);
  std::vector<T> s(c.n);
  for (T& x : s) x = T(rng.uniform<double>(0.25, 4.0));
  for (const bool similarity : {false, true}) {
    c = before;
    rotate_splats<T>(c.arrays(), c.n, q.data(), similarity ? s.data() : nullptr);
    for (std::size_t i = 0; i < c.n; ++i) {
      const Matrix3L R = rotation_of(q.data() + 4 * i);
      const L s2 = similarity ? L(s[i]) * L(s[i]) : 1;
      const Matrix3L expected =
          s2 * R * covariance(before.rotations.data() + 4 * i, before.log_scales.data() + 3 * i) * R.transpose();
      const Matrix3L got = covariance(c.rotations.data() + 4 * i, c.log_scales.data() + 3 * i);
      L largest_log = 0;
      for (int j = 0; j < 3; ++j) largest_log = std::max(largest_log, std::abs(L(c.log_scales[3 * i + j])));
      INFO("splat " << i << " similarity " << similarity);
      CHECK(max_abs(got - expected) <= covariance_bound<T>(expected, largest_log));
      // written normalised: |q'| = 1 to T's rounding of four components (2 eps_T)
      L length = 0;
      for (int j = 0; j < 4; ++j) length += L(c.rotations[4 * i + j]) * L(c.rotations[4 * i + j]);
      CHECK(std::abs(std::sqrt(length) - 1) <= 2 * L(std::numeric_limits<T>::epsilon()));
    }
  }
}

TEMPLATE_TEST_CASE("the identity motion keeps every bit of every splat", "[splats]", float, double) {
  using T = TestType;
  Cloud<T> c = cloud<T>(100, 41);
  const Cloud<T> before = c;
  std::vector<T> q(4 * c.n, T(0)), s(c.n, T(1)), M(9 * c.n, T(0));
  for (std::size_t i = 0; i < c.n; ++i) {
    q[4 * i] = i % 2 ? T(1) : T(-1);  // -1 is the identity rotation too
    for (std::size_t j = 0; j < 3; ++j) M[9 * i + 4 * j] = 1;
  }
  rotate_splats<T>(c.arrays(), c.n, q.data(), s.data());
  transform_splats_affine<T>(c.arrays(), c.n, M.data());
  CHECK(std::memcmp(c.rotations.data(), before.rotations.data(), c.rotations.size() * sizeof(T)) == 0);
  CHECK(std::memcmp(c.log_scales.data(), before.log_scales.data(), c.log_scales.size() * sizeof(T)) == 0);
  CHECK(std::memcmp(c.sh.data(), before.sh.data(), c.sh.size() * sizeof(T)) == 0);
}

TEST_CASE("two rotations one after the other equal their product at once", "[splats]") {
  Rng rng(51);
  Cloud<double> a = cloud<double>(100, 52);
  Cloud<double> b = a;
  const std::vector<double> q1 = random_transforms<double>(a.n, rng), q2 = random_transforms<double>(a.n, rng);
  std::vector<double> q21(4 * a.n);
  for (std::size_t i = 0; i < a.n; ++i) {
    const Eigen::Quaternion<L> p = Eigen::Quaternion<L>{q2[4 * i], q2[4 * i + 1], q2[4 * i + 2], q2[4 * i + 3]} *
                                   Eigen::Quaternion<L>{q1[4 * i], q1[4 * i + 1], q1[4 * i + 2], q1[4 * i + 3]};
    const L parts[4] = {p.w(), p.x(), p.y(), p.z()};
    for (std::size_t j = 0; j < 4; ++j) q21[4 * i + j] = double(parts[j]);
  }
  rotate_splats<double>(a.arrays(), a.n, q1.data());
  rotate_splats<double>(a.arrays(), a.n, q2.data());
  rotate_splats<double>(b.arrays(), b.n, q21.data());
  for (std::size_t i = 0; i < a.n; ++i) {
    // Each path rounds its quaternion products and normalisations a handful of times: 16 eps_d.
    for (int j = 0; j < 4; ++j) CHECK(std::abs(a.rotations[4 * i + j] - b.rotations[4 * i + j]) <= 16 * DBL_EPSILON);
    // Two SH rotations against one, each within 2,600 eps_d ||c|| of exact per coefficient (colour_bound's
    // derivation without the basis factor; ||c|| of one channel <= that of all three): 3 x 2,600 eps_d.
    for (int j = 0; j < 45; ++j)
      CHECK(std::abs(a.sh[45 * i + j] - b.sh[45 * i + j]) <= 3 * 2600 * DBL_EPSILON * norm(b.sh.data() + 45 * i, 45));
  }
}

TEST_CASE("splats: the result is bitwise the same for any thread count", "[splats]") {
  Rng rng(61);
  Cloud<float> a = cloud<float>(5000, 62);
  Cloud<float> b = a;
  const std::vector<float> q = random_transforms<float>(a.n, rng);
  rotate_splats<float>(a.arrays(), a.n, q.data(), nullptr, 1);
  rotate_splats<float>(b.arrays(), b.n, q.data(), nullptr, 0);
  CHECK(a.rotations == b.rotations);
  CHECK(a.sh == b.sh);
}
