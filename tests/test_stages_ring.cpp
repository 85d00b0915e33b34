// The stage tests of docs/design.md for the ARAP steps' one-ring sums: the local step's ring_correlation and the
// global step's ring_rhs, each SIMD twin (kernels/arap/) against its scalar reference
// (core/src/arap/ring_correlation.cpp), on every ISA the CPU runs, at sizes around the lane width and the block,
// through the stage entries of tests/stages/. Each pair is two bodies (the scalar one over the CSR one-rings, the
// SIMD one over padded blocks or a row of b_i per lane) with the same plain operations in the same order:
// bitwise. The sums are also held against long double (tests/stages/table.hpp's gamma_k). The paper's stages:
// tests/test_stages.cpp.
#include "tests/stages/table.hpp"

#include "core/src/arap/ring_correlation.hpp"

#include "kernels/contract.hpp"

#include "tests/support/catch.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <vector>

using namespace mlsdeform;
using namespace mlsdeform::testing::stages;

namespace {

/// A random graph of n vertices as CSR one-rings (the stages' input): valences 0 to 9 (a vertex may repeat in a
/// ring, or be its own neighbour: the stages do not care), w_ij in (0, 1] and w_ij (p_i - p_j) in [-1, 1], from g.
struct RandomRings {
  std::vector<Eigen::Index> start{0}, nbr;
  std::vector<double> w, we;
  mlsdeform::detail::PaddedRings padded;
  RandomRings(std::size_t n, std::mt19937_64& g) {
    std::uniform_real_distribution<double> u(-1, 1);
    std::uniform_int_distribution<int> valence(0, 9);
    std::uniform_int_distribution<std::size_t> vertex(0, n - 1);
    for (std::size_t i = 0; i < n; ++i) {
      for (int k = valence(g); k > 0; --k) {
        nbr.push_back(Eigen::Index(vertex(g)));
        w.push_back((u(g) + 1) / 2);
        for (int c = 0; c < 3; ++c) we.push_back(u(g));
      }
      start.push_back(Eigen::Index(nbr.size()));
    }
    padded = mlsdeform::detail::pad_one_rings(start, nbr, w, we);
  }
};

/// The ARAP local step's one-ring sums (ring_correlation) on a random graph of n vertices (RandomRings) and x
/// in [-1, 1]. The SIMD twin's H and energy record must be the scalar reference's bit for
/// bit (the same plain products and sums in the same order, the padding adding exact zeros; the exact power-of-
/// two scaling), with and without the energy, at x's scale and at 2^-1040 (S_i below 2^-1000: the scaling's
/// two factors; underflow then spoils the sums, but both sides alike), whole and cut into two block ranges.
/// Against long double, at scale 1: the raw sums within gamma_{K+1} sum_j |x_i - x_j| |a_j| (K the valence,
/// ring_correlation.hpp derives it) and the energy sum within gamma_{K+5} sum_j w_ij |x_i - x_j|^2; H is then
/// exactly T(S_i 2^-ilogb(max |S_i|)) of the raw sums.
template <class T>
void check_ring_correlation(const StageEntries<T>& simd, const StageEntries<T>& scalar, std::size_t n) {
  std::mt19937_64 g(28 + n);
  const RandomRings rings(n, g);
  const auto &start = rings.start, &nbr = rings.nbr;
  const auto &w = rings.w, &we = rings.we;
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> x(3 * n);
  for (double& v : x) v = u(g);
  const std::size_t blocks = (n + kernels::kLanes - 1) / kernels::kLanes;
  const T nan = std::numeric_limits<T>::quiet_NaN();
  for (const double scale : {1.0, 0x1p-1040})
    for (const bool energy : {false, true}) {
      std::vector<double> xs(x);
      for (double& v : xs) v *= scale;
      struct Out {
        std::vector<T> H;
        std::vector<double> ring;
      };
      auto run_entry = [&](const StageEntries<T>& t, std::size_t cut) {
        Out o{std::vector<T>(9 * n, nan), std::vector<double>(energy ? 10 * n : 0, double(nan))};
        const kernels::RingFrame<T> fr = mlsdeform::detail::ring_frame<T>(n, xs.data(), start, nbr, w, we, rings.padded,
                                                                          o.H.data(), energy ? o.ring.data() : nullptr);
        t.ring_correlation(fr, 0, cut);
        t.ring_correlation(fr, cut, blocks);
        return o;
      };
      const Out ref = run_entry(scalar, blocks), got = run_entry(simd, blocks), cut = run_entry(simd, blocks / 2);
      INFO("ring_correlation on " << n << " vertices, scale " << scale << (energy ? ", with energy" : ""));
      CHECK(std::none_of(ref.H.begin(), ref.H.end(), [](T v) { return std::isnan(v); }));
      // Bit for bit; memcmp only on non-empty arrays (an empty vector's data() may be null, which memcmp must
      // not be given even for zero bytes: UBSan).
      const auto same_bits = [](const auto& a, const auto& b) {
        return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0);
      };
      CHECK(same_bits(got.H, ref.H));
      CHECK(same_bits(cut.H, ref.H));
      CHECK(same_bits(got.ring, ref.ring));
      if (scale != 1.0 || !energy) continue;
      for (std::size_t i = 0; i < n; ++i) {
        const int K = int(start[i + 1] - start[i]);
        LD S[9] = {}, Sabs[9] = {}, dd = 0, dd_abs = 0;
        for (Eigen::Index e = start[i]; e < start[i + 1]; ++e) {
          const std::size_t j = std::size_t(nbr[std::size_t(e)]);
          LD d[3];
          for (std::size_t c = 0; c < 3; ++c) d[c] = LD(x[3 * i + c]) - LD(x[3 * j + c]);
          for (std::size_t k = 0; k < 9; ++k) {
            const LD t = d[k / 3] * LD(we[3 * std::size_t(e) + k % 3]);
            S[k] += t, Sabs[k] += std::abs(t);
          }
          const LD t = LD(w[std::size_t(e)]) * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
          dd += t, dd_abs += t;
        }
        const double* raw = ref.ring.data() + 10 * i;
        double m = 0;
        for (std::size_t k = 0; k < 9; ++k) {
          CHECK(std::abs(LD(raw[k]) - S[k]) <= gamma<double>(K + 1) * Sabs[k]);
          m = std::max(m, std::abs(raw[k]));
        }
        CHECK(std::abs(LD(raw[9]) - dd) <= gamma<double>(K + 5) * dd_abs);
        for (std::size_t k = 0; k < 9; ++k) {
          const T want = m > 0 ? T(std::ldexp(raw[k], -std::ilogb(m))) : T(raw[k]);
          CHECK(std::memcmp(&ref.H[k * n + i], &want, sizeof(T)) == 0);
        }
      }
    }
}

/// The global step's rotated one-ring sums (ring_rhs) on a random graph of n vertices (RandomRings), with random R_i^T
/// in T (entries in [-1, 1]: the stage does not need rotations) and c_i, w_ij (p_i - p_j) in [-1, 1]. The SIMD
/// twin's b must be the scalar reference's bit for bit (the same plain products and sums in the same order),
/// whole and cut into two block ranges, with a NaN in the padding value after the last R_j (the twin's spare
/// lane reads it and must drop it). Against long double: b_ir within gamma_{K+3} of half the sum of |R_rk a_k|
/// over its K + 1 terms (ring_correlation.hpp derives it).
template <class T>
void check_ring_rhs(const StageEntries<T>& simd, const StageEntries<T>& scalar, std::size_t n) {
  std::mt19937_64 g(29 + n);
  const RandomRings rings(n, g);
  const auto &start = rings.start, &nbr = rings.nbr;
  const auto& we = rings.we;
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> c(3 * n);
  for (double& v : c) v = u(g);
  std::vector<T> Rt(9 * n + 1);
  for (T& v : Rt) v = T(u(g));
  Rt.back() = std::numeric_limits<T>::quiet_NaN();
  const std::size_t blocks = (n + kernels::kLanes - 1) / kernels::kLanes;
  auto run_entry = [&](const StageEntries<T>& t, std::size_t cut) {
    std::vector<double> b(3 * n, std::numeric_limits<double>::quiet_NaN());
    const kernels::RingFrame<T> fr = mlsdeform::detail::ring_frame<T>(n, nullptr, start, nbr, rings.w, we, rings.padded,
                                                                      nullptr, nullptr, Rt.data(), c.data(), b.data());
    t.ring_rhs(fr, 0, cut);
    t.ring_rhs(fr, cut, blocks);
    return b;
  };
  const std::vector<double> ref = run_entry(scalar, blocks), got = run_entry(simd, blocks),
                            cut = run_entry(simd, blocks / 2);
  INFO("ring_rhs on " << n << " vertices");
  CHECK(std::none_of(ref.begin(), ref.end(), [](double v) { return std::isnan(v); }));
  CHECK(std::memcmp(got.data(), ref.data(), got.size() * sizeof(double)) == 0);
  CHECK(std::memcmp(cut.data(), ref.data(), cut.size() * sizeof(double)) == 0);
  for (std::size_t i = 0; i < n; ++i) {
    const int K = int(start[i + 1] - start[i]);
    for (std::size_t r = 0; r < 3; ++r) {
      LD exact = 0, bound = 0;
      const auto term = [&](std::size_t j, const double* a) {
        for (std::size_t k = 0; k < 3; ++k) {
          const LD t = LD(Rt[9 * j + 3 * k + r]) * LD(a[k]);  // R_rk = (R^T)_kr
          exact += t / 2, bound += std::abs(t) / 2;
        }
      };
      term(i, c.data() + 3 * i);
      for (Eigen::Index e = start[i]; e < start[i + 1]; ++e)
        term(std::size_t(nbr[std::size_t(e)]), we.data() + 3 * std::size_t(e));
      CHECK(std::abs(LD(ref[3 * i + r]) - exact) <= gamma<double>(K + 3) * bound);
    }
  }
}

}  // namespace

TEMPLATE_TEST_CASE("the rotated one-ring sums' SIMD stage agrees with its scalar twin on every ISA", "[stages][isa]",
                   float, double) {
  for_each_simd_table<TestType>([](const StageEntries<TestType>& simd, const StageEntries<TestType>& scalar) {
    constexpr std::size_t B = kernels::kLanes;  // sizes around the block the stage's ranges are in
    for (std::size_t n : {std::size_t(1), std::size_t(2), B - 1, B, B + 1, 2 * B + 3, 5 * B}) {
      INFO(n << " vertices");
      check_ring_rhs<TestType>(simd, scalar, n);
    }
  });
}

TEMPLATE_TEST_CASE("the one-ring sums' SIMD stage agrees with its scalar twin on every ISA", "[stages][isa]", float,
                   double) {
  for_each_simd_table<TestType>([](const StageEntries<TestType>& simd, const StageEntries<TestType>& scalar) {
    // Sizes around the lane width and around the block of kLanes vertices the sums work in.
    const std::size_t W = simd.width;
    constexpr std::size_t B = kernels::kLanes;
    std::set<std::size_t> sizes = {1, W - 1, W, W + 1, 2 * W + 3, 3 * W, B - 1, B, B + 1, 2 * B + 3, 5 * B};
    sizes.erase(0);
    for (std::size_t n : sizes) {
      INFO(n << " vertices");
      check_ring_correlation<TestType>(simd, scalar, n);
    }
  });
}
