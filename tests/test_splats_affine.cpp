// Splats carried through affine motions (mlsdeform/splats.hpp), the bad input every splat function refuses, and
// the generated 3DGS PLY file's layout.
#include "tests/support/splats.hpp"
#include "tests/test_splats_common.hpp"

#include <mlsdeform/splats.hpp>

#include "tests/support/catch.hpp"

#include <cstring>
#include <limits>
#include <string>

using namespace mlsdeform;
using namespace splat_test;
using mlsdeform::testing::Rng;

namespace {

// A well-conditioned random linear part: a rotation times diag in [0.5, 2], times a rotation (cond <= 4).
template <class T>
Matrix3L random_linear(Rng& rng, bool reflect) {
  Matrix3L D = Matrix3L::Zero();
  for (int k = 0; k < 3; ++k) D(k, k) = rng.uniform(0.5L, 2.0L);
  if (reflect) D(0, 0) = -D(0, 0);
  Matrix3L M = rng.rotation() * D * rng.rotation();
  return M.template cast<T>().template cast<L>();  // the matrix the library receives, exactly
}

}  // namespace

TEMPLATE_TEST_CASE("an affine map takes a splat's covariance to M Sigma M^T, its colour by M's polar rotation",
                   "[splats]", float, double) {
  using T = TestType;
  constexpr L eps = std::numeric_limits<T>::epsilon();
  Rng rng(71);
  for (const bool reflect : {false, true}) {
    Cloud<T> c = cloud<T>(100, 72);
    const Cloud<T> before = c;
    std::vector<T> linear(9 * c.n);
    std::vector<Matrix3L> Ms(c.n);
    for (std::size_t i = 0; i < c.n; ++i) {
      Ms[i] = random_linear<T>(rng, reflect);
      for (int j = 0; j < 9; ++j) linear[9 * i + std::size_t(j)] = T(Ms[i](j / 3, j % 3));
    }
    transform_splats_affine<T>(c.arrays(), c.n, linear.data());
    for (std::size_t i = 0; i < c.n; ++i) {
      const Matrix3L& M = Ms[i];
      INFO("splat " << i << " reflect " << reflect);
      const Matrix3L expected =
          M * covariance(before.rotations.data() + 4 * i, before.log_scales.data() + 3 * i) * M.transpose();
      const Matrix3L got = covariance(c.rotations.data() + 4 * i, c.log_scales.data() + 3 * i);
      L largest_log = 0;
      for (int j = 0; j < 3; ++j) largest_log = std::max(largest_log, std::abs(L(c.log_scales[3 * i + j])));
      // Rounding the outputs to T: as for a rotation (test_splats.cpp's covariance_bound), 3 (8 + |log s|)
      // eps_T lambda_max. The eigenproblem in double adds ~ eps_d cond: within the bound for T = float; for
      // T = double, doubled (cond(Sigma') <= 16 cond(Sigma), Sigma' = M Sigma M^T computed in a few roundings).
      const L scale = std::is_same_v<T, double> ? 2 : 1;
      CHECK(max_abs(got - expected) <= scale * 3 * (8 + largest_log) * eps * max_abs(expected));
      // The colour: f'(Q d) = f(d) for the orthogonal polar factor Q of M (Q = U V^T from M's SVD).
      const Eigen::JacobiSVD<Matrix3L> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
      const Matrix3L Q = svd.matrixU() * svd.matrixV().transpose();
      for (int channel = 0; channel < 3; ++channel) {
        const T* old = before.sh.data() + 45 * i;
        // As test_splats.cpp's colour_bound, with Q from an SVD in double (a few eps_d more: 4,000 in all).
        const L bound = (eps / 2 + 4000 * L(std::numeric_limits<double>::epsilon())) * norm(old + 15 * channel, 15) *
                        std::sqrt(15 / (4 * std::numbers::pi_v<L>));
        for (int t = 0; t < 4; ++t) {
          const Vector3L d = rng.unit_vector();
          CHECK(std::abs(colour(c.sh.data() + 45 * i, 3, channel, Vector3L(Q * d)) - colour(old, 3, channel, d)) <=
                bound);
        }
      }
    }
  }
}

TEST_CASE("a mild affine map keeps each scale_k on the axis it was", "[splats]") {
  Rng rng(81);
  Cloud<double> c = cloud<double>(100, 82);
  const Cloud<double> before = c;
  std::vector<double> linear(9 * c.n);
  for (std::size_t i = 0; i < c.n; ++i)
    for (std::size_t j = 0; j < 9; ++j) linear[9 * i + j] = (j % 4 == 0 ? 1 : 0) + 0.01 * rng.gaussian<double>();
  transform_splats_affine<double>(c.arrays(), c.n, linear.data());
  for (std::size_t i = 0; i < c.n; ++i) {
    // Axes matched to their images: a 1% map changes each log scale by about 0.01 (bound 0.1), where a swap
    // of two axes would change them by their difference (0.5 * sqrt(2) on average, by the generator).
    for (std::size_t k = 0; k < 3; ++k) CHECK(std::abs(c.log_scales[3 * i + k] - before.log_scales[3 * i + k]) < 0.1);
    // and the quaternion's sign follows the old one
    double dot = 0;
    for (std::size_t j = 0; j < 4; ++j) dot += c.rotations[4 * i + j] * before.rotations[4 * i + j];
    CHECK(dot > 0);
  }
}

TEMPLATE_TEST_CASE("bad splat input is refused, naming the splat, with nothing written", "[splats]", float, double) {
  using T = TestType;
  const T nan = std::numeric_limits<T>::quiet_NaN();
  const Cloud<T> good = cloud<T>(10, 91);
  std::vector<T> q(40, T(0)), M(90, T(0));
  for (std::size_t i = 0; i < 10; ++i) {
    q[4 * i + 1] = 1;                                          // a half-turn about x
    for (std::size_t j = 0; j < 3; ++j) M[9 * i + 4 * j] = 2;  // 2 I
  }
  auto refused = [&](Cloud<T> c, const std::vector<T>& qs, const T* scales, const std::vector<T>& Ms,
                     const std::string& what) {
    const Cloud<T> before = c;
    INFO(what);
    CHECK_THROWS_WITH(rotate_splats<T>(c.arrays(), c.n, qs.data(), scales), Catch::Matchers::ContainsSubstring(what));
    CHECK_THROWS_AS(transform_splats_affine<T>(c.arrays(), c.n, Ms.data()), std::invalid_argument);
    // bitwise (a NaN planted in the input compares unequal to itself)
    CHECK(std::memcmp(c.rotations.data(), before.rotations.data(), c.rotations.size() * sizeof(T)) == 0);
    CHECK(std::memcmp(c.log_scales.data(), before.log_scales.data(), c.log_scales.size() * sizeof(T)) == 0);
    CHECK(std::memcmp(c.sh.data(), before.sh.data(), c.sh.size() * sizeof(T)) == 0);
  };
  Cloud<T> c = good;
  c.rotations[4 * 7 + 2] = nan;
  refused(c, q, nullptr, M, "splat 7: rotation (rot_*) is NaN");
  c = good;
  std::fill(c.rotations.begin() + 12, c.rotations.begin() + 16, T(0));
  refused(c, q, nullptr, M, "splat 3: rotation (rot_*) is zero");
  c = good;
  c.log_scales[3 * 5] = std::numeric_limits<T>::infinity();
  refused(c, q, nullptr, M, "splat 5: log scale");
  c = good;
  c.sh[45 * 9 + 44] = nan;
  refused(c, q, nullptr, M, "splat 9: SH coefficient");
  // Bad transforms (the splats are good): only the function given it refuses.
  std::vector<T> bad_q = q;
  bad_q[4 * 2] = T(0.5);  // length sqrt(1.25)
  CHECK_THROWS_WITH(rotate_splats<T>(c.arrays(), c.n, bad_q.data()),
                    Catch::Matchers::ContainsSubstring("splat 2: transform quaternion "
                                                       "is not a unit quaternion"));
  bad_q = q;
  bad_q[4 * 4 + 3] = nan;
  CHECK_THROWS_WITH(rotate_splats<T>(c.arrays(), c.n, bad_q.data()),
                    Catch::Matchers::ContainsSubstring("splat 4: transform quaternion "
                                                       "is NaN"));
  std::vector<T> s(10, T(1));
  s[6] = T(0);
  CHECK_THROWS_WITH(rotate_splats<T>(c.arrays(), c.n, q.data(), s.data()),
                    Catch::Matchers::ContainsSubstring("splat 6: scale"));
  std::vector<T> bad_M = M;
  bad_M[9 * 8 + 8] = T(0);  // diag(2, 2, 0)
  CHECK_THROWS_WITH(transform_splats_affine<T>(c.arrays(), c.n, bad_M.data()),
                    Catch::Matchers::ContainsSubstring("splat 8: linear part "
                                                       "is singular"));
  bad_M = M;
  bad_M[1] = nan;
  CHECK_THROWS_WITH(transform_splats_affine<T>(c.arrays(), c.n, bad_M.data()),
                    Catch::Matchers::ContainsSubstring("splat 0: linear part "
                                                       "is NaN"));
  c = good;
  if constexpr (std::is_same_v<T, double>) {  // a float M times a float extent cannot overflow double
    bad_M = M;
    bad_M[9 * 3] = T(1e200);
    CHECK_THROWS_WITH(transform_splats_affine<T>(c.arrays(), c.n, bad_M.data()),
                      Catch::Matchers::ContainsSubstring("splat 3: linear part times"));
  }
  CHECK(c.rotations == good.rotations);
  c.sh[45 * 1 + 3] = std::numeric_limits<T>::max() / 2;
  CHECK_THROWS_WITH(rotate_splats<T>(c.arrays(), c.n, q.data()),
                    Catch::Matchers::ContainsSubstring("splat 1: SH coefficient"));
  c = good;
  CHECK_THROWS_WITH(rotate_splats<T>(c.arrays(), c.n, nullptr),
                    Catch::Matchers::ContainsSubstring("quaternions is null"));
  SplatArrays<T> a = c.arrays();
  a.sh_degree = 4;
  CHECK_THROWS_WITH(rotate_splats<T>(a, c.n, q.data()), Catch::Matchers::ContainsSubstring("sh_degree 4"));
  a = c.arrays();
  a.log_scales = nullptr;
  CHECK_THROWS_WITH(transform_splats_affine<T>(a, c.n, M.data()), Catch::Matchers::ContainsSubstring("both needed"));
}

TEST_CASE("the generated splat PLY has 3DGS's layout", "[splats]") {
  const testing::SplatCloud c = testing::random_splat_cloud(5, 101);
  const std::vector<char> bytes = testing::splat_ply_bytes(c);
  const std::string text(bytes.begin(), bytes.end());
  const std::size_t end = text.find("end_header\n") + 11;
  REQUIRE(end > 11);
  CHECK(text.rfind("ply\nformat binary_little_endian 1.0\nelement vertex 5\nproperty float x\n", 0) == 0);
  // 62 float properties in 3DGS's order, 248 bytes a splat
  CHECK(bytes.size() - end == 5 * 62 * 4);
  std::vector<std::string> names;
  for (std::size_t at = text.find("property float "); at < end; at = text.find("property float ", at + 1))
    names.push_back(text.substr(at + 15, text.find('\n', at) - at - 15));
  REQUIRE(names.size() == 62);
  CHECK(names[6] == "f_dc_0");
  CHECK(names[9] == "f_rest_0");
  CHECK(names[53] == "f_rest_44");
  CHECK(names[54] == "opacity");
  CHECK(names[55] == "scale_0");
  CHECK(names[58] == "rot_0");
  CHECK(names[61] == "rot_3");
  // the second splat's rot_0 (w) and f_rest_15 (G's first coefficient) where they belong
  float w, g;
  std::memcpy(&w, bytes.data() + end + (62 + 58) * 4, 4);
  std::memcpy(&g, bytes.data() + end + (62 + 9 + 15) * 4, 4);
  CHECK(w == c.rotations[4]);
  CHECK(g == c.f_rest[45 + 15]);
}
