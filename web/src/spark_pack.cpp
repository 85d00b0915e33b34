// Spark 2.2.0's packed splats (spark_pack.hpp), written as its utils.ts writes them, rounding as JavaScript's
// Math.round does (half up).
#include "web/src/spark_pack.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace mlsdeform::web {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kC0 = 0.28209479177387814;  // 1 / (2 sqrt(pi)): band 0's basis function
constexpr double kLnScaleZero = -30;         // Spark's LN_SCALE_ZERO: a scale below exp(-30) is stored as 0

double js_round(double x) { return std::floor(x + 0.5); }
std::uint32_t byte_of(double unit) { return std::uint32_t(std::clamp(js_round(unit * 255), 0.0, 255.0)); }

/// float -> half as Spark's toHalfJS: the mantissa truncated, overflow to infinity, tiny values to zero.
std::uint32_t half_of(float f) {
  std::uint32_t bits;  // std::bit_cast: not in emscripten 3.1.6's libc++
  std::memcpy(&bits, &f, 4);
  const std::uint32_t sign = (bits >> 31) << 15, frac = bits & 0x7fffff;
  const int exp = int((bits >> 23) & 0xff);
  if (exp == 255) return sign | (frac ? 0x7fffu : 0x7c00u);
  const int e = exp - 127 + 15;
  if (e >= 31) return sign | 0x7c00u;
  if (e <= 0) return e < -10 ? sign : sign | ((frac | 0x800000u) >> (1 - e + 13));
  return sign | std::uint32_t(e) << 10 | frac >> 13;
}

/// encodeQuatOctXy88R8: the rotation's axis on the octahedron (u, v bytes) and its angle in [0, pi] (a byte).
std::uint32_t quaternion_code(const double q_in[4]) {
  const double len = std::sqrt(q_in[0] * q_in[0] + q_in[1] * q_in[1] + q_in[2] * q_in[2] + q_in[3] * q_in[3]);
  double w = q_in[0] / len, x = q_in[1] / len, y = q_in[2] / len, z = q_in[3] / len;
  if (w < 0) w = -w, x = -x, y = -y, z = -z;
  const double theta = 2 * std::acos(std::min(w, 1.0));
  const double xyz = std::sqrt(x * x + y * y + z * z);
  double ax = 1, ay = 0, az = 0;
  if (!(xyz < 1e-6)) ax = x / xyz, ay = y / xyz, az = z / xyz;
  const double sum = std::fabs(ax) + std::fabs(ay) + std::fabs(az);
  double px = ax / sum, py = ay / sum;
  if (az < 0) {
    const double t = px;
    px = (1 - std::fabs(py)) * (px >= 0 ? 1 : -1);
    py = (1 - std::fabs(t)) * (py >= 0 ? 1 : -1);
  }
  const auto u = std::uint32_t(js_round((px * 0.5 + 0.5) * 255));
  const auto v = std::uint32_t(js_round((py * 0.5 + 0.5) * 255));
  const auto angle = std::uint32_t(js_round(theta * (255 / kPi)));
  return angle << 16 | v << 8 | u;
}

/// Count signed fields of Bits bits, packed low bits first across Words words (encodeSh1Rgb, encodeSh3Rgb),
/// each value scaled and clamped to [-limit, limit] (in float: these are display bytes; fmin / fmax send a NaN
/// to a bound); templated so that every field's word and shift are constants.
template <int Bits, int Count, int Words>
void pack_signed(const float* rgb, float scale, std::uint32_t* words) {
  constexpr float limit = float((1 << (Bits - 1)) - 1);
  std::uint32_t w[Words] = {};
  for (int i = 0; i < Count; ++i) {
    const float s = std::fmax(-limit, std::fmin(limit, rgb[i] * scale));
    const std::uint32_t value = std::uint32_t(int(std::floor(s + 0.5f))) & ((1u << Bits) - 1);
    const int start = i * Bits, word = start / 32, offset = start % 32;
    w[word] |= value << offset;
    if (offset + Bits > 32) w[word + 1] |= value >> (32 - offset);
  }
  std::copy_n(w, Words, words);
}

}  // namespace

std::size_t spark_capacity(std::size_t n) {
  constexpr std::size_t width = 2048, max_height = 2048;
  const std::size_t height = std::max<std::size_t>(1, std::min(max_height, (n + width - 1) / width));
  const std::size_t depth = (n + width * height - 1) / (width * height);
  return width * height * std::max<std::size_t>(depth, 1);
}

std::uint32_t pack_colour(float opacity, const float f_dc[3], const SparkEncoding& e) {
  std::uint32_t rgb[3];
  for (int c = 0; c < 3; ++c)
    rgb[c] = byte_of((0.5 + kC0 * double(f_dc[c]) - e.rgb_min) / double(e.rgb_max - e.rgb_min));
  const std::uint32_t alpha = byte_of(1 / (1 + std::exp(-double(opacity))));
  return rgb[0] | rgb[1] << 8 | rgb[2] << 16 | alpha << 24;
}

void pack_pose(std::uint32_t* out, const float centre[3], const float log_scale[3], const double q[4],
               const SparkEncoding& e) {
  const std::uint32_t quat = quaternion_code(q);
  const double step = 254 / double(e.ln_scale_max - e.ln_scale_min);
  std::uint32_t scale[3];
  for (int c = 0; c < 3; ++c)
    scale[c] =
        log_scale[c] < kLnScaleZero
            ? 0
            : std::uint32_t(std::clamp(js_round((double(log_scale[c]) - e.ln_scale_min) * step) + 1, 1.0, 255.0));
  out[1] = half_of(centre[0]) | half_of(centre[1]) << 16;
  out[2] = half_of(centre[2]) | (quat & 0xff) << 16 | ((quat >> 8) & 0xff) << 24;
  out[3] = scale[0] | scale[1] << 8 | scale[2] << 16 | ((quat >> 16) & 0xff) << 24;
}

void pack_sh(const float* f_rest, int degree, const SparkEncoding& e, std::uint32_t* sh1, std::uint32_t* sh2,
             std::uint32_t* sh3) {
  const int k = (degree + 1) * (degree + 1) - 1;
  // Spark keeps each band coefficient-major with the channels inner (coefficient j of channel c at 3 j + c);
  // 3DGS keeps them channel-major (f_rest[c k + j]). Both order a band's coefficients m = -l..l alike.
  float band[21];
  auto gather = [&](int first, int count) {
    for (int j = 0; j < count; ++j)
      for (int c = 0; c < 3; ++c) band[3 * j + c] = f_rest[c * k + first + j];
  };
  if (degree >= 1) {
    gather(0, 3);
    pack_signed<7, 9, 2>(band, 63 / e.sh_max[0], sh1);
  }
  if (degree >= 2) {
    gather(3, 5);
    band[15] = 0;  // the fourth word's last byte
    pack_signed<8, 16, 4>(band, 127 / e.sh_max[1], sh2);
  }
  if (degree >= 3) {
    gather(8, 7);
    pack_signed<6, 21, 4>(band, 31 / e.sh_max[2], sh3);
  }
}

}  // namespace mlsdeform::web
