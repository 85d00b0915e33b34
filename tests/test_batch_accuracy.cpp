// The batched rotation fit (fit_rotations, SIMD lanes) on the accuracy suite's case families, held to the
// same bounds as the scalar fit (tests/support/accuracy_bounds.hpp) on every ISA this CPU runs: what
// tests/test_rotation_accuracy.cpp checks one matrix at a time, checked here a structure-of-arrays batch at a
// time, for the two methods that have SIMD kernels (axis_angle, horn_quaternion by Jacobi in lanes).
//
// MLSDEFORM_SEED as in the scalar suite; MLSDEFORM_BATCH_CASES sets the matrices per family and precision
// (default 4,000; 400 under the sanitizers and under an emulator); MLSDEFORM_SUBNORMAL_CASES the matrices per
// family and subnormal scale (default 3). The families' order within a batch is interleaved so that every SIMD
// batch mixes families (a lane's result must not depend on its neighbours).
#include "tests/support/accuracy_bounds.hpp"
#include "tests/support/isa_guard.hpp"
#include "tests/support/rotation_cases.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#if defined(__SSE2__)
#include <xmmintrin.h>  // MXCSR: flush-to-zero and denormals-are-zero
#endif

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

using namespace mlsdeform;
using namespace mlsdeform::testing;

namespace {

template <class T>
const char* type_name() {
  return std::is_same_v<T, float> ? "float" : "double";
}

template <class T>
void batched_families() {
  const std::uint64_t seed = env_u64("MLSDEFORM_SEED", 20261121);
  const std::uint64_t per_family =
      env_u64("MLSDEFORM_BATCH_CASES", built_with_sanitizer() || run_emulated() ? 400 : 4000);
  const auto families = all_families();
  // Case i of family f sits at index i * F + f: consecutive lanes hold different families.
  const std::size_t F = families.size(), n = per_family * F;
  std::vector<Case<T>> cases(n);
  std::vector<Reference> refs(n);
  std::vector<T> H(9 * n);
  for (std::size_t i = 0; i < per_family; ++i)
    for (std::size_t f = 0; f < F; ++f) {
      const std::size_t k = i * F + f;
      cases[k] = make_case<T>(families[f].family, seed, i);
      refs[k] = reference(cases[k].H);
      for (std::size_t e = 0; e < 9; ++e) H[e * n + k] = cases[k].H(e / 3, e % 3);
    }
  const IsaGuard guard;  // restores the ISA in force, also when a check throws
  for (Isa isa : supported_isas()) {
    set_isa(isa);
    for (RotationMethod m : {RotationMethod::axis_angle, RotationMethod::horn_quaternion}) {
      std::vector<T> R(9 * n, T(-7));
      fit_rotations(H.data(), R.data(), n, m);
      std::map<std::string, std::uint64_t> beyond;  // per family
      std::map<std::string, std::string> first;
      for (std::size_t k = 0; k < n; ++k) {
        Matrix3<T> Rk;
        for (std::size_t e = 0; e < 9; ++e) Rk(e / 3, e % 3) = R[e * n + k];
        const std::string v = violations<T>(measure(Rk, cases[k].H, refs[k]), refs[k], m);
        if (v.empty()) continue;
        const std::string key = std::string(type_name<T>()) + " " + std::string(to_string(m)) + " on " +
                                std::string(to_string(cases[k].family));
        if (beyond[key]++ == 0) first[key] = describe(cases[k]) + ":" + v;
      }
      std::ostringstream regular;  // families held to the bound
      for (const auto& [key, count] : beyond) {
        regular << "\n  " << key << ": " << count << " of " << per_family << " cases; first: " << first[key];
      }
      INFO("isa " << to_string(isa) << ", batched " << to_string(m) << ", cases beyond the bound:" << regular.str());
      CHECK(regular.str().empty());
    }
  }
}

}  // namespace

TEMPLATE_TEST_CASE("fit_rotations passes the accuracy suite's families on every ISA", "[batch][accuracy]", float,
                   double) {
  batched_families<TestType>();
}

// The scalar suite's reproducers (test_rotation_accuracy.cpp), in the lanes: the coplanar double case that
// the first-generation fit missed, alone in a batch and beside padding lanes, on every ISA.
TEST_CASE("fit_rotations: the coplanar reproducer (double, kappa 2e4) on every ISA", "[batch][accuracy]") {
  Matrix3<double> H;
  H << -0x1.dd8422e0ca639p-7, 0x1.3fe63d7696e59p-4, -0x1.dd2b853ca4a34p-4, -0x1.1f67292ca715dp-3, 0x1.7fa7cb8ced28bp-1,
      -0x1.1e089e4fced31p+0, 0x1.da973e9396783p-10, -0x1.395efcf53904fp-7, 0x1.d2c7a5e02c79p-7;
  const Reference ref = reference(H);
  const IsaGuard guard;  // restores the ISA in force, also when a check throws
  for (Isa isa : supported_isas()) {
    set_isa(isa);
    for (RotationMethod m : {RotationMethod::axis_angle, RotationMethod::horn_quaternion}) {
      std::vector<double> Hs(9), R(9);
      for (int e = 0; e < 9; ++e) Hs[e] = H(e / 3, e % 3);
      fit_rotations(Hs.data(), R.data(), 1, m);
      Matrix3<double> Rm;
      for (int e = 0; e < 9; ++e) Rm(e / 3, e % 3) = R[e];
      const std::string v = violations<double>(measure(Rm, H, ref), ref, m);
      INFO("isa " << to_string(isa) << ", " << to_string(m) << ":" << v);
      CHECK(v.empty());
    }
  }
}

namespace {

/// Runs fit_rotations on the 3 x 3 x n array H (threads: 1 = on this thread) and returns matrix k of R.
template <class T>
std::vector<Matrix3<T>> fit_all(const std::vector<Matrix3<T>>& H, RotationMethod m, int threads = 0) {
  const std::size_t n = H.size();
  std::vector<T> soa(9 * n), R(9 * n, T(-7));
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t e = 0; e < 9; ++e) soa[e * n + k] = H[k](e / 3, e % 3);
  fit_rotations(soa.data(), R.data(), n, m, threads);
  std::vector<Matrix3<T>> out(n);
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t e = 0; e < 9; ++e) out[k](e / 3, e % 3) = R[e * n + k];
  return out;
}

/// The subnormal scales of T: the largest entry of H in [2^b, 2^(b + 1)) for b = lo .. hi, from denorm_min
/// (2^-149, 2^-1074) to the smallest normal binade (2^-126, 2^-1022).
template <class T>
constexpr int subnormal_lo = std::numeric_limits<T>::min_exponent - std::numeric_limits<T>::digits;
template <class T>
constexpr int subnormal_hi = std::numeric_limits<T>::min_exponent - 1;

/// Every family of the suite at every subnormal scale b, per ISA and batched method:
///  exact  H = Q 2^b with Q the family's H scaled to [1, 2) and rounded to the grid 2^(lo - b), so that Q 2^b
///         is exactly representable (integers times 2^lo): fit_rotations normalises by exact powers of two,
///         so the result must be bitwise the result for Q itself, which is held to the suite's bounds;
///  rounded  the family's H scaled to 2^b and rounded to T (subnormal entries keep few bits): held to the
///         suite's bounds for the matrix it is (c_b = 16, every check), and within twice the angle bound of
///         the scalar fit_rotation where the optimum is unique; for exact_rotation (H = s R + dH, R known), R
///         is recovered to the angle bound plus the rounding's own effect: Davenport's K of s R has eigengap
///         4 s and |dK|_2 <= 2 |dH|_F, so its top eigenvector turns by theta with sin theta <= 2 |dK|_2 / gap
///         (Davis-Kahan, in the form of Yu, Wang and Samworth 2015) <= |dH|_F / s, the rotation by 2 theta.
template <class T>
void subnormal_families() {
  using LD = long double;
  const std::uint64_t seed = env_u64("MLSDEFORM_SEED", 20261121);
  const std::uint64_t per_scale = env_u64("MLSDEFORM_SUBNORMAL_CASES", 3);
  const int lo = subnormal_lo<T>, hi = subnormal_hi<T>;
  struct Item {
    Case<T> c;
    int b = 0;
    Matrix3<T> Q, exact, rounded;
    LD factor = 0;  // rounded = factor H_exact + its rounding
  };
  std::vector<Item> items;
  for (std::uint64_t i = 0; i < per_scale; ++i)
    for (int b = lo; b <= hi; ++b)
      for (const FamilyInfo& f : all_families()) {  // consecutive lanes: different families and scales
        Item it;
        it.c = make_case<T>(f.family, seed, i * std::uint64_t(hi - lo + 1) + std::uint64_t(b - lo));
        it.b = b;
        const LD m = it.c.H_exact.cwiseAbs().maxCoeff();
        const int e = m > 0 ? std::ilogb(m) : 0;
        const Matrix3L unit = it.c.H_exact * std::ldexp(LD(1), -e);
        const LD grid = std::ldexp(LD(1), lo - b);
        for (int r = 0; r < 3; ++r)
          for (int s = 0; s < 3; ++s) {
            it.Q(r, s) = T(std::nearbyint(unit(r, s) / grid) * grid);
            it.exact(r, s) = T(std::ldexp(LD(it.Q(r, s)), b));
            it.rounded(r, s) = T(std::ldexp(unit(r, s), b));
            REQUIRE(LD(it.exact(r, s)) == std::ldexp(LD(it.Q(r, s)), b));  // exactly representable
          }
        it.factor = std::ldexp(LD(1), b - e);
        items.push_back(it);
      }
  const std::size_t n = items.size();
  std::vector<Matrix3<T>> Q(n), exact(n), rounded(n);
  for (std::size_t k = 0; k < n; ++k) Q[k] = items[k].Q, exact[k] = items[k].exact, rounded[k] = items[k].rounded;
  const IsaGuard guard;  // restores the ISA in force, also when a check throws
  for (RotationMethod m : {RotationMethod::axis_angle, RotationMethod::horn_quaternion}) {
    std::vector<Matrix3<T>> scalar(n);
    for (std::size_t k = 0; k < n; ++k) scalar[k] = fit_rotation(rounded[k], m);
    for (Isa isa : supported_isas()) {
      set_isa(isa);
      const std::vector<Matrix3<T>> RQ = fit_all(Q, m), Re = fit_all(exact, m), Rr = fit_all(rounded, m);
      std::map<std::string, std::uint64_t> beyond;
      std::map<std::string, std::string> first;
      auto fail = [&](const Item& it, const char* what, const std::string& v) {
        const std::string key = std::string(what) + " " + std::string(to_string(it.c.family));
        if (beyond[key]++ == 0) first[key] = "2^" + std::to_string(it.b) + ", " + describe(it.c) + ":" + v;
      };
      for (std::size_t k = 0; k < n; ++k) {
        const Item& it = items[k];
        if (Re[k] != RQ[k]) fail(it, "exact: not bitwise the unit-scale result on", " R = [" + hex(Re[k]) + "]");
        if (const std::string v = violations<T>(measure(RQ[k], Q[k], reference(Q[k])), reference(Q[k]), m); !v.empty())
          fail(it, "exact: unit-scale Q beyond the bound on", v);
        const Reference ref = reference(rounded[k]);
        if (const std::string v = violations<T>(measure(Rr[k], rounded[k], ref), ref, m); !v.empty())
          fail(it, "rounded: beyond the bound on", v);
        if (ref.unique()) {
          const LD tol = 2 * tol_angle<T>(ref.kappa, m);
          const LD a = rotation_angle(Rr[k].template cast<LD>(), scalar[k].template cast<LD>());
          if (tol < std::numbers::pi_v<LD> && !(a <= tol))
            fail(it, "rounded: away from the scalar fit on", " angle " + std::to_string(double(a)));
        }
        if (it.c.family == Family::exact_rotation) {
          const LD turn = (rounded[k].template cast<LD>() - it.factor * it.c.H_exact).norm() / it.factor;
          const LD tol = tol_angle<T>(ref.kappa, m) + 2 * std::asin(std::min<LD>(turn, 1));
          const LD a = rotation_angle(Rr[k].template cast<LD>(), it.c.H_exact);
          if (tol < std::numbers::pi_v<LD> && !(a <= tol))
            fail(it, "rounded: away from the known rotation on", " angle " + std::to_string(double(a)));
        }
      }
      std::ostringstream out;
      for (const auto& [key, count] : beyond) out << "\n  " << key << ": " << count << " cases; first: " << first[key];
      INFO(type_name<T>() << ", isa " << to_string(isa) << ", batched " << to_string(m) << ", " << n
                          << " matrices, scales 2^" << lo << " .. 2^" << hi << ":" << out.str());
      CHECK(out.str().empty());
    }
  }
}

}  // namespace

TEMPLATE_TEST_CASE("fit_rotations at subnormal scales on every ISA: the unit-scale result, the suite's bounds",
                   "[batch][accuracy][subnormal]", float, double) {
  subnormal_families<TestType>();
}

TEMPLATE_TEST_CASE("fit_rotations: H = 0, -0, denorm_min I and mixed signed zeros give rotations on every ISA",
                   "[batch][subnormal]", float, double) {
  using T = TestType;
  using L = std::numeric_limits<T>;
  const T z = T(0), nz = -T(0), d = L::denorm_min();
  Matrix3<T> mixed;
  mixed << nz, z, nz, z, nz, z, nz, nz, z;
  Matrix3<T> tiny_rotation;  // a quarter turn about z, at the smallest scale
  tiny_rotation << 0, -d, 0, d, 0, 0, 0, 0, d;
  Matrix3<T> quarter;
  quarter << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  // Padded beside ordinary lanes, so that every lane of a batch is checked next to the others.
  std::vector<Matrix3<T>> H = {Matrix3<T>::Zero(), Matrix3<T>::Constant(nz), mixed,  d * Matrix3<T>::Identity(),
                               tiny_rotation,      Matrix3<T>::Identity(),   quarter};
  const std::vector<Matrix3<T>> expected = {Matrix3<T>::Identity(),
                                            Matrix3<T>::Identity(),
                                            Matrix3<T>::Identity(),
                                            Matrix3<T>::Identity(),
                                            quarter,
                                            Matrix3<T>::Identity(),
                                            quarter};
  const IsaGuard guard;  // restores the ISA in force, also when a check throws
  for (Isa isa : supported_isas()) {
    set_isa(isa);
    for (RotationMethod m : {RotationMethod::axis_angle, RotationMethod::horn_quaternion}) {
      const std::vector<Matrix3<T>> R = fit_all(H, m);
      for (std::size_t k = 0; k < H.size(); ++k) {
        INFO(type_name<T>() << ", isa " << to_string(isa) << ", " << to_string(m) << ", H = [" << hex(H[k])
                            << "], R = [" << hex(R[k]) << "]");
        // H = 0 gives the identity exactly; the others are exact rotations (singular values equal, kappa 1):
        // within the suite's angle bound at kappa = 1 of the known one.
        if (k < 3) {
          CHECK(R[k] == Matrix3<T>::Identity());
        } else {
          CHECK(rotation_angle(R[k].template cast<long double>(), expected[k].template cast<long double>()) <=
                tol_angle<T>(1, m));
        }
      }
    }
  }
}

namespace {

/// Sets flush-to-zero and denormals-are-zero on this thread (as a library built with -ffast-math does for
/// a whole process when loaded), and restores the control register when it goes, also when a check throws.
/// x86: MXCSR's FTZ and DAZ bits; aarch64: FPCR's FZ bit, which flushes subnormal inputs and outputs both;
/// elsewhere nothing (the test then checks the default mode).
class FlushToZero {
 public:
#if defined(__SSE2__)
  FlushToZero() : saved_(_mm_getcsr()) { _mm_setcsr(saved_ | 0x8040u); }  // FTZ (bit 15) | DAZ (bit 6)
  ~FlushToZero() { _mm_setcsr(saved_); }
#elif defined(__aarch64__)
  FlushToZero() : saved_(fpcr()) { set_fpcr(saved_ | (std::uint64_t(1) << 24)); }  // FZ (bit 24)
  ~FlushToZero() { set_fpcr(saved_); }
#endif
  FlushToZero(const FlushToZero&) = delete;
  FlushToZero& operator=(const FlushToZero&) = delete;

 private:
#if defined(__SSE2__)
  unsigned saved_;
#elif defined(__aarch64__)
  static std::uint64_t fpcr() {
    std::uint64_t r;
    asm volatile("mrs %0, fpcr" : "=r"(r));
    return r;
  }
  static void set_fpcr(std::uint64_t r) { asm volatile("msr fpcr, %0" : : "r"(r)); }
  std::uint64_t saved_;
#endif
};

}  // namespace

TEMPLATE_TEST_CASE("fit_rotations under flush-to-zero and denormals-are-zero: rotations on every ISA",
                   "[batch][subnormal]", float, double) {
  // With DAZ a subnormal H reads as zero (the identity, in the scalar code as in the lanes) and with FTZ
  // tiny intermediates vanish: results may differ from the default mode's, but each must still be a rotation
  // (the suite's orthonormality and det bounds). Every family at unit scale and at the subnormal scales.
  using T = TestType;
  std::vector<Matrix3<T>> H;
  for (const FamilyInfo& f : all_families())
    for (std::uint64_t i = 0; i < 16; ++i) {
      const Matrix3<T> Hc = make_case<T>(f.family, 7, i).H;
      H.push_back(Hc);
      const T m = Hc.cwiseAbs().maxCoeff();
      if (m > 0) H.push_back(Hc * std::ldexp(T(1), -std::ilogb(m) + subnormal_lo<T> + int(i % 24)));
    }
  const IsaGuard guard;  // restores the ISA in force, also when a check throws
  const FlushToZero ftz;
  for (Isa isa : supported_isas()) {
    set_isa(isa);
    for (RotationMethod m : {RotationMethod::axis_angle, RotationMethod::horn_quaternion}) {
      const std::vector<Matrix3<T>> R = fit_all(H, m, 1);  // on this thread: MXCSR / FPCR is per thread
      std::size_t bad = 0;
      std::string first;
      for (std::size_t k = 0; k < H.size(); ++k) {
        const Errors e = measure(R[k], H[k], reference(H[k]));
        if (e.finite && e.orthonormality <= tol_orthonormality<T>() && e.det_error <= tol_det<T>()) continue;
        if (bad++ == 0) first = "H = [" + hex(H[k]) + "], R = [" + hex(R[k]) + "]";
      }
      INFO(type_name<T>() << ", isa " << to_string(isa) << ", " << to_string(m) << ": " << bad << " of " << H.size()
                          << " not rotations; first " << first);
      CHECK(bad == 0);
    }
  }
}
