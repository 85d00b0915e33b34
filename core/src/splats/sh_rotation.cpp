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

/// Band 3 of sh_basis (its entries 8..14).
std::array<double, 7> band3(const std::array<double, 3>& d) {
  const double x = d[0], y = d[1], z = d[2];
  const double xx = x * x, yy = y * y, zz = z * z;
  return {C3[0] * y * (3 * xx - yy),      C3[1] * x * y * z,
          C3[2] * y * (4 * zz - xx - yy), C3[3] * z * (2 * zz - 3 * xx - 3 * yy),
          C3[4] * x * (4 * zz - xx - yy), C3[5] * z * (xx - yy),
          C3[6] * x * (xx - 3 * yy)};
}

// The 26-point Lebedev rule (degree 7): 6 axis points of weight 1/21, 12 edge midpoints of weight 4/105 and 8
// corners of weight 9/280 (the weights sum to 1, times the sphere's area 4 pi). The points come in antipodal
// pairs, and f_3(-x) B_3m(-x) = f_3(x) B_3m(x) (both odd): so one point of each pair, at twice its weight.
constexpr std::size_t kPoints = 13;
struct Rule {
  std::array<std::array<double, 3>, kPoints> x;
  // 8 pi w_p B_3m(x_p): what turns band 3's values at the points into its coefficients.
  std::array<std::array<double, 7>, kPoints> project;
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
  for (std::size_t p = 0; p < kPoints; ++p) {
    const double w = p < 3 ? 1.0 / 21.0 : p < 9 ? 4.0 / 105.0 : 9.0 / 280.0;
    const std::array<double, 7> basis = band3(r.x[p]);
    for (std::size_t m = 0; m < 7; ++m) r.project[p][m] = 8.0 * std::numbers::pi * w * basis[m];
  }
  return r;
}

const Rule& rule() {
  static const Rule r = make_rule();
  return r;
}

/// Band 1: f_1(x) = C1 v . x with v = (-c_2, -c_0, c_1) (the basis is C1 (-y, z, -x)), so f_1(R^T x) =
/// C1 (R v) . x: the coefficients of R v (of -R v mirrored, f_1 being odd). Exact but for 3 roundings a value.
void rotate_band1(double* c, const double R[9], double sign) {
  const double v[3] = {-c[2], -c[0], c[1]};
  double w[3];
  for (int i = 0; i < 3; ++i) w[i] = sign * (R[3 * i] * v[0] + R[3 * i + 1] * v[1] + R[3 * i + 2] * v[2]);
  c[0] = -w[1];
  c[1] = w[2];
  c[2] = -w[0];
}

/// Band 2: f_2(x) = x^T A x with A symmetric and traceless (A_01 = C2_0 c_0 / 2, A_12 = C2_1 c_1 / 2,
/// A_02 = C2_3 c_3 / 2, A_22 = 2 C2_2 c_2, A_00 = -C2_2 c_2 + C2_4 c_4, A_11 = -C2_2 c_2 - C2_4 c_4), so
/// f_2(R^T x) = x^T (R A R^T) x, and the coefficients are read back from R A R^T (which stays traceless);
/// f_2 is even, so a mirror changes nothing. Exact but for a few roundings a value.
void rotate_band2(double* c, const double R[9]) {
  const double d = C2[2] * c[2], e = C2[4] * c[4];
  const double A[3][3] = {{e - d, C2[0] * c[0] / 2, C2[3] * c[3] / 2},
                          {C2[0] * c[0] / 2, -d - e, C2[1] * c[1] / 2},
                          {C2[3] * c[3] / 2, C2[1] * c[1] / 2, 2 * d}};
  double RA[3][3], B[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) RA[i][j] = R[3 * i] * A[0][j] + R[3 * i + 1] * A[1][j] + R[3 * i + 2] * A[2][j];
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j) B[i][j] = RA[i][0] * R[3 * j] + RA[i][1] * R[3 * j + 1] + RA[i][2] * R[3 * j + 2];
  c[0] = 2 * B[0][1] / C2[0];
  c[1] = 2 * B[1][2] / C2[1];
  c[2] = B[2][2] / (2 * C2[2]);
  c[3] = 2 * B[0][2] / C2[3];
  c[4] = (B[0][0] - B[1][1]) / (2 * C2[4]);
}

}  // namespace

std::array<double, 15> sh_basis(const std::array<double, 3>& d) {
  const double x = d[0], y = d[1], z = d[2];
  const double xx = x * x, yy = y * y, zz = z * z;
  const std::array<double, 7> b3 = band3(d);
  return {-C1 * y,       C1 * z,
          -C1 * x,       C2[0] * x * y,
          C2[1] * y * z, C2[2] * (2 * zz - xx - yy),
          C2[3] * x * z, C2[4] * (xx - yy),
          b3[0],         b3[1],
          b3[2],         b3[3],
          b3[4],         b3[5],
          b3[6]};
}

template <class T>
void rotate_sh(T* sh_rest, int degree, const double R[9], bool mirror) {
  if (degree <= 0) return;
  const int k = (degree + 1) * (degree + 1) - 1;
  // Band 3: its basis at the points moved back, R^T x_p, stored basis-major so that the loops below sum every
  // point's value at once (independent sums: one chain of dependent additions after another would run at the
  // adder's latency, a third of its throughput).
  alignas(64) double back[7][kPoints];
  const Rule* r = nullptr;
  if (degree == 3) {
    r = &rule();
    for (std::size_t p = 0; p < kPoints; ++p) {
      const std::array<double, 3>& x = r->x[p];
      const std::array<double, 7> b =
          band3({R[0] * x[0] + R[3] * x[1] + R[6] * x[2], R[1] * x[0] + R[4] * x[1] + R[7] * x[2],
                 R[2] * x[0] + R[5] * x[1] + R[8] * x[2]});
      for (std::size_t m = 0; m < 7; ++m) back[m][p] = b[m];
    }
  }
  const double odd = mirror ? -1.0 : 1.0;  // f'(x) = f(-R^T x) mirrored: odd bands change sign
  for (int channel = 0; channel < 3; ++channel) {
    T* c = sh_rest + channel * k;
    double rotated[15];
    for (int j = 0; j < k; ++j) rotated[j] = double(c[j]);
    rotate_band1(rotated, R, odd);
    if (degree >= 2) rotate_band2(rotated + 3, R);
    if (degree == 3) {
      double f[kPoints] = {};  // f_3(R^T x_p): band 3 of the old colour at the moved-back points
      for (std::size_t m = 0; m < 7; ++m) {
        const double cm = odd * double(c[8 + m]);
        for (std::size_t p = 0; p < kPoints; ++p) f[p] += cm * back[m][p];
      }
      for (std::size_t m = 0; m < 7; ++m) rotated[8 + m] = 0;
      for (std::size_t p = 0; p < kPoints; ++p)
        for (std::size_t m = 0; m < 7; ++m) rotated[8 + m] += r->project[p][m] * f[p];
    }
    for (int j = 0; j < k; ++j) c[j] = T(rotated[j]);
  }
}

template void rotate_sh<float>(float*, int, const double*, bool);
template void rotate_sh<double>(double*, int, const double*, bool);

}  // namespace mlsdeform::detail
