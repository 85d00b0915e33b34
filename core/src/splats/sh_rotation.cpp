#include "core/src/splats/sh_rotation.hpp"

#include <cmath>
#include <cstddef>
#include <numbers>

namespace mlsdeform::detail {

namespace {

// 3DGS's constants (sh_utils.py), the orthonormal real SH's normalisations with its signs.
constexpr double C1 = 0.4886025119029199;
constexpr double C2[5] = {1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792,
                          0.5462742152960396};
constexpr double C3[7] = {-0.5900435899266435, 2.890611442640554, -0.4570457994644658, 0.3731763325901154,
                          -0.4570457994644658, 1.445305721320277, -0.5900435899266435};

// The 26-point Lebedev rule (degree 7): 6 axis points of weight 1/21, 12 edge midpoints of weight 4/105 and 8
// corners of weight 9/280 (the weights sum to 1, times the sphere's area 4 pi). The points come in antipodal
// pairs, and f_l(-x) B_lm(-x) = (-1)^(2 l) f_l(x) B_lm(x): so one point of each pair, at twice its weight.
constexpr int kPoints = 13;
struct Rule {
  std::array<std::array<double, 3>, kPoints> x;
  // w[k] * 8 pi * B_j(x_k): what turns the values at the points into coefficients.
  std::array<std::array<double, 15>, kPoints> project;
};

Rule make_rule() {
  const double a = std::sqrt(0.5), b = std::sqrt(1.0 / 3.0);
  Rule r{};
  r.x = {{{1, 0, 0},
          {0, 1, 0},
          {0, 0, 1},  // axes
          {a, a, 0},
          {a, -a, 0},
          {a, 0, a},
          {a, 0, -a},
          {0, a, a},
          {0, a, -a},  // edges
          {b, b, b},
          {b, b, -b},
          {b, -b, b},
          {b, -b, -b}}};  // corners
  for (int k = 0; k < kPoints; ++k) {
    const double w = k < 3 ? 1.0 / 21.0 : k < 9 ? 4.0 / 105.0 : 9.0 / 280.0;
    const std::array<double, 15> basis = sh_basis(r.x[std::size_t(k)]);
    for (std::size_t j = 0; j < 15; ++j) r.project[std::size_t(k)][j] = 8.0 * std::numbers::pi * w * basis[j];
  }
  return r;
}

const Rule& rule() {
  static const Rule r = make_rule();
  return r;
}

}  // namespace

std::array<double, 15> sh_basis(const std::array<double, 3>& d) {
  const double x = d[0], y = d[1], z = d[2];
  const double xx = x * x, yy = y * y, zz = z * z;
  return {-C1 * y,
          C1 * z,
          -C1 * x,
          C2[0] * x * y,
          C2[1] * y * z,
          C2[2] * (2 * zz - xx - yy),
          C2[3] * x * z,
          C2[4] * (xx - yy),
          C3[0] * y * (3 * xx - yy),
          C3[1] * x * y * z,
          C3[2] * y * (4 * zz - xx - yy),
          C3[3] * z * (2 * zz - 3 * xx - 3 * yy),
          C3[4] * x * (4 * zz - xx - yy),
          C3[5] * z * (xx - yy),
          C3[6] * x * (xx - 3 * yy)};
}

template <class T>
void rotate_sh(T* sh_rest, int degree, const double R[9], bool mirror) {
  if (degree <= 0) return;
  const Rule& r = rule();
  const int k = (degree + 1) * (degree + 1) - 1;
  // The basis at the points moved back, R^T x_p (or -R^T x_p mirrored: the sign is band l's (-1)^l below),
  // stored basis-major so that the loops below run over the points, independent sums (one sum over the 7 terms of
  // a band per point, not one 13-term chain after another: a chain of dependent additions runs at the adder's
  // latency, a third of its throughput).
  alignas(64) double back[15][kPoints];
  for (std::size_t p = 0; p < kPoints; ++p) {
    const std::array<double, 3>& x = r.x[p];
    const std::array<double, 15> b =
        sh_basis({R[0] * x[0] + R[3] * x[1] + R[6] * x[2], R[1] * x[0] + R[4] * x[1] + R[7] * x[2],
                  R[2] * x[0] + R[5] * x[1] + R[8] * x[2]});
    for (std::size_t j = 0; j < 15; ++j) back[j][p] = b[j];
  }
  for (int channel = 0; channel < 3; ++channel) {
    T* c = sh_rest + channel * k;
    double rotated[15];
    for (int l = 1, first = 0; l <= degree; first += 2 * l + 1, ++l) {
      const int end = first + 2 * l + 1;
      const double sign = mirror && l % 2 == 1 ? -1.0 : 1.0;
      double f[kPoints] = {};  // f_l(R^T x_p): band l of the old colour at the moved-back points
      for (int j = first; j < end; ++j) {
        const double cj = sign * double(c[j]);
        for (std::size_t p = 0; p < kPoints; ++p) f[p] += cj * back[j][p];
      }
      for (int j = first; j < end; ++j) rotated[j] = 0;
      for (std::size_t p = 0; p < kPoints; ++p)
        for (int j = first; j < end; ++j) rotated[j] += r.project[p][std::size_t(j)] * f[p];
    }
    for (int j = 0; j < k; ++j) c[j] = T(rotated[j]);
  }
}

template void rotate_sh<float>(float*, int, const double*, bool);
template void rotate_sh<double>(double*, int, const double*, bool);

}  // namespace mlsdeform::detail
