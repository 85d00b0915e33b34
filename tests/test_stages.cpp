// The stage test of docs/design.md: every paper stage's SIMD twin (kernels/) against its scalar reference
// (core/src/), on every ISA the CPU runs, at sizes around the lane width (partial batches included), both
// through the stage entries of tests/stages/ (one table per ISA, layouts.hpp). Each output is also held against a
// long-double evaluation, with a bound derived from the stage's operation count and, where it matters, the problem's
// conditioning (gamma_k = k eps / (1 - k eps), Higham's bound for a k-step sum of products).
//
// The deformer's stages are one body each (kernels/deformer/stages.hpp), instantiated at width 1 by the
// scalar table and per batch by the ISAs', with plain products and sums (the kernels are built with
// -ffp-contract=off, core/ with baseline flags that have no FMA), so there the SIMD result must equal the
// scalar one bit for bit, except the sums over the pseudo-handles (weighted_centroid, correlation_matrix), which
// fuse on the FMA ISAs, as the rotation stages do: there both sides are checked against the long-double value. The ARAP
// local step's one-ring sums: tests/test_stages_ring.cpp.
#include "tests/stages/table.hpp"
#include "tests/support/accuracy_bounds.hpp"
#include "tests/support/rotation_cases.hpp"

#include "core/src/rotation/axis_angle.hpp"

#include "kernels/contract.hpp"

#include <mlsdeform/dispatch.hpp>

#include <Eigen/Geometry>
#include "tests/support/catch.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iterator>
#include <limits>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <vector>

using namespace mlsdeform;
using namespace mlsdeform::testing;
using namespace mlsdeform::testing::stages;

namespace {

/// Runs an entry on in's lanes; the outputs start as NaN, so that a lane the entry skips fails its checks.
template <class T, class Out>
std::vector<Out> nan_filled(std::size_t n) {
  std::vector<Out> out(n);
  T flat[sizeof(Out) / sizeof(T)];
  std::fill(std::begin(flat), std::end(flat), std::numeric_limits<T>::quiet_NaN());
  for (Out& o : out) std::memcpy(&o, flat, sizeof o);
  return out;
}
template <class T, template <class> class In, template <class> class Out>
std::vector<Out<T>> run(void (*entry)(const In<T>*, Out<T>*, std::size_t), const std::vector<In<T>>& in) {
  std::vector<Out<T>> out = nan_filled<T, Out<T>>(in.size());
  entry(in.data(), out.data(), in.size());
  return out;
}
template <class T, template <class> class In, template <class> class Out>
std::vector<Out<T>> run(void (*entry)(const In<T>*, const Shared<T>&, Out<T>*, std::size_t),
                        const std::vector<In<T>>& in, const Shared<T>& shared) {
  std::vector<Out<T>> out = nan_filled<T, Out<T>>(in.size());
  entry(in.data(), shared, out.data(), in.size());
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
  std::vector<Matrix3<T>> H;
  std::vector<Matrix<T>> h;
};

template <class T>
Lanes<T> lanes(std::size_t n) {
  Lanes<T> l;
  for (std::size_t i = 0; i < n; ++i) {
    l.H.push_back(normalised_case<T>(i));
    Matrix<T> m;
    for (std::size_t e = 0; e < 9; ++e) m.h[e] = l.H[i](e / 3, e % 3);
    l.h.push_back(m);
  }
  return l;
}

template <class T>
void check_rotation_stages(const StageEntries<T>& simd, const StageEntries<T>& scalar, std::size_t n) {
  const Lanes<T> L = lanes<T>(n);
  const LD eps = std::numeric_limits<T>::epsilon();

  // invariants (6). Bounds: a k-step sum of products is within gamma_k of the exact value times the same sum
  // over absolute values: E (2 additions), z (1 subtraction), ||H||^2 (9 squares summed), det H (2x2 minors,
  // then a 3-term dot product: 5 steps), c2 (minors, squared, 9 summed: 12 steps, against sum m_i^2 with
  // m_i = |ab| + |cd| for the minor ab - cd).
  const auto inv_simd = run(simd.invariants, L.h);
  const auto inv_scalar = run(scalar.invariants, L.h);
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
    const InvariantsOut<LD> ref = {H.trace(), {z(0), z(1), z(2)}, H.squaredNorm(), H.determinant(), c2};
    const InvariantsOut<LD> tol = {gamma<T>(2) * A.trace(),
                                   {gamma<T>(1) * zabs(0), gamma<T>(1) * zabs(1), gamma<T>(1) * zabs(2)},
                                   gamma<T>(9) * A.squaredNorm(),
                                   gamma<T>(5) * det_abs,
                                   gamma<T>(12) * c2_abs};
    for (const auto* out : {&inv_simd[i], &inv_scalar[i]}) {
      INFO("invariants, lane " << i << " of " << n << (out == &inv_simd[i] ? ", SIMD" : ", scalar"));
      CHECK(std::abs(LD(out->E_) - ref.E_) <= tol.E_);
      for (int k = 0; k < 3; ++k) CHECK(std::abs(LD(out->z[k]) - ref.z[k]) <= tol.z[k]);
      CHECK(std::abs(LD(out->norm2) - ref.norm2) <= tol.norm2);
      CHECK(std::abs(LD(out->det) - ref.det) <= tol.det);
      CHECK(std::abs(LD(out->c2) - ref.c2) <= tol.c2);
    }
  }

  // maximum_root (13), both on the scalar invariants. Reference: Newton's method in long double on the same
  // coefficients. A converged y is off the root by the rounding of P at y over P'(y) (P's evaluation:
  // 8 steps, against Pabs(y) = y^4 + 2n y^2 + 8|det| y + n^2 + 4 c2), plus the last Newton step's
  // truncation: the step that met the stopping rule (<= sqrt(eps)/4 y) leaves (P''/2P') step^2 with
  // P''/P' = 2 sum_{i>1} 1/(y - lambda_i) <= 6 / (y - lambda_2), y - lambda_2 = 2 (s2 + d s3), i.e. at most
  // (3/32) (kappa + 1) eps y. Both terms doubled for the first-order approximations.
  const auto root_simd = run(simd.maximum_root, inv_scalar);
  const auto root_scalar = run(scalar.maximum_root, inv_scalar);
  std::vector<AxisIn<T>> axis_in(n);
  std::size_t converged = 0;
  std::vector<Reference> refs;
  for (std::size_t i = 0; i < n; ++i) {
    refs.push_back(reference(L.H[i]));
    const LD nn = inv_scalar[i].norm2, det = inv_scalar[i].det, c2 = inv_scalar[i].c2;
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
    std::copy(std::begin(L.h[i].h), std::end(L.h[i].h), axis_in[i].h);
    axis_in[i].y = root_scalar[i].y;
    if (root_simd[i].converged == T(1) && root_scalar[i].converged == T(1)) {
      ++converged;
      INFO("maximum_root, lane " << i << " of " << n << ", kappa " << double(refs[i].kappa));
      CHECK(std::abs(LD(root_simd[i].y) - y) <= tol);
      CHECK(std::abs(LD(root_scalar[i].y) - y) <= tol);
    }
  }
  CHECK(converged * 10 >= n * 9);  // the uniform family: careful lanes are ~1e-3

  // rotation_axis (14), fast path, on the scalar root: where the fit takes the fast path (converged root,
  // dk^2 > tau^2 ||H||^6), the rotation of q is within the accuracy suite's angle bound of the optimum
  // (tests/support/accuracy_bounds.hpp; the fast path's error analysis is at detail::rotation_axis).
  // top_eigenvector (careful path): within the same bound on every lane (unique optimum).
  const auto axis_simd = run(simd.rotation_axis, axis_in);
  const auto axis_scalar = run(scalar.rotation_axis, axis_in);
  const auto top_simd = run(simd.top_eigenvector, L.h);
  const auto top_scalar = run(scalar.top_eigenvector, L.h);
  const LD tau = kernels::kCarefulTau<T>;
  auto quaternion = [](const T(&q)[4]) { return Eigen::Matrix<LD, 4, 1>(q[0], q[1], q[2], q[3]); };
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Matrix<LD, 4, 1> qref = quaternion_of(refs[i].rotation);
    const LD tol = tol_angle<T>(refs[i].kappa, c_b_uniform);
    const LD n3 = std::pow(LD(inv_scalar[i].norm2), 3);
    INFO("rotation_axis / top_eigenvector, lane " << i << " of " << n << ", kappa " << double(refs[i].kappa));
    for (const auto* out : {&axis_scalar[i], &axis_simd[i]})
      if (root_scalar[i].converged == T(1) && LD(out->dk) * out->dk > tau * tau * n3)
        CHECK(rotation_angle(quaternion(out->q), qref) <= tol);
    CHECK(rotation_angle(quaternion(top_simd[i].q), qref) <= tol);
    CHECK(rotation_angle(quaternion(top_scalar[i].q), qref) <= tol);
  }

  // sin_cos (15), (5), on random quaternions: each entry is a numerator of abs-value at most 2 |q|^2 (8 steps)
  // over |q|^2 (4 steps), an entry of R at most 1: |dR_ij| <= 2 gamma_8 + gamma_5 <= 3 gamma_10.
  std::mt19937_64 g(7 + n);
  std::normal_distribution<double> normal;
  std::vector<Quaternion<T>> qin(n);
  for (auto& q : qin)
    for (T& x : q.q) x = T(normal(g));
  const auto r_simd = run(simd.sin_cos, qin);
  const auto r_scalar = run(scalar.sin_cos, qin);
  for (std::size_t i = 0; i < n; ++i) {
    const Matrix3L R = detail::sin_cos<LD>(quaternion(qin[i].q));
    for (std::size_t e = 0; e < 9; ++e) {
      INFO("sin_cos, lane " << i << " of " << n << ", entry " << e);
      CHECK(std::abs(LD(r_simd[i].r[e]) - R(e / 3, e % 3)) <= 3 * gamma<T>(10));
      CHECK(std::abs(LD(r_scalar[i].r[e]) - R(e / 3, e % 3)) <= 3 * gamma<T>(10));
    }
  }
}

/// Every bit of every lane's output the same.
template <class Out>
void check_bitwise(const std::vector<Out>& a, const std::vector<Out>& b, const char* stage, std::size_t n) {
  REQUIRE(a.size() == b.size());
  std::size_t differ = 0;
  for (std::size_t k = 0; k < a.size(); ++k) differ += std::memcmp(&a[k], &b[k], sizeof(Out)) != 0;
  INFO(stage << " on " << n << " lanes");
  CHECK(differ == 0);
}

template <class T>
void check_deformer_stages(const StageEntries<T>& simd, const StageEntries<T>& scalar, std::size_t n) {
  std::mt19937_64 g(11 + n);
  std::uniform_real_distribution<double> u(-1, 1);
  auto fill = [&]<class S>(std::vector<S>& v, double lo = -1) {
    for (S& s : v) {
      T flat[sizeof(S) / sizeof(T)];
      for (T& x : flat) x = T(lo + (u(g) + 1) / 2 * (1 - lo));
      std::memcpy(&s, flat, sizeof s);
    }
  };
  // weighted_centroid (2) and correlation_matrix (6): sums of J terms, each term's product and sum rounded twice
  // (the scalar table, SSE4.2: then bitwise equal) or fused and rounded once (AVX2, AVX-512: LaneArith's
  // mul_add). Either way each side within gamma_2J (2 J roundings at most) of the long-double sums times the
  // sums of absolute terms.
  const bool fused = std::string(simd.isa) != "sse4_2";
  std::vector<Weights<T>> omega(n);
  std::vector<CorrelationIn<T>> A(n);
  std::vector<Shared<T>> q(1), d(1);
  fill(omega, 0), fill(q), fill(A), fill(d);
  const auto qs_simd = run(simd.weighted_centroid, omega, q[0]);
  const auto qs_scalar = run(scalar.weighted_centroid, omega, q[0]);
  if (!fused) check_bitwise(qs_simd, qs_scalar, "weighted_centroid", n);
  const auto h_simd = run(simd.correlation_matrix, A, d[0]);
  const auto h_scalar = run(scalar.correlation_matrix, A, d[0]);
  if (!fused) check_bitwise(h_simd, h_scalar, "correlation_matrix", n);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t c = 0; c < 3; ++c) {
      LD s = 0, sa = 0;
      for (std::size_t j = 0; j < kJ; ++j)
        s += LD(omega[i].w[j]) * q[0].q[j][c], sa += std::abs(LD(omega[i].w[j]) * q[0].q[j][c]);
      CHECK(std::abs(qs_scalar[i].x[c] - s) <= gamma<T>(2 * kJ) * sa);
      CHECK(std::abs(qs_simd[i].x[c] - s) <= gamma<T>(2 * kJ) * sa);
    }
    for (std::size_t e = 0; e < 9; ++e) {
      LD s = 0, sa = 0;
      for (std::size_t j = 0; j < kJ; ++j) {
        const LD t = LD(d[0].q[j][e / 3]) * A[i].a[j][e % 3];
        s += t, sa += std::abs(t);
      }
      CHECK(std::abs(h_scalar[i].r[e] - s) <= gamma<T>(2 * kJ) * sa);
      CHECK(std::abs(h_simd[i].r[e] - s) <= gamma<T>(2 * kJ) * sa);
    }
  }
  // similarity_scale (Sec. 6.1) and apply (steps 8-10): bitwise equal; lane 0 has D = 0 (the `otherwise`).
  std::vector<SimilarityIn<T>> sin(n);
  fill(sin);
  for (std::size_t i = 0; i < n; ++i) sin[i].D = i == 0 ? T(0) : T(0.5) + std::abs(sin[i].D);
  check_bitwise(run(simd.similarity_scale, sin), run(scalar.similarity_scale, sin), "similarity_scale", n);
  std::vector<ApplyIn<T>> ain(n);
  fill(ain);
  check_bitwise(run(simd.apply, ain), run(scalar.apply, ain), "apply", n);

  // rotation_quaternion (the frames): bitwise equal, and against the exact quaternion of the rotation the
  // input was rounded from. Rotations from random unit quaternions in long double, and the corner cases:
  // the identity, half turns (w = 0) about each axis and about a diagonal, and a turn by pi - 1e-3.
  std::vector<Rotation<T>> rin(n);
  std::vector<Eigen::Matrix<LD, 4, 1>> qref(n);
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Matrix<LD, 4, 1> qi(LD(u(g)), LD(u(g)), LD(u(g)), LD(u(g)));
    const LD half = std::sin(LD(0.5) * (LD(std::numbers::pi) - LD(1e-3))),
             w = std::cos(LD(0.5) * (LD(std::numbers::pi) - LD(1e-3)));
    const Eigen::Matrix<LD, 4, 1> corner[6] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0},
                                               {0, 0, 0, 1}, {0, 1, 1, 1}, {w, half, 0, 0}};
    if (i % 4 == 0) qi = corner[(i / 4) % 6];
    qi.normalize();
    if (qi(0) < 0) qi = -qi;
    qref[i] = qi;
    const Eigen::Matrix<LD, 3, 3> R = Eigen::Quaternion<LD>(qi(0), qi(1), qi(2), qi(3)).toRotationMatrix();
    for (int e = 0; e < 9; ++e) rin[i].r[e] = T(R(e / 3, e % 3));
  }
  const auto q_simd = run(simd.rotation_quaternion, rin), q_scalar = run(scalar.rotation_quaternion, rin);
  check_bitwise(q_simd, q_scalar, "rotation_quaternion", n);
  // Bound: R's entries are rounded to T (eps / 2 each); the chosen column 4 q_k q has entries of 1 + 3 terms
  // or 2 terms, each within 3 (eps / 2) + 3 eps of its exact value, so the column is within 8 eps in norm,
  // and its norm is 4 |q_k| >= 2 (the largest of four squares summing to 1 is >= 1/4): 4 eps in direction;
  // the square root and the division add 3 eps. At w = 0 either sign is exact: the nearer is compared.
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Matrix<LD, 4, 1> got(LD(q_scalar[i].q[0]), LD(q_scalar[i].q[1]), LD(q_scalar[i].q[2]),
                                      LD(q_scalar[i].q[3]));
    CHECK(std::min((got - qref[i]).norm(), (got + qref[i]).norm()) <= 7 * eps<T>);
    CHECK(got(0) >= 0);
  }
}

}  // namespace

TEMPLATE_TEST_CASE("every SIMD stage agrees with its scalar twin on every ISA", "[stages][isa]", float, double) {
  for_each_simd_table<TestType>([](const StageEntries<TestType>& simd, const StageEntries<TestType>& scalar) {
    const std::size_t W = simd.width;
    std::set<std::size_t> sizes = {1, W - 1, W, W + 1, 2 * W + 3, 3 * W};
    sizes.erase(0);
    for (std::size_t n : sizes) {
      INFO(n << " lanes");
      check_rotation_stages<TestType>(simd, scalar, n);
      check_deformer_stages<TestType>(simd, scalar, n);
    }
  });
}

TEMPLATE_TEST_CASE("every stage table has every entry", "[stages]", float, double) {
  std::vector<const StageEntries<TestType>*> tables = {&scalar_entries<TestType>()};
  for (Isa isa : supported_isas())
    if (isa != Isa::scalar) tables.push_back(&entries<TestType>(isa));
  for (const StageEntries<TestType>* t : tables) {
    INFO(t->isa);
    CHECK(t->invariants);
    CHECK(t->maximum_root);
    CHECK(t->rotation_axis);
    CHECK(t->top_eigenvector);
    CHECK(t->sin_cos);
    CHECK(t->weighted_centroid);
    CHECK(t->correlation_matrix);
    CHECK(t->similarity_scale);
    CHECK(t->apply);
    CHECK(t->rotation_quaternion);
    CHECK(t->ring_correlation);
    CHECK(t->ring_rhs);
  }
}
