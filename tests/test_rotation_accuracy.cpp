// Accuracy suite for fit_rotation: every method, float and double, against the
// independent long-double SVD reference of tests/support/rotation_cases.hpp, on the random and degenerate
// case families listed there.
//
// Seed and size. The run's seed and case count are printed. Environment variables choose others:
//   MLSDEFORM_SEED=7 MLSDEFORM_CASES=10000000 build/tests/test_rotation_accuracy
// MLSDEFORM_CASES is the number of matrices H per precision, split evenly over the families; each H is
// judged for every method. MLSDEFORM_FAMILY=near_pi (a comma-separated list) restricts the families.
// (Catch2 2's prebuilt main takes no custom options, hence the environment.)
//
// Tolerances: derived in tests/support/accuracy_bounds.hpp from the precision and the conditioning (two
// operation-count constants: c_o = 64, and c_b = 16, or 64 for axis_angle and horn_matrix); the report
// tools/accuracy_report counts the cases beyond the same bounds, and beyond c_b = 16 for every method.
#include "tests/support/accuracy_bounds.hpp"
#include "tests/support/rotation_cases.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <iostream>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

using namespace mlsdeform;
using namespace mlsdeform::testing;

namespace {

/// Default number of matrices per precision: about 5 s per precision in Release on a 2-core x86-64 machine;
/// a tenth of that under AddressSanitizer (tools/dev.sh test runs the suite twice).
constexpr std::uint64_t kDefaultCases = built_with_sanitizer() ? 4000 : 40000;

struct RunConfig {
  std::uint64_t seed;
  std::uint64_t cases;  // per precision, all families together
  std::vector<Family> families;
};

const RunConfig& config() {
  static const RunConfig cfg = [] {
    RunConfig c;
    c.seed = env_u64("MLSDEFORM_SEED", kDefaultSeed);
    c.cases = env_u64("MLSDEFORM_CASES", kDefaultCases);
    const char* f = std::getenv("MLSDEFORM_FAMILY");
    if (f != nullptr && *f != '\0') {
      std::stringstream ss(f);
      std::string name;
      while (std::getline(ss, name, ',')) c.families.push_back(family_from_string(name));
    } else {
      for (const FamilyInfo& info : all_families()) c.families.push_back(info.family);
    }
    std::cout << "test_rotation_accuracy: MLSDEFORM_SEED=" << c.seed << " MLSDEFORM_CASES=" << c.cases << " ("
              << c.families.size() << " families)" << (built_with_sanitizer() ? " [sanitizer build]" : "") << std::endl;
    return c;
  }();
  return cfg;
}

template <class T>
const char* type_name() {
  return std::is_same_v<T, float> ? "float" : "double";
}

/// Collects failures per (family, method) and reports the first few of each in full.
struct FailureLog {
  static constexpr int kShown = 3;
  std::map<std::string, std::uint64_t> counts;

  void add(const std::string& key, const std::string& what) {
    if (++counts[key] > kShown) return;
    FAIL_CHECK(what);
  }
  void summarise() const {
    for (const auto& [key, n] : counts) {
      INFO(key << ": " << n << " failing cases");
      CHECK(n == 0);
    }
  }
};

template <class T>
std::string case_line(const Case<T>& c, RotationMethod m, const Reference& ref, const std::string& what) {
  std::ostringstream out;
  out.precision(6);
  out << type_name<T>() << " " << to_string(m) << ":" << what << "\n  case " << describe(c) << "\n  singular values "
      << double(ref.singular(0)) << " " << double(ref.singular(1)) << " " << double(ref.singular(2)) << " d=" << ref.d
      << " kappa=" << double(ref.kappa);
  return out.str();
}

std::string key_of(const char* type, RotationMethod m, const std::string& what) {
  return std::string(type) + " " + std::string(to_string(m)) + " " + what;
}

/// Every case family against every bound.
template <class T>
void family_accuracy(RotationMethod m, FailureLog& log) {
  const RunConfig& cfg = config();
  const std::uint64_t per_family = (cfg.cases + cfg.families.size() - 1) / cfg.families.size();
  for (Family f : cfg.families) {
    const std::string key = key_of(type_name<T>(), m, "on " + std::string(to_string(f)));
    for (std::uint64_t i = 0; i < per_family; ++i) {
      const Case<T> c = make_case<T>(f, cfg.seed, i);
      const Reference ref = reference(c.H);
      Matrix3<T> R;
      try {
        R = fit_rotation(c.H, m);
      } catch (const std::exception& ex) {
        log.add(key, case_line(c, m, ref, std::string(" threw on a finite H: ") + ex.what()));
        continue;
      }
      const std::string v = violations<T>(measure(R, c.H, ref), ref, m);
      if (!v.empty()) log.add(key, case_line(c, m, ref, v));
    }
  }
}

/// H and 2^k H (exactly representable: no entry leaves the normal range) give the same rotation:
/// bitwise for axis_angle (documented in rotation.hpp), within the angle bound for the others.
template <class T>
void power_of_two_scaling(RotationMethod m, FailureLog& log) {
  const RunConfig& cfg = config();
  const std::uint64_t n = std::max<std::uint64_t>(cfg.cases / 100, 20);
  Rng rng(cfg.seed ^ 0x5CA1Eull);
  const int kmax = std::is_same_v<T, float> ? 50 : 330;  // 2^50 ~ 1e15, 2^330 ~ 1e100
  std::uint64_t exact_scalings = 0;
  for (Family f : {Family::uniform, Family::near_pi, Family::small_angle, Family::reflected, Family::coplanar,
                   Family::collinear, Family::repeated_sv, Family::gaussian, Family::identity}) {
    const std::string key = key_of(type_name<T>(), m, "on " + std::string(to_string(f)) + " scaled by 2^k");
    for (std::uint64_t i = 0; i < n; ++i) {
      const Case<T> c = make_case<T>(f, cfg.seed, i);
      const int k = rng.integer(-kmax, kmax);
      const Matrix3<T> Hs = c.H * std::ldexp(T(1), k);
      bool exact = true;
      for (int r = 0; r < 3; ++r)
        for (int j = 0; j < 3; ++j)
          if (c.H(r, j) != T(0) && !(std::abs(Hs(r, j)) >= std::numeric_limits<T>::min() && std::isfinite(Hs(r, j))))
            exact = false;
      if (!exact) continue;
      ++exact_scalings;
      const Reference ref = reference(c.H);
      const Matrix3<T> R = fit_rotation(c.H, m), Rs = fit_rotation(Hs, m);
      const std::string by = " scaled by 2^" + std::to_string(k);
      if (m == RotationMethod::axis_angle) {
        if (R != Rs) log.add(key, case_line(c, m, ref, by + ": not bitwise identical"));
      } else if (ref.unique()) {
        // Both results are within tol_angle of the same optimum (H and 2^k H have the same one).
        const long double tol = 2 * tol_angle<T>(ref.kappa, m);
        const long double a = rotation_angle(R.template cast<long double>(), Rs.template cast<long double>());
        if (tol < std::numbers::pi_v<long double> && !(a <= tol))
          log.add(key, case_line(c, m, ref, by + ": moves by " + std::to_string(double(a)) + " rad"));
      }
    }
  }
  CHECK(exact_scalings > 0);
}

/// H = round(H_exact) and H_s = round(10^e H_exact): the two results agree to rounding.
template <class T>
void power_of_ten_scaling(RotationMethod m, FailureLog& log) {
  const RunConfig& cfg = config();
  const std::uint64_t n = std::max<std::uint64_t>(cfg.cases / 100, 20);
  const int range = std::is_same_v<T, float> ? 15 : 100;
  for (std::uint64_t i = 0; i < n; ++i) {
    const Case<T> c = make_case<T>(Family::uniform, cfg.seed, i);
    const Reference ref = reference(c.H);
    const Matrix3<T> R = fit_rotation(c.H, m);
    for (int e : {-range, -range / 2, -3, 3, range / 2, range}) {
      // Each rounding moves the entries by eps/2 relative, hence the optimum by at most
      // 2 * 2 (eps/2) ||H||_F / (2 (s2 + d s3)) <= sqrt(3) eps kappa; each result is within tol_angle of
      // the optimum of its own H.
      const Matrix3<T> Hs = (std::pow(10.0L, e) * c.H_exact).template cast<T>();
      const Matrix3<T> Rs = fit_rotation(Hs, m);
      const long double tol =
          2 * tol_angle<T>(ref.kappa, m) + 2 * std::numbers::sqrt3_v<long double> * eps<T> * ref.kappa;
      const long double a = rotation_angle(R.template cast<long double>(), Rs.template cast<long double>());
      if (!Rs.allFinite() || !(a <= tol))
        log.add(key_of(type_name<T>(), m, "on uniform scaled by 10^" + std::to_string(e)),
                case_line(c, m, ref,
                          " scaled by 1e" + std::to_string(e) + ": moves by " + std::to_string(double(a)) + " rad > " +
                              std::to_string(double(tol))));
    }
  }
}

/// Special finite matrices: extremes of the range, signs, ranks, single entries. `subnormal_max`: those
/// whose largest entry is subnormal (kept apart, see the test case below).
template <class T>
std::vector<std::pair<std::string, Matrix3<T>>> hostile_matrices(bool subnormal_max) {
  using L = std::numeric_limits<T>;
  const T big = L::max(), tiny = L::denorm_min(), small = L::min();
  std::vector<std::pair<std::string, Matrix3<T>>> cases;
  auto diag = [](T a, T b, T c) { return Matrix3<T>(Vector3<T>(a, b, c).asDiagonal()); };
  if (subnormal_max) {
    cases.emplace_back("denorm_min I", tiny * Matrix3<T>::Identity());
    cases.emplace_back("all denorm_min", Matrix3<T>::Constant(tiny));
    cases.emplace_back("diag(min/2, -min/4, denorm_min)", diag(small / 2, -small / 4, tiny));
    for (int r = 0; r < 3; ++r)
      for (int j = 0; j < 3; ++j) {
        Matrix3<T> H = Matrix3<T>::Zero();
        H(r, j) = -tiny;
        cases.emplace_back("single entry (" + std::to_string(r) + "," + std::to_string(j) + ") = -denorm_min", H);
      }
    return cases;
  }
  cases.emplace_back("max I", big * Matrix3<T>::Identity());
  cases.emplace_back("-max I", -big * Matrix3<T>::Identity());
  cases.emplace_back("all max", Matrix3<T>::Constant(big));
  cases.emplace_back("all -max", Matrix3<T>::Constant(-big));
  cases.emplace_back("min I", small * Matrix3<T>::Identity());
  cases.emplace_back("diag(max, 1, denorm_min)", diag(big, 1, tiny));
  cases.emplace_back("diag(max, -max, denorm_min)", diag(big, -big, tiny));
  cases.emplace_back("diag(1, 1, -1)", diag(1, 1, -1));
  cases.emplace_back("diag(1, -1, -1)", diag(1, -1, -1));
  cases.emplace_back("-I", -Matrix3<T>::Identity());
  cases.emplace_back("diag(-1, -1, 1)", diag(-1, -1, 1));
  cases.emplace_back("diag(1, 1, 0)", diag(1, 1, 0));
  cases.emplace_back("diag(1, 0, 0)", diag(1, 0, 0));
  cases.emplace_back("diag(-1, 0, 0)", diag(-1, 0, 0));
  cases.emplace_back("diag(1, -1, 0)", diag(1, -1, 0));
  cases.emplace_back("ones (rank 1)", Matrix3<T>::Ones());
  for (int r = 0; r < 3; ++r)
    for (int j = 0; j < 3; ++j)
      for (T v : {T(1), T(-1), big, -small}) {
        Matrix3<T> H = Matrix3<T>::Zero();
        H(r, j) = v;
        cases.emplace_back(
            "single entry (" + std::to_string(r) + "," + std::to_string(j) + ") = " + std::to_string(double(v)), H);
      }
  {
    Matrix3<T> H;  // mixed magnitudes across the whole range
    H << big, tiny, -small, T(1), -big / 4, tiny * 3, small, T(-1e-3), big / 2;
    cases.emplace_back("mixed magnitudes", H);
  }
  {
    Matrix3<T> H;  // skew-symmetric: trace 0, the optimum is a quarter turn
    H << 0, -1, 2, 1, 0, -3, -2, 3, 0;
    cases.emplace_back("skew-symmetric", H);
  }
  return cases;
}

template <class T>
void hostile(RotationMethod m, FailureLog& log, bool subnormal_max) {
  for (const auto& [name, H] : hostile_matrices<T>(subnormal_max)) {
    const Reference ref = reference(H);
    const std::string what =
        std::string(type_name<T>()) + " " + std::string(to_string(m)) + " on " + name + " H=[" + hex(H) + "]:";
    Matrix3<T> R;
    try {
      R = fit_rotation(H, m);
    } catch (const std::exception& ex) {
      log.add(key_of(type_name<T>(), m, "on " + name), what + " threw " + ex.what());
      continue;
    }
    const std::string v = violations<T>(measure(R, H, ref), ref, m);
    if (!v.empty()) log.add(key_of(type_name<T>(), m, "on " + name), what + v);
  }
}

/// The whole suite for one method, float and double.
void suite(RotationMethod m) {
  FailureLog log;
  family_accuracy<float>(m, log);
  family_accuracy<double>(m, log);
  power_of_two_scaling<float>(m, log);
  power_of_two_scaling<double>(m, log);
  power_of_ten_scaling<float>(m, log);
  power_of_ten_scaling<double>(m, log);
  hostile<float>(m, log, false);
  hostile<double>(m, log, false);
  log.summarise();
}

}  // namespace

// One test case per method (both precisions; every family, scaling, special matrices), so that a method
// under repair can be run alone: build/tests/test_rotation_accuracy "[axis_angle]". Failures print the
// case (family, seed, index and H in hex floats) and the bound it broke; at most 3 per family and check,
// then a count.

// Every method is held to c_b = 16 (accuracy_bounds.hpp) on every family.
TEST_CASE("accuracy: axis_angle (the paper's method)", "[accuracy][axis_angle]") { suite(RotationMethod::axis_angle); }

TEST_CASE("accuracy: horn_quaternion", "[accuracy][horn_quaternion]") { suite(RotationMethod::horn_quaternion); }

// The eigenvectors of H^T H carry eps kappa^2; fit_rotation_horn_matrix takes v2 from the deflated 2x2 Gram
// matrix and runs three rounds of subspace iteration, which bring that back to eps kappa.
TEST_CASE("accuracy: horn_matrix", "[accuracy][horn_matrix]") { suite(RotationMethod::horn_matrix); }

TEST_CASE("accuracy: kanatani", "[accuracy][kanatani]") { suite(RotationMethod::kanatani); }

TEST_CASE("accuracy: svd", "[accuracy][svd]") { suite(RotationMethod::svd); }

// The normalisation by 2^-ilogb(max |H_ij|) must be applied entry by entry: for a subnormal largest entry the
// factor itself (2^149 in float, 2^1074 in double) is not representable.
TEST_CASE("every method on H whose largest entry is subnormal", "[accuracy][finite]") {
  FailureLog log;
  for (RotationMethod m : all_rotation_methods) {
    hostile<float>(m, log, true);
    hostile<double>(m, log, true);
  }
  log.summarise();
}

/// Matrix3<T> from 9 entries in row-major order.
template <class T>
Matrix3<T> row_major(std::initializer_list<T> v) {
  Matrix3<T> H;
  auto it = v.begin();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) H(r, c) = *it++;
  return H;
}

/// The suite's verdict on axis_angle for one matrix ("" when within every bound).
template <class T>
std::string axis_angle_violations(const Matrix3<T>& H) {
  const Reference ref = reference(H);
  return violations<T>(measure(fit_rotation(H, RotationMethod::axis_angle), H, ref), ref, RotationMethod::axis_angle);
}

// Regression cases (they failed before core/src/rotation/axis_angle.hpp sent clustered H to a symmetric eigensolver,
// top_eigenvector): axis_angle with a repeated largest singular value and det H < 0 (H = U diag(s, s, t) V^T,
// t slightly below s). Then K's top eigenvalues are 2s - t and a double t just below it (a cluster of three),
// and the result can be far from the optimum with a real trace loss. Found by docs/accuracy.md's run (10^5
// cases per family, seed 20261121; repeated_sv indices below, `make_case<T>(Family::repeated_sv, 20261121,
// index)`); the default suite run draws too few of them to hit these. Judged with the suite's own bounds for
// axis_angle (then c_b = 64): every one of them was beyond it.
TEST_CASE("axis_angle: repeated largest singular value with det H < 0 (reproducers)", "[accuracy][axis_angle]") {
  const std::pair<const char*, Matrix3<float>> float_cases[] = {
      // s = 0.99964, 0.99964, 0.999482, kappa 6.4e3: 2.04 rad off, trace loss 1.1e3 eps ||H||.
      {"float repeated_sv 7476",
       row_major<float>({-0x1.1c6586p-1f, 0x1.e66a9ep-3f, 0x1.97c52ep-1f, 0x1.9e8e04p-1f, 0x1.7b8994p-2f,
                         0x1.d11bcep-2f, 0x1.7ff2b2p-3f, -0x1.cb747ap-1f, 0x1.97cd36p-2f})},
      // s = 0.892561, 0.892561, 0.890805, kappa 508: 1.31 rad off, trace loss 7.1e3 eps ||H||.
      {"float repeated_sv 9056",
       row_major<float>({-0x1.5722dcp-6f, 0x1.b60714p-1f, 0x1.037c48p-2f, 0x1.5c11cap-1f, 0x1.6f53ecp-3f,
                         -0x1.183d5ap-1f, 0x1.278c48p-1f, -0x1.71852cp-3f, 0x1.4ffb3cp-1f})},
      // s = 0.899249, 0.899249, 0.898949, kappa 3.0e3: 0.25 rad off (bound 0.079).
      {"float repeated_sv 3602",
       row_major<float>({-0x1.eaabf4p-3f, 0x1.aa354ep-1f, 0x1.ee52b6p-3f, 0x1.ba6a96p-1f, 0x1.af5314p-3f,
                         0x1.0ddf22p-3f, -0x1.0ae59ep-4f, -0x1.117e02p-2f, 0x1.b64d5ap-1f})},
  };
  const std::pair<const char*, Matrix3<double>> double_cases[] = {
      // s = 0.93331, 0.93331, 0.933305, kappa 1.7e5: 4.0e-7 rad off (bound 8.3e-9).
      {"double repeated_sv 25198",
       row_major<double>({0x1.14e0542badcaap-3, 0x1.a2668c7140db4p-2, 0x1.a803d5bf4d7eep-1, 0x1.575fcdb7bb8a8p-1,
                          0x1.105a2bcea664bp-1, -0x1.7cd9b95b42152p-2, 0x1.45089009b24efp-1, -0x1.4c45ad0b674e9p-1,
                          0x1.bb8172c4232a1p-3})},
      // s = 0.440907, 0.354181, 0.354181, det < 0 (optimum not unique): trace loss 342 eps ||H|| (bound 318).
      {"double repeated_sv 25808",
       row_major<double>({0x1.f5586d028dfcap-5, -0x1.d54ba5be53e8cp-4, 0x1.52429005e11afp-2, 0x1.b664c81e7cd56p-2,
                          -0x1.108cbd57fe8cbp-5, -0x1.2a99c2d015118p-4, -0x1.500384b3f6715p-4, -0x1.565713972842p-2,
                          -0x1.af619b8a82caep-4})},
  };
  auto check = [](const auto& cases) {
    for (const auto& [what, H] : cases) {
      const std::string v = axis_angle_violations(H);
      INFO(what << ":" << v);
      CHECK(v.empty());
    }
  };
  check(float_cases);
  check(double_cases);
}

// Regression: three coplanar points in double, det H < 0, s = 1.36006, 6.5259e-05, 1.3e-18 (kappa 2.08e4).
// The first-generation fit reached 1.67e-9 rad (359 eps kappa) where the bound with c_b = 16 is 2.6e-10.
// Found by docs/accuracy.md's run: coplanar index 61231, seed 20261121 (the default suite run does not reach
// it). Checked for the scalar fit here and for every ISA's lanes in test_batch_accuracy.
TEST_CASE("axis_angle: three coplanar points, double, kappa 2e4 (reproducer)", "[accuracy][axis_angle]") {
  Matrix3<double> H;
  H << -0x1.dd8422e0ca639p-7, 0x1.3fe63d7696e59p-4, -0x1.dd2b853ca4a34p-4, -0x1.1f67292ca715dp-3, 0x1.7fa7cb8ced28bp-1,
      -0x1.1e089e4fced31p+0, 0x1.da973e9396783p-10, -0x1.395efcf53904fp-7, 0x1.d2c7a5e02c79p-7;
  const std::string v = axis_angle_violations(H);
  INFO("coplanar 61231:" << v);
  CHECK(v.empty());
}
