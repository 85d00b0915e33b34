// mlsdeform files: the antimatter15 `.splat` layout (docs/splats.md ".splat"): 32 bytes a splat, no header:
// float x y z, float linear standard deviations (exp of 3DGS's log scales), bytes R G B A (0.5 + C0 f_dc and
// the sigmoid of the opacity, times 255), bytes of the unit quaternion w x y z (q * 128 + 128). PLY's axes;
// SH degree 0. Read only.
#include "core/files/formats/splat_codecs.hpp"
#include "core/files/formats/splat_support.hpp"

#include <cmath>

namespace mlsdeform::files {

using namespace splat_detail;

SplatCloud decode_splat(std::string_view bytes, const std::string& path) {
  if (bytes.empty()) throw InputError(path, ".splat: empty file");
  if (bytes.size() % 32 != 0)
    throw InputError(
        path, ".splat: " + std::to_string(bytes.size()) + " bytes, not a whole number of 32-byte splats (truncated?)");
  constexpr double kC0 = 0.28209479177387814;
  const std::size_t n = bytes.size() / 32;
  SplatCloud c;
  c.resize(n, 0);
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  static const char* const axis[3] = {"x", "y", "z"};
  for (std::size_t i = 0; i < n; ++i, p += 32) {
    for (std::size_t j = 0; j < 3; ++j) {
      const float x = load_f32(p + 4 * j), s = load_f32(p + 12 + 4 * j);
      if (!std::isfinite(x))
        throw InputError(path, ".splat: splat " + std::to_string(i) + ": " + axis[j] + " is not finite");
      if (!(s > 0) || !std::isfinite(s))
        throw InputError(path, ".splat: splat " + std::to_string(i) + ": scale " + shown_value(s) + " along " +
                                   axis[j] + " (a standard deviation must be positive and finite)");
      c.position[i * 3 + j] = x;
      c.scale[i * 3 + j] = float(std::log(double(s)));
      c.f_dc[i * 3 + j] = float((p[24 + j] / 255.0 - 0.5) / kC0);
    }
    c.opacity[i] = logit_of(p[27], 255);
    double q[4], n2 = 0;
    for (std::size_t j = 0; j < 4; ++j) {
      q[j] = (p[28 + j] - 128.0) / 128.0;
      n2 += q[j] * q[j];
    }
    if (n2 == 0)
      throw InputError(path, ".splat: splat " + std::to_string(i) +
                                 ": the quaternion bytes are all 128 (zero), "
                                 "no orientation");
    for (std::size_t j = 0; j < 4; ++j) c.rot[i * 4 + j] = float(q[j] / std::sqrt(n2));
  }
  return c;
}

}  // namespace mlsdeform::files
