// The batched rotation fit (fit_rotations, SIMD lanes) on the accuracy suite's case families, held to the
// same bounds as the scalar fit (tests/support/accuracy_bounds.hpp) on every ISA this CPU runs: what
// tests/test_rotation_accuracy.cpp checks one matrix at a time, checked here a structure-of-arrays batch at a
// time, for the two methods that have SIMD kernels (axis_angle, horn_quaternion by Jacobi in lanes).
//
// MLSDEFORM_SEED as in the scalar suite; MLSDEFORM_BATCH_CASES sets the matrices per family and precision
// (default 4,000; 400 under the sanitizers). The families' order within a batch is interleaved so that every
// SIMD batch mixes families (a lane's result must not depend on its neighbours).
#include "accuracy_bounds.hpp"
#include "isa_guard.hpp"
#include "rotation_cases.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include <catch2/catch.hpp>

#include <cstdint>
#include <map>
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
  const std::uint64_t per_family = env_u64("MLSDEFORM_BATCH_CASES", built_with_sanitizer() ? 400 : 4000);
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
