// The batched (SIMD) rotation fits against the scalar reference and a long-double SVD, on every ISA this
// CPU runs, on sizes around the lane width and on random and degenerate inputs.
#include "tests/support/isa_guard.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include "tests/support/catch.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <iostream>
#include <limits>
#include <random>
#include <string>
#include <vector>

using namespace mlsdeform;
using mlsdeform::testing::IsaGuard;

namespace {

using LD = long double;

// The optimum of trace(R^T H) (s1 + s2 + sign(det) s3) and the condition number s1 / (s2 + sign(det) s3)
// from an SVD in long double of the very H the methods see.
template <class T>
void reference(const Matrix3<T>& H, LD& optimum, LD& kappa) {
  Eigen::JacobiSVD<Eigen::Matrix<LD, 3, 3>> svd(H.template cast<LD>());
  const auto s = svd.singularValues();
  const LD d = H.template cast<LD>().determinant() < 0 ? -1 : 1;
  optimum = s(0) + s(1) + d * s(2);
  kappa = s(1) + d * s(2) > 0 ? s(0) / (s(1) + d * s(2)) : std::numeric_limits<LD>::infinity();
}

template <class T>
Matrix3<T> at(const std::vector<T>& M, std::size_t n, std::size_t i) {
  Matrix3<T> X;
  for (std::size_t e = 0; e < 9; ++e) X(e / 3, e % 3) = M[e * n + i];
  return X;
}

// H = sum_i w q_i p_i^T for random point sets under a random rotation, with the degenerate shapes mixed in:
// every 8th collinear (rank-1 H), every 8th coplanar, every 8th reflected, every 8th a rotation by pi, a few
// exact H = 0, identity, -identity.
template <class T>
std::vector<T> make_cases(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  std::vector<T> H(9 * n);
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Matrix3d R = Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
    const int kind = int(i % 8);
    if (kind == 4) R = Eigen::AngleAxisd(M_PI, Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized()).toRotationMatrix();
    Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
    for (int k = 0; k < 6; ++k) {
      Eigen::Vector3d p(g(rng), g(rng), g(rng));
      if (kind == 1) p = Eigen::Vector3d(1, 0.5, -2) * p(0);
      if (kind == 2) p(2) = 0.25 * p(0) - p(1);
      Eigen::Vector3d q = R * p + 1e-3 * Eigen::Vector3d(g(rng), g(rng), g(rng));
      if (kind == 3) q = -q;
      M += std::exp(g(rng)) * q * p.transpose();
    }
    if (i % 97 == 5) M.setZero();
    if (i % 97 == 6) M.setIdentity();
    if (i % 97 == 7) M = -Eigen::Matrix3d::Identity();
    for (std::size_t e = 0; e < 9; ++e) H[e * n + i] = T(M(e / 3, e % 3));
  }
  return H;
}

// The n matrices of H (3 x 3 x n) fitted by axis_angle in calls of `piece` matrices each (the last shorter).
template <class T>
std::vector<T> fit_in_pieces(const std::vector<T>& H, std::size_t n, std::size_t piece) {
  std::vector<T> out(9 * n), h(9 * piece), r(9 * piece);
  for (std::size_t i0 = 0; i0 < n; i0 += piece) {
    const std::size_t m = std::min(piece, n - i0);
    for (std::size_t e = 0; e < 9; ++e)
      for (std::size_t i = 0; i < m; ++i) h[e * m + i] = H[e * n + i0 + i];
    fit_rotations(h.data(), r.data(), m, RotationMethod::axis_angle, 1);
    for (std::size_t e = 0; e < 9; ++e)
      for (std::size_t i = 0; i < m; ++i) out[e * n + i0 + i] = r[e * m + i];
  }
  return out;
}

// The n matrices of a planar batch (3 x 3 x n) in numpy's layout (n x 3 x 3).
template <class T>
std::vector<T> interleaved(const std::vector<T>& planar, std::size_t n) {
  std::vector<T> out(9 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t e = 0; e < 9; ++e) out[9 * i + e] = planar[e * n + i];
  return out;
}

// How many of expected's values R[k] differs from bitwise.
template <class T>
std::size_t differing(const T* R, const std::vector<T>& expected) {
  std::size_t differ = 0;
  for (std::size_t k = 0; k < expected.size(); ++k) differ += std::memcmp(&R[k], &expected[k], sizeof(T)) != 0;
  return differ;
}

template <class T>
void check_against_scalar(Isa isa, RotationMethod method, std::size_t n) {
  INFO("isa " << to_string(isa) << ", method " << to_string(method) << ", n = " << n);
  const std::vector<T> H = make_cases<T>(n, 20261121 + n);
  std::vector<T> R(9 * n, T(-7));
  set_isa(isa);
  fit_rotations(H.data(), R.data(), n, method);
  constexpr LD eps = std::numeric_limits<T>::epsilon();
  for (std::size_t i = 0; i < n; ++i) {
    const Matrix3<T> Hi = at(H, n, i), Ri = at(R, n, i);
    const Matrix3<T> Rs = fit_rotation<T>(Hi, method);
    INFO("matrix " << i << "\nH =\n" << Hi << "\nR =\n" << Ri << "\nscalar R =\n" << Rs);
    REQUIRE(Ri.allFinite());
    // Orthonormality and det: the quaternion-to-matrix map is exact up to about 8 roundings per entry.
    CHECK((Ri.template cast<LD>().transpose() * Ri.template cast<LD>() - Eigen::Matrix<LD, 3, 3>::Identity())
              .cwiseAbs()
              .maxCoeff() <= 16 * eps);
    CHECK(std::abs(Ri.template cast<LD>().determinant() - 1) <= 16 * eps);
    LD optimum, kappa;
    reference(Hi, optimum, kappa);
    const LD scale = Hi.template cast<LD>().norm();
    if (scale == 0) {
      CHECK(Ri == Matrix3<T>::Identity());
      continue;
    }
    // Trace: the scalar path attains the optimum to <= 12 eps ||H|| on 10^5-case families (docs/accuracy.md);
    // the SIMD path computes the same stages with different rounding, so we allow 32 eps ||H||.
    const LD achieved = (Ri.template cast<LD>().transpose() * Hi.template cast<LD>()).trace();
    CHECK(optimum - achieved <= 32 * eps * scale);
    // Angle to the scalar result where the optimum is unique: each is within c eps kappa of the optimum
    // (c <= 65 measured for the scalar path), so the two are within 2 * 64 eps kappa.
    if (kappa < 1 / (1024 * eps)) {
      const LD angle = Eigen::AngleAxis<LD>(Ri.template cast<LD>().transpose() * Rs.template cast<LD>()).angle();
      CHECK(angle <= 128 * eps * std::max<LD>(kappa, 1));
    }
  }
}

}  // namespace

TEMPLATE_TEST_CASE("fit_rotations agrees with the scalar fit on every ISA and size", "[batch]", float, double) {
  const IsaGuard guard;  // restores the ISA in force, also when a check throws
  for (Isa isa : supported_isas()) {
    set_isa(isa);
    const std::size_t W = simd_lanes<TestType>();
    for (RotationMethod method : {RotationMethod::axis_angle, RotationMethod::horn_quaternion})
      // W, 2W and 4W: the axis/angle kernel steps tiles of four batches of W lanes, Horn-Jacobi two
      // interleaved ones.
      for (std::size_t n : {std::size_t(1), W - 1, W, W + 1, 2 * W - 1, 2 * W, 2 * W + 1, 3 * W + 2, 4 * W - 1, 4 * W,
                            4 * W + 1, 5 * W + 3, std::size_t(5000)})
        if (n > 0) check_against_scalar<TestType>(isa, method, n);
  }
}

TEMPLATE_TEST_CASE("fit_rotations: batches fitted side by side are fitted bitwise as one at a time", "[batch]", float,
                   double) {
  // The axis/angle kernel interleaves the Newton steps of a tile of batches, and queues the lanes for its
  // careful path across the whole range to fit them W at a time (kernels/rotation/axis_angle.hpp,
  // fit_range_axis_angle, CarefulQueue). Each lane must compute exactly what it computes when its batch is
  // fitted alone, and when it is fitted alone: the same n matrices in one call (whole tiles, a shorter tile,
  // a padded last batch) against calls of one batch of W each (the same batch companions, one batch per
  // tile), and against calls of one matrix each (a padded batch, whose careful lanes are fitted in it, not
  // queued). make_cases's rank-1 H (one in 8) take the careful path: at n = 5000 the queue fills and flushes
  // many times.
  const IsaGuard guard;
  for (Isa isa : supported_isas()) {
    set_isa(isa);
    const std::size_t W = simd_lanes<TestType>();
    for (std::size_t n : {4 * W - 1, 4 * W, 4 * W + 1, 9 * W + 3, std::size_t(5000)}) {
      INFO("isa " << to_string(isa) << ", n = " << n);
      const std::vector<TestType> H = make_cases<TestType>(n, 20261127 + n);
      std::vector<TestType> R(9 * n);
      fit_rotations(H.data(), R.data(), n, RotationMethod::axis_angle, 1);
      const std::vector<TestType> R1 = fit_in_pieces(H, n, W), R2 = fit_in_pieces(H, n, 1);
      CHECK(differing(R.data(), R1) == 0);
      CHECK(differing(R.data(), R2) == 0);
    }
  }
}

TEMPLATE_TEST_CASE("fit_rotations: a batch written past the caches is fitted bitwise as in pieces", "[batch]", float,
                   double) {
  // From 8 MiB of rotations on, fit_rotations writes R by non-temporal stores where the ISA has them
  // (fit_rotations.cpp, kStreamBytes; kernels/rotation/axis_angle.hpp, fit_range_axis_angle's kStream), only
  // where the stride (n) is a multiple of the lanes and from the first matrix whose rows start on a vector
  // boundary: the matrices before it as below the threshold. The same n matrices fitted in pieces of 4,096
  // (below it) must give the same bits for every alignment of R (a misaligned streaming store faults), with n a
  // multiple of every lane width and not, on one thread and two (each chunk of 2,048 aligned apart).
  // fit_rotations_interleaved streams each tile's rotations from its whole 64-byte lines on (copy_streaming): the
  // same bits as the planar fit, transposed, at every offset, and in place.
  using T = TestType;
  const IsaGuard guard;
  const std::size_t big = (std::size_t(8) << 20) / (9 * sizeof(T)) + 64, piece = 4096;
  for (std::size_t n : {big, big + 3}) {
    const std::vector<T> H = make_cases<T>(n, 20261128 + n);
    const std::vector<T> Hi = interleaved(H, n);
    for (Isa isa : supported_isas()) {
      set_isa(isa);
      const std::vector<T> expected = fit_in_pieces(H, n, piece), expected_i = interleaved(expected, n);
      // R at every offset from a 64-byte boundary that a vector's alignment can tell apart (0 .. 15 values).
      std::vector<T> storage(9 * n + 64 / sizeof(T) + 16);
      const auto base = reinterpret_cast<std::uintptr_t>(storage.data());
      T* aligned = storage.data() + (64 - base % 64) % 64 / sizeof(T);
      for (std::size_t offset : {0, 1, 5, 8, 15})
        for (int threads : {1, 2}) {
          INFO("isa " << to_string(isa) << ", n = " << n << ", R offset " << offset << ", threads " << threads);
          T* R = aligned + offset;
          std::fill(R, R + 9 * n, T(-3));
          fit_rotations(H.data(), R, n, RotationMethod::axis_angle, threads);
          CHECK(differing(R, expected) == 0);
          std::fill(R, R + 9 * n, T(-3));
          fit_rotations_interleaved(Hi.data(), R, n, RotationMethod::axis_angle, threads);
          CHECK(differing(R, expected_i) == 0);
          std::copy(Hi.begin(), Hi.end(), R);
          fit_rotations_interleaved(R, R, n, RotationMethod::axis_angle, threads);  // in place
          CHECK(differing(R, expected_i) == 0);
        }
    }
  }
}

TEMPLATE_TEST_CASE("fit_rotations: n = 0, bad input, threads", "[batch]", float, double) {
  using T = TestType;
  fit_rotations<T>(nullptr, nullptr, 0);  // nothing to do, nothing touched
  const std::size_t n = 20000;
  std::vector<T> H = make_cases<T>(n, 7), R1(9 * n), R2(9 * n);
  fit_rotations(H.data(), R1.data(), n, RotationMethod::axis_angle, 1);
  fit_rotations(H.data(), R2.data(), n, RotationMethod::axis_angle, 0);
  CHECK(R1 == R2);  // bitwise: each matrix is computed by the same code whatever the thread
  std::vector<T> R3(9 * n, T(5));
  H[4 * n + 123] = std::numeric_limits<T>::quiet_NaN();
  CHECK_THROWS_WITH(fit_rotations(H.data(), R3.data(), n),
                    Catch::Matchers::ContainsSubstring("matrix 123, entry (1, 1)"));
  CHECK(R3 == std::vector<T>(9 * n, T(5)));  // nothing written
  // The finite check works on exponent bits: infinities of either sign and the very last entry are caught,
  // while the largest finite and the subnormal values pass.
  constexpr T inf = std::numeric_limits<T>::infinity();
  for (T bad : {inf, -inf, -std::numeric_limits<T>::quiet_NaN()}) {
    std::vector<T> Hb = make_cases<T>(n, 7);
    Hb[9 * n - 1] = bad;
    CHECK_THROWS_WITH(fit_rotations(Hb.data(), R3.data(), n),
                      Catch::Matchers::ContainsSubstring("matrix 19999, entry (2, 2)"));
  }
  std::vector<T> Hf = make_cases<T>(n, 7);
  Hf[5] = std::numeric_limits<T>::max();
  Hf[6] = -std::numeric_limits<T>::max();
  Hf[7] = std::numeric_limits<T>::denorm_min();
  Hf[8] = -std::numeric_limits<T>::min() / T(2);
  CHECK_NOTHROW(fit_rotations(Hf.data(), R3.data(), n));
}

TEMPLATE_TEST_CASE("fit_rotations_interleaved: the planar fits bitwise, in place, bad input, cancel", "[batch]", float,
                   double) {
  using T = TestType;
  const IsaGuard guard;
  fit_rotations_interleaved<T>(nullptr, nullptr, 0);  // nothing to do, nothing touched
  // Sizes around the tile (128 matrices) and the chunk (2,048): tails of every length within both.
  for (std::size_t n : {std::size_t(1), std::size_t(127), std::size_t(129), std::size_t(2047), std::size_t(4100)}) {
    const std::vector<T> H = make_cases<T>(n, 11 + n);  // planar, 3 x 3 x n
    const std::vector<T> Hi = interleaved(H, n);        // the same matrices interleaved, n x 3 x 3
    for (Isa isa : supported_isas()) {
      set_isa(isa);
      for (RotationMethod method : all_rotation_methods) {
        INFO("isa " << to_string(isa) << ", method " << to_string(method) << ", n = " << n);
        std::vector<T> R(9 * n), Ri(9 * n, T(-7));
        fit_rotations(H.data(), R.data(), n, method);
        // The same stages on the same values in the same lanes' code: bitwise, whatever the threads.
        for (int threads : {1, 0}) {
          fit_rotations_interleaved(Hi.data(), Ri.data(), n, method, threads);
          bool same = true;
          for (std::size_t i = 0; i < n; ++i)
            for (std::size_t e = 0; e < 9; ++e) same = same && Ri[9 * i + e] == R[e * n + i];
          CHECK(same);
        }
        std::vector<T> in_place = Hi;
        fit_rotations_interleaved(in_place.data(), in_place.data(), n, method, 0);
        CHECK(in_place == Ri);
      }
    }
  }
  const std::size_t n = 20000;
  std::vector<T> H(9 * n), R(9 * n, T(5));
  for (std::size_t i = 0; i < 9 * n; ++i) H[i] = T(std::sin(double(i)));
  constexpr T inf = std::numeric_limits<T>::infinity();
  for (T bad : {std::numeric_limits<T>::quiet_NaN(), inf, -inf}) {
    for (std::size_t at : {std::size_t(9 * 123 + 4), 9 * n - 1}) {
      std::vector<T> Hb = H;
      Hb[at] = bad;
      const std::string where = "H[" + std::to_string(at / 9) + ", " + std::to_string(at % 9 / 3) + ", " +
                                std::to_string(at % 3) + "] is NaN or infinite";
      for (int threads : {1, 0}) {
        CHECK_THROWS_WITH(fit_rotations_interleaved(Hb.data(), R.data(), n, RotationMethod::axis_angle, threads),
                          Catch::Matchers::ContainsSubstring(where));
        CHECK(R == std::vector<T>(9 * n, T(5)));  // nothing written
      }
    }
  }
  // A check that says stop at its third question: Cancelled, after two chunks of 2,048 at most were fitted.
  int asked = 0;
  const CancelCheck cancel = [&] { return ++asked > 2; };
  CHECK_THROWS_AS(fit_rotations_interleaved(H.data(), R.data(), n, RotationMethod::axis_angle, 1, nullptr, cancel),
                  Cancelled);
  CHECK(asked == 3);
  CHECK(std::all_of(R.begin() + 9 * 2 * 2048, R.end(), [](T r) { return r == T(5); }));
}

TEST_CASE("ISA names and forcing", "[batch]") {
  const auto isas = supported_isas();
  REQUIRE(!isas.empty());
  CHECK(isas.front() == Isa::scalar);
  std::cout << "supported ISAs:";
  for (Isa isa : isas) std::cout << ' ' << to_string(isa);
  std::cout << "; active: " << to_string(active_isa()) << '\n';
  for (Isa isa : mlsdeform::testing::architecture_isas())
    if (std::find(isas.begin(), isas.end(), isa) == isas.end())
      WARN("ISA " << to_string(isa) << " not supported by this CPU: its kernels are not tested here");
}
