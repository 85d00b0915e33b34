// Segment handles' weight moments (paper Sec. 6.2, core/src/deformer/weights.hpp): the exact integral by the
// library's quadrature against closed forms and an independent long-double rule, for moderate and for large
// weight exponents. The moments are the scalar precomputation's: no instruction set is dispatched here.
#include "tests/test_deformer_common.hpp"

#include "core/src/deformer/weights.hpp"

#include <iostream>

using namespace deformer_test;

namespace {

using LD = long double;

/// The N-point Gauss-Legendre rule on [-1, 1] in long double: each node by Newton's method on the Legendre
/// polynomial P_N (from the classical first guess cos(pi (i + 3/4) / (N + 1/2))), its weight
/// 2 / ((1 - x^2) P_N'(x)^2).
template <int N>
void gauss_legendre(LD (&x)[N], LD (&w)[N]) {
  for (int i = 0; i < N; ++i) {
    LD z = std::cos(3.14159265358979323846264338327950288L * (i + 0.75L) / (N + 0.5L)), dp = 1;
    for (int it = 0; it < 100; ++it) {
      LD p0 = 1, p1 = z;
      for (int k = 2; k <= N; ++k) {
        const LD p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = N * (z * p1 - p0) / (z * z - 1);
      z -= p1 / dp;
    }
    x[i] = z;
    w[i] = 2 / ((1 - z * z) * dp * dp);
  }
}

/// Closed form of the moments for u = 2: w(t) = d_min^2 / (h^2 + L^2 (t - t0)^2), with tau = t - t0,
/// K0 = int dtau / (h^2 + L^2 tau^2) = atan(L tau / h) / (h L), K1 = int tau ... = ln(h^2 + L^2 tau^2) / (2 L^2),
/// K2 = int tau^2 ... = (tau - h^2 K0) / L^2, and t = t0 + tau expanded in (1-t)^2, t(1-t), t^2.
detail::SegmentMoments closed_form_u2(LD L, LD t0, LD h, LD d_min) {
  const LD lo = -t0, hi = 1 - t0;
  const LD K0 = (std::atan(L * hi / h) - std::atan(L * lo / h)) / (h * L);
  const LD K1 = (std::log(h * h + L * L * hi * hi) - std::log(h * h + L * L * lo * lo)) / (2 * L * L);
  const LD K2 = ((hi - lo) - h * h * K0) / (L * L);
  const LD s = 1 - t0, d2 = d_min * d_min;
  const LD I2 = d2 * (t0 * t0 * K0 + 2 * t0 * K1 + K2);
  const LD I0 = d2 * (s * s * K0 - 2 * s * K1 + K2);
  const LD I1 = d2 * (t0 * s * K0 + (s - t0) * K1 - K2);
  return {double(I0), double(I1), double(I2)};
}

/// An independent long-double reference for any u: 24-point Gauss-Legendre on pieces four times shorter than
/// the library's (so at least ~10^10 times more accurate than needed), nodes by Newton in long double.
detail::SegmentMoments fine_reference(const detail::SegmentGeometry& g, LD d_min, LD u) {
  constexpr int N = 24;
  LD x[N], w[N];
  gauss_legendre(x, w);
  LD I0 = 0, I1 = 0, I2 = 0;
  const LD kappa = std::min<LD>(1, 8 / u) / 4;
  for (int side = 1; side >= -1; side -= 2) {
    const LD len = (side > 0 ? 1 - LD(g.tc) : LD(g.tc)) * g.L;
    for (LD x0 = 0; x0 < len;) {
      const LD x1 = std::min(x0 == 0 ? kappa * g.d : (1 + kappa) * x0, len);
      for (int k = 0; k < N; ++k) {
        const LD xx = (x0 + x1) / 2 + (x1 - x0) / 2 * x[k];
        const LD r = g.off + xx, dist = std::sqrt(LD(g.h) * g.h + r * r);
        const LD t = g.tc + side * xx / g.L, wt = (x1 - x0) / 2 * w[k] * std::pow(d_min / dist, u) / g.L;
        I0 += wt * (1 - t) * (1 - t);
        I1 += wt * t * (1 - t);
        I2 += wt * t * t;
      }
      x0 = x1;
    }
  }
  return {double(I0), double(I1), double(I2)};
}

/// Pieces the library's composite rule uses (weights.hpp), for the rounding part of the tolerance.
int pieces(const detail::SegmentGeometry& g, double u) {
  const double kappa = std::min(1.0, 8.0 / u);
  int p = 0;
  for (int side = 1; side >= -1; side -= 2) {
    const double len = (side > 0 ? 1 - g.tc : g.tc) * g.L;
    for (double x0 = 0; x0 < len; ++p) x0 = std::min(x0 == 0 ? kappa * g.d : (1 + kappa) * x0, len);
  }
  return p;
}

}  // namespace

TEST_CASE("segment weight moments: exact integral against closed forms and a fine reference", "[deformer][segment]") {
  std::mt19937_64 gen(seed());
  INFO("seed " << seed());
  double worst = 0, worst_fine = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const Vec3d a = random_vector(gen), b = random_vector(gen);
    // Vertices from 1e-6 to 10 segment lengths away, feet inside and beyond both ends.
    const double t0 = std::uniform_real_distribution<double>(-1, 2)(gen);
    const double h = (b - a).norm() * std::pow(10.0, std::uniform_real_distribution<double>(-6, 1)(gen));
    Vec3d n = (b - a).unitOrthogonal();
    const Vec3d v = a + t0 * (b - a) + h * n;
    const detail::SegmentGeometry g = detail::segment_geometry(v, a, b);
    const double d_min = g.d * std::uniform_real_distribution<double>(0.1, 1)(gen);  // another handle may be nearer
    for (double u : {2.0, 1.0, 1.5, 3.0, 4.0, 7.5, 16.0, 40.0}) {
      const detail::SegmentMoments m = detail::segment_moments_exact(g, d_min, u);
      // The reference sees the geometry as computed (g.t0, g.h), so geometry rounding is not counted.
      const detail::SegmentMoments r = u == 2.0 ? closed_form_u2(g.L, g.t0, g.h, d_min) : fine_reference(g, d_min, u);
      // All integrand terms are positive: relative rounding <= (16 nodes x pieces + 16 per-node roundings)
      // eps, plus the quadrature error (<= 1e-17, weights.hpp), plus, for the closed form, its cancellation
      // (terms up to ~1/(h L) against a result ~ 1 / L^2 for feet inside: a factor L / h, in long double).
      const double eps = std::numeric_limits<double>::epsilon();
      const double cancel = u == 2.0 ? double(std::numeric_limits<LD>::epsilon()) * (g.L / g.h + 1) * 64 : 0;
      const double tol = (16.0 * pieces(g, u) + 16) * eps + 1e-17 + double(cancel);
      for (auto [got, want] : {std::pair{m.I0, r.I0}, {m.I1, r.I1}, {m.I2, r.I2}}) {
        INFO("u " << u << " t0 " << g.t0 << " h/L " << g.h / g.L << " got " << got << " want " << want);
        // I1 carries t(1-t) -> 0 at both ends: compare it relative to the total weight.
        const double scale = std::max(std::abs(want), r.I0 + 2 * r.I1 + r.I2);
        CHECK(std::abs(got - want) <= tol * scale);
        worst = std::max(worst, std::abs(got - want) / scale);
        if (u != 2.0) worst_fine = std::max(worst_fine, std::abs(got - want) / scale);
      }
    }
  }
  std::cout << "[segment quadrature] largest relative error " << worst << " (" << worst_fine
            << " against the long-double rule, u != 2)\n";
}

namespace {

/// Moments of one side-split integral, in long double; J1abs = int w |t - tc| dt, the scale of J1.
struct RefMoments {
  LD I0 = 0, I1 = 0, I2 = 0, J1 = 0, J2 = 0, J1abs = 0;
};

/// An independent long-double reference for large u, in x (not in the library's sigma): 24-point
/// Gauss-Legendre on uniform pieces of a quarter of the peak's width, min(d / sqrt(u), d^2 / (u off)) (the
/// Gaussian width where the foot is inside, the exponential decay length beyond an end), up to where
/// u/2 log(dist^2 / d^2) = 100. The weight is (d_min / d)^u exp(-u/2 log1p(x (2 off + x) / (h^2 + off^2))),
/// with d^2 = h^2 + off^2 as the library takes it, and the ratio d_min / d rounded to double as the library's
/// is: the problem's conditioning in d is u (a relative change of d by eps moves w by u eps), so the
/// reference must see the same d to test the quadrature. Beyond the cut w < e^-100 and decays at least as
/// (d / dist)^u, so the part dropped is below e^-100 of the peak's integral; each piece's integrand changes
/// its exponent by at most ~4 (by sqrt(200) / 4 at the cut where the foot is inside, 1/4 per piece where the
/// decay is exponential), where 24 nodes are exact far below long double's eps.
RefMoments peaked_reference(const detail::SegmentGeometry& g, double d_min, LD u) {
  constexpr int N = 24;
  LD X[N], W[N];
  gauss_legendre(X, W);
  const LD h = g.h, off = g.off, L = g.L, d2 = h * h + off * off, d = std::sqrt(d2);
  LD width = d / std::sqrt(u);
  if (off > 0) width = std::min(width, d2 / (u * off));
  width /= 4;
  const LD factor = std::pow(LD(d_min / g.d), u);
  RefMoments m;
  for (int side = 1; side >= -1; side -= 2) {
    const LD len = (side > 0 ? 1 - LD(g.tc) : LD(g.tc)) * L;
    if (!(len > 0)) continue;
    const LD e2 = d2 * std::expm1(200 / u), cut = std::min(len, e2 / (std::sqrt(e2 + off * off) + off));
    const long pieces = std::max(1L, long(std::ceil(cut / width)));
    const LD step = cut / LD(pieces);
    for (long p = 0; p < pieces; ++p)
      for (int k = 0; k < N; ++k) {
        const LD x = (LD(p) + (1 + X[k]) / 2) * step;
        const LD w = step / 2 * W[k] * factor * std::exp(-u / 2 * std::log1p(x * (2 * off + x) / d2)) / L;
        const LD dt = x / L, t = g.tc + side * dt;
        m.I0 += w * (1 - t) * (1 - t);
        m.I1 += w * t * (1 - t);
        m.I2 += w * t * t;
        m.J1 += side * w * dt;
        m.J1abs += w * dt;
        m.J2 += w * dt * dt;
      }
  }
  return m;
}

/// Pieces of the library's rule in sigma (weights.hpp, segment_moments_peaked), for the rounding tolerance.
int peaked_pieces(const detail::SegmentGeometry& g, double u) {
  const double rho = std::min(1.0, g.off / g.d);
  const double sigma_s = rho == 1.0 ? HUGE_VAL : std::sqrt(-0.5 * u * std::log1p(-rho * rho));
  const double first = rho > 0 && sigma_s < 1 ? std::max(sigma_s, 0x1p-60) : 1.0;
  int p = 0;
  for (int side = 1; side >= -1; side -= 2) {
    const double len = (side > 0 ? 1 - g.tc : g.tc) * g.L;
    if (!(len > 0)) continue;
    const double end = std::min(8.0, std::sqrt(0.5 * u * std::log1p(len * (2 * g.off + len) / (g.d * g.d))));
    for (double a = 0; a < end; ++p) a = std::min(a == 0 ? first : a < 1 ? std::min(2 * a, 1.0) : a + 1, end);
  }
  return p;
}

}  // namespace

TEST_CASE("segment weight moments: beyond u = 64 the rule in sigma against a long-double rule in x",
          "[deformer][segment]") {
  std::mt19937_64 gen(seed());
  INFO("seed " << seed());
  const double eps = std::numeric_limits<double>::epsilon();
  double worst = 0;
  int most_pieces = 0;
  // Up to 1e50: beyond, J2 ~ (d / L)^2 I / u leaves the double range for small d (the reference's values
  // are then below DBL_MIN and the library's 0, both right).
  for (double u : {64.5, 100.0, 1e3, 3e4, 1e6, 1e10, 1e15, 1e50}) {
    for (int trial = 0; trial < 120; ++trial) {
      const Vec3d a = random_vector(gen), b = random_vector(gen);
      // As above, and the cases that steer the rule: feet just beyond an end (off tiny: the graded pieces),
      // vertices on the line (h = 0: no singularity), feet inside (off = 0).
      double t0 = std::uniform_real_distribution<double>(-1, 2)(gen);
      if (trial % 6 == 0)
        t0 = trial % 12 == 0 ? 1 + std::pow(10.0, -3.0 - trial % 11) : -std::pow(10.0, -2.0 - trial % 9);
      double h = (b - a).norm() * std::pow(10.0, std::uniform_real_distribution<double>(-6, 1)(gen));
      if (trial % 10 == 5) h = 0;
      const Vec3d v = a + t0 * (b - a) + h * (b - a).unitOrthogonal();
      const detail::SegmentGeometry g = detail::segment_geometry(v, a, b);
      if (!(g.d > 0)) continue;
      // The segment is the nearest handle or, for moderate u, one a little farther than another.
      const double d_min = u <= 1e3 ? g.d * 0.99 : g.d;
      const detail::SegmentMoments m = detail::segment_moments_exact(g, d_min, u);
      const RefMoments r = peaked_reference(g, d_min, u);
      // Every node's contribution is positive (but J1's, scaled by int w |t - tc|) and carries at most ~16
      // roundings (the mapping x(sigma), x'(sigma), exp, the products: a few eps each); the sums over 16
      // nodes and the pieces add one rounding per term: (16 pieces + 32) eps relative, plus the
      // quadrature's own error (below 1e-20 relative, weights.hpp) and pow's (one ulp of the factor).
      const int pieces = peaked_pieces(g, u);
      most_pieces = std::max(most_pieces, pieces);
      const double tol = (16.0 * pieces + 34) * eps;
      const LD total = r.I0 + 2 * r.I1 + r.I2;
      const std::pair<double, LD> checks[] = {{m.I0, std::max(std::abs(r.I0), total)},
                                              {m.I1, std::max(std::abs(r.I1), total)},
                                              {m.I2, std::max(std::abs(r.I2), total)},
                                              {m.J1, r.J1abs},
                                              {m.J2, r.J2}};
      const LD want[] = {r.I0, r.I1, r.I2, r.J1, r.J2};
      for (int c = 0; c < 5; ++c) {
        INFO("u " << u << " t0 " << g.t0 << " h/L " << g.h / g.L << " off/d " << g.off / g.d << " moment " << c
                  << " got " << checks[c].first << " want " << double(want[c]));
        const double err = double(std::abs(checks[c].first - want[c]) / checks[c].second);
        CHECK(err <= tol);
        worst = std::max(worst, err);
      }
    }
  }
  std::cout << "[segment quadrature, u > 64] largest relative error " << worst << ", at most " << most_pieces
            << " pieces\n";
}
