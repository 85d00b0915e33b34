// Inverse-distance weights of the MLS deformer (paper Sec. 3, w_i = |p_i - v|^-u, and Sec. 6.2 for segments),
// scalar reference in double, used by the precomputed table (precompute_table.cpp) for every precision T.
//
// Scale invariance and range. All weights are taken relative to the nearest handle: w = (d_min / d)^u, so
// they lie in [0, 1], the nearest handle has weight 1 and nothing overflows for any u >= 1 or any scene
// size. The caller works in "local" coordinates (the scene translated to its bounding-box centre and scaled
// by an exact power of two to a unit-sized box), so squared distances cannot overflow or underflow either.
//
// Segments (Sec. 6.2). A segment a -> b, p(t) = (1 - t) a + t b, enters the fit through the three moments
//   I0 = int_0^1 w(t) (1-t)^2 dt,   I1 = int_0^1 w(t) t (1-t) dt,   I2 = int_0^1 w(t) t^2 dt
// (the entries of the paper's W_i, whose diagonal the paper lists in the opposite order; for the symmetric
// constant weight that is the same matrix). int w (1-t) = I0 + I1 and int w t = I1 + I2 are the centroid
// weights of the end points, int w = I0 + 2 I1 + I2 the segment's total weight.
//   paper_constant   w(t) = (d_min / d)^u with d the distance from v to the segment: I0 = I2 = w/3, I1 = w/6.
//   exact_integral   w(t) = (d_min / |p(t) - v|)^u, by composite Gauss-Legendre quadrature (below), in x
//                    for u <= 64 and in the Gaussian variable sigma beyond, at a cost independent of u.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cmath>

namespace mlsdeform::detail {

/// r^u for r = d_min / d in [0, 1] and u >= 1. Integer exponents up to 16 (the paper's 2, 3, 4) use
/// repeated squaring: exact to a few ulps, cheaper than pow, and the same on every platform.
inline double relative_weight(double r, double u) {
  if (u == std::floor(u) && u <= 16.0) {
    unsigned k = static_cast<unsigned>(u);
    double result = 1.0, base = r;
    while (k != 0) {
      if (k & 1u) result *= base;
      base *= base;
      k >>= 1;
    }
    return result;
  }
  return std::pow(r, u);
}

/// The N-point Gauss-Legendre rule on [-1, 1], nodes by Newton's method on P_N in long double (computed
/// once, thread-safe static initialisation); nodes and weights are correct to the last bit of a double.
template <int N>
struct GaussLegendre {
  std::array<double, N> x, w;
};

template <int N>
const GaussLegendre<N>& gauss_legendre() {
  static const GaussLegendre<N> rule = [] {
    GaussLegendre<N> g{};
    const long double pi = 3.141592653589793238462643383279502884L;
    for (int i = 0; i < N; ++i) {
      long double z = std::cos(pi * (i + 0.75L) / (N + 0.5L));
      long double dp = 1;
      for (int it = 0; it < 100; ++it) {
        long double p0 = 1, p1 = z;
        for (int k = 2; k <= N; ++k) {
          const long double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
          p0 = p1;
          p1 = p2;
        }
        dp = N * (z * p1 - p0) / (z * z - 1);
        const long double dz = p1 / dp;
        z -= dz;
        if (std::fabs(dz) < 1e-20L) break;
      }
      g.x[i] = static_cast<double>(z);
      g.w[i] = static_cast<double>(2 / ((1 - z * z) * dp * dp));
    }
    return g;
  }();
  return rule;
}

/// Where a vertex v lies relative to the segment a -> b (length L > 0): the foot t0 of the perpendicular on
/// the line, its length h, the closest point of the segment tc = clamp(t0, 0, 1), the distance d from v to
/// the segment, and off = L |tc - t0| (the distance along the line from the foot to the closest point).
/// The distance to p(t) is then sqrt(h^2 + (off + L |t - tc|)^2) for t on the far side of tc from t0:
/// a sum of non-negative squares, with no cancellation near the closest point.
struct SegmentGeometry {
  double L, t0, tc, h, off, d;
};

inline SegmentGeometry segment_geometry(const Eigen::Vector3d& v, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  SegmentGeometry g;
  const Eigen::Vector3d e = b - a, w = v - a;
  const double L2 = e.squaredNorm();
  g.L = std::sqrt(L2);
  g.t0 = w.dot(e) / L2;
  g.h = (w - g.t0 * e).norm();
  g.tc = std::clamp(g.t0, 0.0, 1.0);
  g.off = g.L * std::abs(g.tc - g.t0);
  g.d = std::sqrt(g.h * g.h + g.off * g.off);
  return g;
}

/// The moments (I0, I1, I2) of the weight along a segment, see the file comment, and its first and second
/// moments about the closest point tc, J1 = int w (t - tc) dt and J2 = int w (t - tc)^2 dt. Near a segment
/// with exact_integral weights, w is a peak of width ~ d around tc: the weighted spread about p* is O(d^2),
/// which combinations of I0, I1, I2 with the end points (O(1) each) would give only as a difference of O(1)
/// terms (error eps, not eps d^2); J1 and J2 carry it directly (precompute_table.cpp).
struct SegmentMoments {
  double I0 = 0, I1 = 0, I2 = 0;
  double J1 = 0, J2 = 0;
};

/// One side's quadrature sums of the moments (segment_moments_exact and _peaked): nodes at arc length x from
/// the closest point tc on `side` (+1 towards t = 1, -1 towards t = 0), then added to the moments scaled.
struct SideSums {
  double s0 = 0, s1 = 0, s2 = 0, c1 = 0, c2 = 0;

  void add(const SegmentGeometry& g, int side, double x, double w) {
    // t and 1 - t, each as a difference from the closest point (no cancellation at either end).
    const double dt = x / g.L;
    const double t = side > 0 ? g.tc + dt : g.tc - dt;
    const double omt = side > 0 ? (1.0 - g.tc) - dt : (1.0 - g.tc) + dt;
    s0 += w * omt * omt;
    s1 += w * t * omt;
    s2 += w * t * t;
    c1 += w * dt;  // times side below: t - tc = side dt
    c2 += w * dt * dt;
  }
  void add_to(SegmentMoments& m, int side, double scale) const {
    m.I0 += scale * s0;
    m.I1 += scale * s1;
    m.I2 += scale * s2;
    m.J1 += side * scale * c1;
    m.J2 += scale * c2;
  }
};

/// The moments of the constant weight w on [0, 1], closest point tc.
inline SegmentMoments segment_moments_of_constant(double w, double tc) {
  const double a = 1 - tc;
  return {w / 3.0, w / 6.0, w / 3.0, w * (0.5 - tc), w * (a * a * a + tc * tc * tc) / 3.0};
}

/// Paper's simplification (Sec. 6.2): constant weight (d_min / d)^u.
inline SegmentMoments segment_moments_constant(const SegmentGeometry& g, double d_min, double u) {
  return segment_moments_of_constant(relative_weight(d_min / g.d, u), g.tc);
}

/// Number of Gauss-Legendre nodes per piece of the composite rule below.
inline constexpr int kSegmentQuadratureNodes = 16;

/// Above this exponent segment_moments_exact integrates in sigma (segment_moments_peaked): the rule in x
/// needs pieces at most 8/u times their distance to the vertex, about (u / 8) log(len / d) of them per side,
/// so its cost would grow without bound with u (the measured accuracy below covers u <= 64).
inline constexpr double kPeakedExponent = 64;

/// (expm1(y) / y, -log1p(-z) / z) for y, z >= 0: 1 where the argument is so small that the quotient is 1 in
/// double (below 2^-500 the next term, y / 2, is below 2^-501), so that a tiny argument's underflow costs
/// nothing.
inline double expm1_ratio(double y) { return y > 0x1p-500 ? std::expm1(y) / y : 1.0; }
inline double log1m_ratio(double z) { return z > 0x1p-500 ? -std::log1p(-z) / z : 1.0; }

/// The moments of segment_moments_exact for u > kPeakedExponent, at a cost independent of u.
///
/// Change of variable. On one side of the closest point, with r = off + x the distance along the line from
/// the foot, dist^2 = h^2 + r^2 = d^2 e^(2 sigma^2 / u) defines sigma >= 0, so that
///   w = (d_min / dist)^u = (d_min / d)^u e^(-sigma^2)   exactly,
/// and the side's integral is (d_min / d)^u int_0^sigma_end e^(-sigma^2) f(t(x(sigma))) x'(sigma) dsigma / L,
/// f one of (1-t)^2, t(1-t), t^2, t - tc, (t - tc)^2. With tau = sigma sqrt(2 / u), rho = off / d in [0, 1]
/// and E = expm1(tau^2) / tau^2 (so expm1(tau^2) = tau^2 E; E in [1, e^2] on sigma <= 8):
///   r / d = hypot(rho, tau sqrt(E)),   x / d = tau (tau E / (r / d + rho)),
///   x'(sigma) = d sqrt(2 / u) e^(tau^2) (tau / (r / d)),   with tau / (r / d) in [0, 1],
/// each a product of factors of moderate size: no cancellation, and for any u up to the double range
/// nothing underflows that matters (tau >= 1e-157 stays normal; tau^2 may not, and enters only through
/// E, which is then exactly 1).
/// Truncation at sigma = 8: e^(-sigma^2) e^(tau^2) <= e^(-sigma^2 (1 - 2/u)) <= e^(-62) beyond it (u > 64),
/// and f grows at most like x^2 ~ sigma^2 there, so what is dropped is below 1e-24 of the side's integral.
/// Pieces. The integrand is analytic in sigma except where r / d = 0: tau^2 = log(1 - rho^2) + 2 pi i k. For
/// k != 0, |sigma| >= sqrt(pi u) >= 14, at least 6 from [0, 8]; for k = 0, sigma = +-i sigma_s with
/// sigma_s = sqrt(u / 2) rho sqrt(-log1p(-rho^2) / rho^2) (infinite for rho = 1, the vertex on the line; for
/// rho = 0, the foot inside the segment, x(sigma) = d tau sqrt(E) is analytic at 0: no singularity). So: when
/// 0 < sigma_s < 1, pieces [0, a], [a, 2a], [2a, 4a] ... up to 1, a = max(sigma_s, 2^-60) (each piece no
/// longer than its distance to +-i sigma_s: Bernstein ellipse parameter >= 4.6, 16-point error ~4.6^-32 =
/// 1e-21; below 2^-60 the piece [0, a] holds at most 2^-60 of the integral whatever the rule does there),
/// then unit pieces up to min(8, sigma_end): at most 61 + 8 pieces per side, 8 when rho = 0 or sigma_s >= 1.
/// sigma_end = sqrt(u / 2 log1p(len (2 off + len) / d^2)) is the side's far end (sigma of r = off + len).
inline SegmentMoments segment_moments_peaked(const SegmentGeometry& g, double d_min, double u) {
  const auto& rule = gauss_legendre<kSegmentQuadratureNodes>();
  const double root = std::sqrt(2.0 / u);  // tau / sigma
  const double rho = std::min(1.0, g.off / g.d);
  const double sigma_s = rho == 1.0 ? HUGE_VAL : std::sqrt(0.5 * u) * rho * std::sqrt(log1m_ratio(rho * rho));
  const double first = rho > 0 && sigma_s < 1 ? std::max(sigma_s, 0x1p-60) : 1.0;
  SegmentMoments m;
  for (int side = 1; side >= -1; side -= 2) {
    const double len_t = side > 0 ? 1.0 - g.tc : g.tc;
    if (!(len_t > 0)) continue;
    const double len = len_t * g.L;
    const double sigma_end = std::min(8.0, std::sqrt(0.5 * u * std::log1p(len * (2 * g.off + len) / (g.d * g.d))));
    SideSums sums;
    for (double a = 0; a < sigma_end;) {
      const double b = std::min(a == 0 ? first : a < 1 ? std::min(2 * a, 1.0) : a + 1, sigma_end);
      const double mid = 0.5 * (a + b), half = 0.5 * (b - a);
      for (int k = 0; k < kSegmentQuadratureNodes; ++k) {
        const double sigma = mid + half * rule.x[k];
        const double tau = root * sigma, y = tau * tau, E = expm1_ratio(y);
        const double r_d = std::hypot(rho, tau * std::sqrt(E));
        const double x = g.d * (tau * (tau * E / (r_d + rho)));
        const double dx = g.d * root * std::exp(y) * (tau / r_d);
        sums.add(g, side, x, half * rule.w[k] * std::exp(-sigma * sigma) * dx);
      }
      a = b;
    }
    sums.add_to(m, side, relative_weight(d_min / g.d, u) / g.L);
  }
  return m;
}

/// Exact integral of w(t) = (d_min / |p(t) - v|)^u times (1-t)^2, t(1-t), t^2 over [0, 1].
///
/// Method (u <= kPeakedExponent; beyond, segment_moments_peaked): split at the closest point tc; on each side, with x
/// the arc length from tc, use pieces [0, kappa d], then [x_k, (1 + kappa) x_k] up to the end, kappa = min(1, 8/u), and
/// 16-point Gauss-Legendre on each. The integrand is analytic except at the complex points where |p(t) - v| = 0, whose
/// distance to a real point x is the physical distance |p(x) - v| >= max(d, x); so every piece is at most kappa times
/// as long as its distance to the singularities (Bernstein ellipse parameter >= 4.2), and the peak of
/// width ~ d / sqrt(u) is resolved for large u. Pieces per side: 1 + log(len/d) / log(1 + kappa).
///
/// Accuracy (measured against a 40-point rule on pieces four times shorter, in long double, for u in
/// [1, 64], h/L from 1e-12 to 10, closest point inside and beyond the ends): quadrature error below 1e-17
/// relative; what remains is double rounding, a few ulps times the number of pieces.
inline SegmentMoments segment_moments_exact(const SegmentGeometry& g, double d_min, double u) {
  if (u > kPeakedExponent) return segment_moments_peaked(g, d_min, u);
  const auto& rule = gauss_legendre<kSegmentQuadratureNodes>();
  const double kappa = std::min(1.0, 8.0 / u);
  SegmentMoments m;
  for (int side = 1; side >= -1; side -= 2) {
    // The far side of tc from the foot t0 (only one side when tc is an end point beyond the foot).
    const double len_t = side > 0 ? 1.0 - g.tc : g.tc;
    if (!(len_t > 0)) continue;
    const double len = len_t * g.L;
    double x0 = 0;
    while (x0 < len) {
      const double x1 = std::min(x0 == 0 ? kappa * g.d : (1 + kappa) * x0, len);
      const double mid = 0.5 * (x0 + x1), half = 0.5 * (x1 - x0);
      SideSums sums;
      for (int k = 0; k < kSegmentQuadratureNodes; ++k) {
        const double x = mid + half * rule.x[k];
        const double r = g.off + x;
        const double dist = std::sqrt(g.h * g.h + r * r);
        sums.add(g, side, x, rule.w[k] * relative_weight(d_min / dist, u));
      }
      sums.add_to(m, side, half / g.L);  // dt = dx / L
      x0 = x1;
    }
  }
  return m;
}

}  // namespace mlsdeform::detail
