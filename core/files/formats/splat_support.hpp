// mlsdeform files: small helpers the splat codecs share (little-endian loads and stores, messages naming a
// splat and a property, the checks of a value against a format's range).
#pragma once

#include <mlsdeform/files_error.hpp>
#include "core/files/file_io.hpp"
#include "core/files/formats/splat_codecs.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>

namespace mlsdeform::files {

namespace splat_detail {

inline std::uint32_t load_u32(const unsigned char* p) {
  return std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24;
}
inline std::uint64_t load_u64(const unsigned char* p) {
  return std::uint64_t(load_u32(p)) | std::uint64_t(load_u32(p + 4)) << 32;
}
inline float load_f32(const unsigned char* p) {
  const std::uint32_t u = load_u32(p);
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}
inline void store_u32(std::string& out, std::uint32_t v) {
  const char b[4] = {char(v & 0xff), char(v >> 8 & 0xff), char(v >> 16 & 0xff), char(v >> 24 & 0xff)};
  out.append(b, 4);
}
inline void store_u64(std::string& out, std::uint64_t v) {
  store_u32(out, std::uint32_t(v));
  store_u32(out, std::uint32_t(v >> 32));
}
inline void store_f32(std::string& out, float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, 4);
  store_u32(out, u);
}

/// The 3DGS name of property `k` of a splat's SH rest (f_rest_k), its scale (scale_k), and so on.
inline std::string indexed(const char* base, std::size_t k) { return std::string(base) + std::to_string(k); }

/// Shortest round-trip text of a float, for messages.
std::string shown_value(double v);

/// Refuses `v`, splat `i`'s property `name`, which `format` cannot hold: the message names the splat, the
/// property, the value and the range the format holds (about lo .. hi).
[[noreturn]] inline void refuse(const std::string& path, const char* format, std::size_t i, const std::string& name,
                                double v, double lo, double hi) {
  throw InputError(path, "splat " + std::to_string(i) + ": " + name + " = " + shown_value(v) + " is outside what " +
                             format + " holds (" + shown_value(lo) + " .. " + shown_value(hi) + "); nothing written");
}

/// logit(u / d) in double, rounded once to float: -infinity for u = 0, +infinity for u = d (alpha 0 or 1).
inline float logit_of(double u, double d) { return float(std::log(u / (d - u))); }
inline double sigmoid(double x) { return 1 / (1 + std::exp(-x)); }

/// The unit quaternion of splat i's rot (w x y z) in double; refuses a zero or non-finite one.
void unit_quaternion(const SplatCloud& c, std::size_t i, const std::string& path, const char* format, double q[4]);

}  // namespace splat_detail
}  // namespace mlsdeform::files
