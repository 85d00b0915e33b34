// The stage test of docs/design.md: every paper stage's SIMD twin (kernels/) against its scalar reference
// (core/src/), on every ISA the CPU runs, at sizes around the lane width (partial batches included), both
// through the kernel tables' StageFn entries. Each output is also held against a long-double evaluation,
// with a bound derived from the stage's operation count and, where it matters, the problem's conditioning
// (gamma_k = k eps / (1 - k eps), Higham's bound for a k-step sum of products).
//
// The deformer's stages use plain products and sums on both sides (the kernels are built with
// -ffp-contract=off, core/ with baseline flags that have no FMA), so there the SIMD result must equal the
// scalar one bit for bit. The rotation stages fuse products on FMA ISAs, so there both sides are checked
// against the long-double value instead.
#include "tests/support/accuracy_bounds.hpp"
#include "tests/support/isa_guard.hpp"
#include "tests/support/rotation_cases.hpp"

#include "core/src/dispatch.hpp"
#include "core/src/rotation/axis_angle.hpp"

#include <mlsdeform/dispatch.hpp>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <set>
#include <vector>

using namespace mlsdeform;
using namespace mlsdeform::testing;
using kernels::Stage;
using LD = long double;

namespace {

template <class T>
LD gamma(int k) {
  const LD e = std::numeric_limits<T>::epsilon();
  return k * e / (1 - k * e);
}

template <class T>
kernels::StageFn<T> stage_fn(const kernels::KernelTable& t) {
  if constexpr (std::is_same_v<T, float>)
    return t.stage_f;
  else
    return t.stage_d;
}

/// Runs `stage` through a table: in is SoA [k * n + i], the result likewise.
template <class T>
std::vector<T> run(const kernels::KernelTable& t, Stage stage, const std::vector<T>& in, const std::vector<T>& shared,
                   std::size_t J, std::size_t n) {
  std::vector<T> out(kernels::stage_outputs(stage) * n, std::numeric_limits<T>::quiet_NaN());
  stage_fn<T>(t)(stage, in.data(), shared.data(), J, out.data(), n);
  return out;
}

/// H of the uniform family (unique optimum), normalised exactly as the fit does (max |h| in [1, 2)).
template <class T>
Matrix3<T> normalised_case(std::uint64_t i) {
  const Matrix3<T> H = make_case<T>(Family::uniform, 20261124, i).H;
  const int e = std::ilogb(H.cwiseAbs().maxCoeff());
  return H * std::ldexp(T(1), -e);
}

/// Angle between the rotations of two quaternions: twice the angle between the unit vectors (up to sign),
/// as 2 atan2(|a - b|, |a + b|), accurate for small angles (acos near 1 is not).
LD rotation_angle(const Eigen::Matrix<LD, 4, 1>& a, const Eigen::Matrix<LD, 4, 1>& b) {
  const Eigen::Matrix<LD, 4, 1> u = a.normalized(), v = (a.dot(b) < 0 ? -b : b).normalized();
  return 4 * std::atan2((u - v).norm(), (u + v).norm());
}

Eigen::Matrix<LD, 4, 1> quaternion_of(const Matrix3L& R) {
  const Eigen::Quaternion<LD> q(R);
  return Eigen::Matrix<LD, 4, 1>(q.w(), q.x(), q.y(), q.z());
}

template <class T>
struct Lanes {
  std::size_t n;
  std::vector<Matrix3<T>> H;
  std::vector<T> h;  // SoA, 9 n
};

template <class T>
Lanes<T> lanes(std::size_t n) {
  Lanes<T> l{n, {}, std::vector<T>(9 * n)};
  for (std::size_t i = 0; i < n; ++i) {
    l.H.push_back(normalised_case<T>(i));
    for (std::size_t e = 0; e < 9; ++e) l.h[e * n + i] = l.H[i](e / 3, e % 3);
  }
  return l;
}

template <class T>
void check_rotation_stages(const kernels::KernelTable& simd, const kernels::KernelTable& scalar, std::size_t n) {
  const Lanes<T> L = lanes<T>(n);
  const LD eps = std::numeric_limits<T>::epsilon();
  const std::vector<T> none;

  // invariants (6). Bounds: a k-step sum of products is within gamma_k of the exact value times the same sum
  // over absolute values: E (2 additions), z (1 subtraction), ||H||^2 (9 squares summed), det H (2x2 minors,
  // then a 3-term dot product: 5 steps), c2 (minors, squared, 9 summed: 12 steps, against sum m_i^2 with
  // m_i = |ab| + |cd| for the minor ab - cd).
  const auto inv_simd = run<T>(simd, Stage::invariants, L.h, none, 0, n);
  const auto inv_scalar = run<T>(scalar, Stage::invariants, L.h, none, 0, n);
  for (std::size_t i = 0; i < n; ++i) {
    const Matrix3L H = L.H[i].template cast<LD>();
    const Matrix3L A = H.cwiseAbs();
    LD det_abs = 0, c2_abs = 0;
    const int cols[3][2] = {{0, 1}, {0, 2}, {1, 2}};
    for (const auto& cc : cols)
      for (int r = 0; r < 3; ++r) {
        const int r1 = (r + 1) % 3, r2 = (r + 2) % 3;
        const LD m = A(r1, cc[0]) * A(r2, cc[1]) + A(r2, cc[0]) * A(r1, cc[1]);
        c2_abs += m * m;
        if (cc[0] == 0 && cc[1] == 1) det_abs += m * A(r, 2);
      }
    const Eigen::Matrix<LD, 3, 1> z(H(2, 1) - H(1, 2), H(0, 2) - H(2, 0), H(1, 0) - H(0, 1));
    const Eigen::Matrix<LD, 3, 1> zabs(A(2, 1) + A(1, 2), A(0, 2) + A(2, 0), A(1, 0) + A(0, 1));
    LD c2 = 0;
    for (const auto& cc : cols) c2 += H.col(cc[0]).cross(H.col(cc[1])).squaredNorm();
    const LD ref[7] = {H.trace(), z(0), z(1), z(2), H.squaredNorm(), H.determinant(), c2};
    const LD tol[7] = {gamma<T>(2) * A.trace(), gamma<T>(1) * zabs(0),         gamma<T>(1) * zabs(1),
                       gamma<T>(1) * zabs(2),   gamma<T>(9) * A.squaredNorm(), gamma<T>(5) * det_abs,
                       gamma<T>(12) * c2_abs};
    for (std::size_t k = 0; k < 7; ++k) {
      INFO("invariants, lane " << i << " of " << n << ", output " << k);
      CHECK(std::abs(LD(inv_simd[k * n + i]) - ref[k]) <= tol[k]);
      CHECK(std::abs(LD(inv_scalar[k * n + i]) - ref[k]) <= tol[k]);
    }
  }

  // maximum_root (13), both on the scalar invariants. Reference: Newton's method in long double on the same
  // coefficients. A converged y is off the root by the rounding of P at y over P'(y) (P's evaluation:
  // 8 steps, against Pabs(y) = y^4 + 2n y^2 + 8|det| y + n^2 + 4 c2), plus the last Newton step's
  // truncation: the step that met the stopping rule (<= sqrt(eps)/4 y) leaves (P''/2P') step^2 with
  // P''/P' = 2 sum_{i>1} 1/(y - lambda_i) <= 6 / (y - lambda_2), y - lambda_2 = 2 (s2 + d s3), i.e. at most
  // (3/32) (kappa + 1) eps y. Both terms doubled for the first-order approximations.
  const auto root_simd = run<T>(simd, Stage::maximum_root, inv_scalar, none, 0, n);
  const auto root_scalar = run<T>(scalar, Stage::maximum_root, inv_scalar, none, 0, n);
  std::vector<T> axis_in(10 * n);
  std::copy(L.h.begin(), L.h.end(), axis_in.begin());
  std::size_t converged = 0;
  std::vector<Reference> refs;
  for (std::size_t i = 0; i < n; ++i) {
    refs.push_back(reference(L.H[i]));
    const LD nn = inv_scalar[4 * n + i], det = inv_scalar[5 * n + i], c2 = inv_scalar[6 * n + i];
    const LD a = -2 * nn, b = -8 * det, c = nn * nn - 4 * c2;
    auto P = [&](LD y) { return ((y * y + a) * y + b) * y + c; };
    auto dP = [&](LD y) { return (4 * y * y + 2 * a) * y + b; };
    LD y = std::sqrt(nn + 2 * std::sqrt(det < 0 ? c2 : 3 * c2));
    for (int it = 0; it < 200; ++it) {
      const LD step = P(y) / dP(y);
      if (!(step > 0)) break;
      y -= step;
    }
    const LD Pabs = y * y * y * y + 2 * nn * y * y + 8 * std::abs(det) * y + nn * nn + 4 * c2;
    const LD tol = 2 * gamma<T>(8) * Pabs / dP(y) + LD(3) / 16 * (refs[i].kappa + 1) * eps * y;
    axis_in[9 * n + i] = root_scalar[i];
    if (root_simd[n + i] == T(1) && root_scalar[n + i] == T(1)) {
      ++converged;
      INFO("maximum_root, lane " << i << " of " << n << ", kappa " << double(refs[i].kappa));
      CHECK(std::abs(LD(root_simd[i]) - y) <= tol);
      CHECK(std::abs(LD(root_scalar[i]) - y) <= tol);
    }
  }
  CHECK(converged * 10 >= n * 9);  // the uniform family: careful lanes are ~1e-3

  // rotation_axis (14), fast path, on the scalar root: where the fit takes the fast path (converged root,
  // dk^2 > tau^2 ||H||^6), the rotation of q is within the accuracy suite's angle bound of the optimum
  // (tests/support/accuracy_bounds.hpp; the fast path's error analysis is at detail::rotation_axis).
  // top_eigenvector (careful path): within the same bound on every lane (unique optimum).
  const auto axis_simd = run<T>(simd, Stage::rotation_axis, axis_in, none, 0, n);
  const auto axis_scalar = run<T>(scalar, Stage::rotation_axis, axis_in, none, 0, n);
  const auto top_simd = run<T>(simd, Stage::top_eigenvector, L.h, none, 0, n);
  const auto top_scalar = run<T>(scalar, Stage::top_eigenvector, L.h, none, 0, n);
  const LD tau = kernels::kCarefulTau<T>;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Matrix<LD, 4, 1> qref = quaternion_of(refs[i].rotation);
    const LD tol = tol_angle<T>(refs[i].kappa, c_b_uniform);
    const LD n3 = std::pow(LD(inv_scalar[4 * n + i]), 3);
    auto q = [&](const std::vector<T>& v, std::size_t stride) {
      return Eigen::Matrix<LD, 4, 1>(v[i], v[stride + i], v[2 * stride + i], v[3 * stride + i]);
    };
    INFO("rotation_axis / top_eigenvector, lane " << i << " of " << n << ", kappa " << double(refs[i].kappa));
    if (root_scalar[n + i] == T(1) && LD(axis_scalar[4 * n + i]) * axis_scalar[4 * n + i] > tau * tau * n3)
      CHECK(rotation_angle(q(axis_scalar, n), qref) <= tol);
    if (root_scalar[n + i] == T(1) && LD(axis_simd[4 * n + i]) * axis_simd[4 * n + i] > tau * tau * n3)
      CHECK(rotation_angle(q(axis_simd, n), qref) <= tol);
    CHECK(rotation_angle(q(top_simd, n), qref) <= tol);
    CHECK(rotation_angle(q(top_scalar, n), qref) <= tol);
  }

  // sin_cos (15), (5), on random quaternions: each entry is a numerator of abs-value at most 2 |q|^2 (8 steps)
  // over |q|^2 (4 steps), an entry of R at most 1: |dR_ij| <= 2 gamma_8 + gamma_5 <= 3 gamma_10.
  std::mt19937_64 g(7 + n);
  std::normal_distribution<double> normal;
  std::vector<T> qin(4 * n);
  for (T& x : qin) x = T(normal(g));
  const auto r_simd = run<T>(simd, Stage::sin_cos, qin, none, 0, n);
  const auto r_scalar = run<T>(scalar, Stage::sin_cos, qin, none, 0, n);
  for (std::size_t i = 0; i < n; ++i) {
    const Matrix3L R = detail::sin_cos<LD>(Eigen::Matrix<LD, 4, 1>(qin[i], qin[n + i], qin[2 * n + i], qin[3 * n + i]));
    for (std::size_t e = 0; e < 9; ++e) {
      INFO("sin_cos, lane " << i << " of " << n << ", entry " << e);
      CHECK(std::abs(LD(r_simd[e * n + i]) - R(e / 3, e % 3)) <= 3 * gamma<T>(10));
      CHECK(std::abs(LD(r_scalar[e * n + i]) - R(e / 3, e % 3)) <= 3 * gamma<T>(10));
    }
  }
}

template <class T>
void check_bitwise(const std::vector<T>& a, const std::vector<T>& b, const char* stage, std::size_t n) {
  REQUIRE(a.size() == b.size());
  std::size_t differ = 0;
  for (std::size_t k = 0; k < a.size(); ++k) differ += std::memcmp(&a[k], &b[k], sizeof(T)) != 0;
  INFO(stage << " on " << n << " lanes");
  CHECK(differ == 0);
}

template <class T>
void check_deformer_stages(const kernels::KernelTable& simd, const kernels::KernelTable& scalar, std::size_t n) {
  constexpr std::size_t J = 7;
  std::mt19937_64 g(11 + n);
  std::uniform_real_distribution<double> u(-1, 1);
  auto fill = [&](std::size_t count, double lo = -1) {
    std::vector<T> v(count);
    for (T& x : v) x = T(lo + (u(g) + 1) / 2 * (1 - lo));
    return v;
  };
  // weighted_centroid (2) and correlation_matrix (6): bitwise equal, and within gamma_J (2 J steps for H)
  // of the long-double sums times the sums of absolute terms.
  const std::vector<T> omega = fill(J * n, 0), q = fill(3 * J), A = fill(3 * J * n), d = fill(3 * J);
  const auto qs_simd = run<T>(simd, Stage::weighted_centroid, omega, q, J, n);
  const auto qs_scalar = run<T>(scalar, Stage::weighted_centroid, omega, q, J, n);
  check_bitwise(qs_simd, qs_scalar, "weighted_centroid", n);
  const auto h_simd = run<T>(simd, Stage::correlation_matrix, A, d, J, n);
  const auto h_scalar = run<T>(scalar, Stage::correlation_matrix, A, d, J, n);
  check_bitwise(h_simd, h_scalar, "correlation_matrix", n);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t c = 0; c < 3; ++c) {
      LD s = 0, sa = 0;
      for (std::size_t j = 0; j < J; ++j)
        s += LD(omega[j * n + i]) * q[3 * j + c], sa += std::abs(LD(omega[j * n + i]) * q[3 * j + c]);
      CHECK(std::abs(qs_scalar[c * n + i] - s) <= gamma<T>(2 * J) * sa);
    }
    for (std::size_t e = 0; e < 9; ++e) {
      LD s = 0, sa = 0;
      for (std::size_t j = 0; j < J; ++j) {
        const LD t = LD(d[3 * j + e / 3]) * A[(3 * j + e % 3) * n + i];
        s += t, sa += std::abs(t);
      }
      CHECK(std::abs(h_scalar[e * n + i] - s) <= gamma<T>(2 * J) * sa);
    }
  }
  // similarity_scale (Sec. 6.1) and apply (steps 8-10): bitwise equal; lane 0 has D = 0 (the `otherwise`).
  std::vector<T> sin = fill(20 * n);
  for (std::size_t i = 0; i < n; ++i) sin[18 * n + i] = i == 0 ? T(0) : T(0.5) + std::abs(sin[18 * n + i]);
  check_bitwise(run<T>(simd, Stage::similarity_scale, sin, {}, 0, n),
                run<T>(scalar, Stage::similarity_scale, sin, {}, 0, n), "similarity_scale", n);
  const std::vector<T> ain = fill(16 * n);
  check_bitwise(run<T>(simd, Stage::apply, ain, {}, 0, n), run<T>(scalar, Stage::apply, ain, {}, 0, n), "apply", n);
}

}  // namespace

TEMPLATE_TEST_CASE("every SIMD stage agrees with its scalar twin on every ISA", "[stages][isa]", float, double) {
  const kernels::KernelTable& scalar = kernels::kernel_table_scalar();
  testing::IsaGuard guard;
  int isas = 0;
  for (Isa isa : supported_isas()) {
    if (isa == Isa::scalar) continue;
    set_isa(isa);
    const kernels::KernelTable& simd = detail::active_kernels();
    const std::size_t W = std::is_same_v<TestType, float> ? simd.lanes_float : simd.lanes_double;
    std::set<std::size_t> sizes = {1, W - 1, W, W + 1, 2 * W + 3, 3 * W};
    sizes.erase(0);
    for (std::size_t n : sizes) {
      INFO("ISA " << to_string(isa) << ", " << n << " lanes");
      check_rotation_stages<TestType>(simd, scalar, n);
      check_deformer_stages<TestType>(simd, scalar, n);
    }
    ++isas;
  }
  if (isas == 0) WARN("no SIMD instruction set on this CPU: only the scalar table exists");
}

TEST_CASE("the stage table covers every stage of docs/design.md", "[stages]") {
  // Each stage has an entry on both sides: a stage missing from a switch would leave its outputs NaN.
  const kernels::KernelTable& scalar = kernels::kernel_table_scalar();
  for (Stage s : kernels::all_stages) {
    const std::size_t J = 2, n = 3;
    const std::vector<float> in(kernels::stage_inputs(s, J) * n, 0.5f), shared(3 * J, 0.25f);
    const auto out = run<float>(scalar, s, in, shared, J, n);
    CHECK(std::none_of(out.begin(), out.end(), [](float x) { return std::isnan(x); }));
  }
}
