// mlsdeform files: what the splat codecs share: the cloud's shape, the formats by file name, messages.
#include "core/files/formats/splat_codecs.hpp"
#include "core/files/formats/splat_support.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>

namespace mlsdeform::files {

void SplatCloud::resize(std::size_t n, int degree) {
  count = n;
  sh_degree = degree;
  position.assign(n * 3, 0.f);
  f_dc.assign(n * 3, 0.f);
  f_rest.assign(n * 3 * sh_per_channel(), 0.f);
  opacity.assign(n, 0.f);
  scale.assign(n * 3, 0.f);
  rot.assign(n * 4, 0.f);
}

int sh_degree_of(std::size_t coefficients) {
  switch (coefficients) {
    case 0:
      return 0;
    case 9:
      return 1;
    case 24:
      return 2;
    case 45:
      return 3;
    default:
      return -1;
  }
}

namespace {
bool ends_with_nocase(std::string_view s, std::string_view tail) {
  if (s.size() < tail.size()) return false;
  return std::equal(tail.begin(), tail.end(), s.end() - std::ptrdiff_t(tail.size()),
                    [](char a, char b) { return std::tolower(static_cast<unsigned char>(b)) == a; });
}
}  // namespace

SplatFormat splat_format(std::string_view path) {
  if (ends_with_nocase(path, ".spz")) return SplatFormat::spz;
  if (ends_with_nocase(path, ".splat")) return SplatFormat::splat;
  if (ends_with_nocase(path, ".compressed.ply")) return SplatFormat::compressed_ply;
  return SplatFormat::none;
}

const char* splat_format_name(SplatFormat f) {
  switch (f) {
    case SplatFormat::spz:
      return "SPZ";
    case SplatFormat::splat:
      return ".splat";
    case SplatFormat::compressed_ply:
      return "compressed PLY";
    default:
      return "3DGS PLY";
  }
}

bool looks_like_compressed_ply(std::string_view bytes) {
  if (bytes.substr(0, 4) != "ply\n") return false;
  const std::size_t end = bytes.substr(0, 1 << 16).find("end_header");
  const std::string_view header =
      bytes.substr(0, end == std::string_view::npos ? std::min<std::size_t>(bytes.size(), 1 << 16) : end);
  return header.find("\nelement chunk ") != std::string_view::npos &&
         header.find("\nproperty uint packed_position\n") != std::string_view::npos;
}

namespace splat_detail {

std::string shown_value(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", v);  // enough digits to tell any two floats apart
  return buf;
}

void unit_quaternion(const SplatCloud& c, std::size_t i, const std::string& path, const char* format, double q[4]) {
  double n2 = 0;
  for (int k = 0; k < 4; ++k) {
    q[k] = c.rot[i * 4 + std::size_t(k)];
    n2 += q[k] * q[k];
  }
  if (!(n2 > 0) || !std::isfinite(n2))
    throw InputError(path, "splat " + std::to_string(i) + ": rot_0..3 is " + (n2 > 0 ? "not finite" : "zero") +
                               ", not an orientation " + format + " can hold; nothing written");
  const double inv = 1 / std::sqrt(n2);
  for (int k = 0; k < 4; ++k) q[k] *= inv;
}

}  // namespace splat_detail
}  // namespace mlsdeform::files
