// mlsdeform files: PlayCanvas's compressed PLY (docs/splats.md "Compressed PLY"): a binary little-endian PLY
// with a `chunk` element (per 256 consecutive splats, float bounds of the centre, the log scales and, optionally,
// the colour), a `vertex` element of four uint32 per splat (centre 11-10-11 bits and log scale 11-10-11 bits
// within the chunk's bounds, the quaternion as 2 bits naming its largest component and three 10-bit others,
// colour 8-8-8 within the chunk's bounds and opacity after the sigmoid in 8 bits) and an optional `sh` element
// of uchar f_rest_* (the 3DGS names and order, (v / 8 + 0.5) * 256). Axes and quaternion order are PLY's.
#include "core/files/formats/splat_codecs.hpp"
#include "core/files/formats/splat_support.hpp"

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <limits>

namespace mlsdeform::files {

using namespace splat_detail;

namespace {

constexpr std::size_t kChunk = 256;
constexpr double kC0 = 0.28209479177387814;  // the band-0 SH constant, 1 / (2 sqrt(pi))
const std::array<const char*, 18> kChunkNames = {
    "min_x",       "min_y",       "min_z",       "max_x", "max_y", "max_z", "min_scale_x", "min_scale_y", "min_scale_z",
    "max_scale_x", "max_scale_y", "max_scale_z", "min_r", "min_g", "min_b", "max_r",       "max_g",       "max_b"};
const std::array<const char*, 4> kVertexNames = {"packed_position", "packed_rotation", "packed_scale", "packed_color"};

std::string problem(const std::string& what) { return "compressed PLY: " + what; }

struct Header {
  std::size_t chunks = 0, splats = 0, chunk_floats = 0, sh = 0, body = 0;
};

// Reads the header line by line: the layout is fixed (the names and types in this order), only comments vary.
Header parse_header(std::string_view bytes, const std::string& path) {
  const std::size_t end = bytes.find("end_header\n");
  if (bytes.substr(0, 4) != "ply\n" || end == std::string_view::npos)
    throw InputError(path, problem("no PLY header (\"ply\" ... \"end_header\")"));
  std::vector<std::string_view> lines;
  for (std::size_t at = 4; at < end;) {
    const std::size_t nl = bytes.find('\n', at);
    const std::string_view line = bytes.substr(at, nl - at);
    if (line.substr(0, 8) != "comment " && line.substr(0, 9) != "obj_info ") lines.push_back(line);
    at = nl + 1;
  }
  Header h;
  h.body = end + 11;
  std::size_t li = 0;
  auto next = [&](const std::string& expected_what) -> std::string_view {
    if (li >= lines.size()) throw InputError(path, problem("the header ends where " + expected_what + " belongs"));
    return lines[li++];
  };
  auto count = [&](std::string_view line, std::string_view prefix) {
    if (line.substr(0, prefix.size()) != prefix) return std::numeric_limits<std::size_t>::max();
    const std::string_view digits = line.substr(prefix.size());
    std::size_t v = 0;
    if (digits.empty() || digits.size() > 15)
      throw InputError(path, problem("bad count in '" + std::string(line) + "'"));
    for (const char ch : digits) {
      if (ch < '0' || ch > '9') throw InputError(path, problem("bad count in '" + std::string(line) + "'"));
      v = v * 10 + std::size_t(ch - '0');
    }
    return v;
  };
  auto property = [&](std::string_view line, std::initializer_list<std::string_view> types, const std::string& name) {
    for (const std::string_view t : types)
      if (line == "property " + std::string(t) + " " + name) return;
    throw InputError(path, problem("'" + std::string(line) + "' where 'property " + std::string(*types.begin()) + " " +
                                   name + "' belongs"));
  };
  if (next("the format") != "format binary_little_endian 1.0")
    throw InputError(path, problem("not binary_little_endian 1.0"));
  h.chunks = count(next("element chunk"), "element chunk ");
  if (h.chunks == std::numeric_limits<std::size_t>::max())
    throw InputError(path, problem("no 'element chunk' first (not a compressed PLY)"));
  for (std::size_t k = 0; k < 18; ++k) {
    const std::string_view line = next("the chunk's properties");
    if (k == 12 && line.substr(0, 8) == "element ") {
      --li;
      break;
    }
    property(line, {"float", "float32"}, kChunkNames[k]);
    h.chunk_floats = k + 1;
  }
  h.splats = count(next("element vertex"), "element vertex ");
  if (h.splats == std::numeric_limits<std::size_t>::max()) throw InputError(path, problem("no 'element vertex'"));
  for (const char* name : kVertexNames) property(next("the vertex properties"), {"uint", "uint32"}, name);
  if (li < lines.size()) {
    if (count(next("element sh"), "element sh ") != h.splats)
      throw InputError(path, problem("the 'sh' element must follow with one item per splat"));
    while (li < lines.size()) property(next("f_rest"), {"uchar", "uint8"}, indexed("f_rest_", h.sh++));
    if (sh_degree_of(h.sh) <= 0)
      throw InputError(path, problem(std::to_string(h.sh) + " f_rest_* properties (9, 24 or 45 are SH degrees 1-3)"));
  }
  if (h.splats == 0) throw InputError(path, problem("no splats"));
  if (h.chunks != (h.splats + kChunk - 1) / kChunk)
    throw InputError(path, problem(std::to_string(h.chunks) + " chunks for " + std::to_string(h.splats) +
                                   " splats (one per 256 expected)"));
  const std::size_t need = h.chunks * h.chunk_floats * 4 + h.splats * (16 + h.sh);
  if (bytes.size() - h.body != need)
    throw InputError(path, problem("the header promises " + std::to_string(need) + " bytes of data; " +
                                   std::to_string(bytes.size() - h.body) + " follow it"));
  return h;
}

double unorm(std::uint32_t v, int bits) { return double(v & ((1u << bits) - 1)) / double((1u << bits) - 1); }
float lerp(float a, float b, double t) { return float(a * (1 - t) + b * t); }
double sh_value(unsigned b) { return b == 0 ? -4 : b == 255 ? 4 : (b + 0.5) / 32 - 4; }

}  // namespace

SplatCloud decode_compressed_ply(std::string_view bytes, const std::string& path) {
  const Header h = parse_header(bytes, path);
  SplatCloud c;
  c.resize(h.splats, sh_degree_of(h.sh));
  const auto* chunk = reinterpret_cast<const unsigned char*>(bytes.data()) + h.body;
  const unsigned char* vertex = chunk + h.chunks * h.chunk_floats * 4;
  const unsigned char* sh = vertex + h.splats * 16;
  const std::size_t k = c.sh_per_channel();
  for (std::size_t j = 0; j < h.chunks * h.chunk_floats; ++j)
    if (!std::isfinite(load_f32(chunk + j * 4)))
      throw InputError(path, problem("chunk " + std::to_string(j / h.chunk_floats) + ": " +
                                     kChunkNames[j % h.chunk_floats] + " is not finite"));
  for (std::size_t i = 0; i < h.splats; ++i) {
    const unsigned char* b = chunk + (i / kChunk) * h.chunk_floats * 4;
    auto bound = [&](std::size_t j) { return load_f32(b + j * 4); };
    const std::uint32_t pp = load_u32(vertex + i * 16), pr = load_u32(vertex + i * 16 + 4),
                        ps = load_u32(vertex + i * 16 + 8), pc = load_u32(vertex + i * 16 + 12);
    const double tp[3] = {unorm(pp >> 21, 11), unorm(pp >> 11, 10), unorm(pp, 11)};
    const double ts[3] = {unorm(ps >> 21, 11), unorm(ps >> 11, 10), unorm(ps, 11)};
    for (std::size_t j = 0; j < 3; ++j) {
      c.position[i * 3 + j] = lerp(bound(j), bound(3 + j), tp[j]);
      c.scale[i * 3 + j] = lerp(bound(6 + j), bound(9 + j), ts[j]);
      const double t = unorm(pc >> (24 - 8 * j), 8);
      const double colour = h.chunk_floats == 18 ? double(lerp(bound(12 + j), bound(15 + j), t)) : t;
      c.f_dc[i * 3 + j] = float((colour - 0.5) / kC0);
    }
    c.opacity[i] = logit_of(pc & 0xff, 255);
    const int largest = int(pr >> 30);
    double q[4], sum = 0;
    for (int j = 0, shift = 20; j < 4; ++j) {
      if (j == largest) continue;
      q[j] = (unorm(pr >> shift, 10) - 0.5) * M_SQRT2;
      sum += q[j] * q[j];
      shift -= 10;
    }
    if (sum > 1)
      throw InputError(path, problem("splat " + std::to_string(i) +
                                     ": corrupt packed_rotation (its three stored "
                                     "components square to more than 1)"));
    q[largest] = std::sqrt(1 - sum);
    for (int j = 0; j < 4; ++j) c.rot[i * 4 + std::size_t(j)] = float(q[j]);
    for (std::size_t j = 0; j < 3 * k; ++j) c.f_rest[i * 3 * k + j] = float(sh_value(sh[i * 3 * k + j]));
  }
  return c;
}

std::string encode_compressed_ply(const SplatCloud& c, const std::string& path) {
  const std::size_t n = c.count, k = c.sh_per_channel(), chunks = (n + kChunk - 1) / kChunk;
  if (n == 0) throw InputError(path, problem("no splats to write"));
  std::string out = "ply\nformat binary_little_endian 1.0\nelement chunk " + std::to_string(chunks) + "\n";
  for (const char* name : kChunkNames) out += std::string("property float ") + name + "\n";
  out += "element vertex " + std::to_string(n) + "\n";
  for (const char* name : kVertexNames) out += std::string("property uint ") + name + "\n";
  if (k) {
    out += "element sh " + std::to_string(n) + "\n";
    for (std::size_t j = 0; j < 3 * k; ++j) out += "property uchar " + indexed("f_rest_", j) + "\n";
  }
  out += "end_header\n";
  const std::size_t chunk_at = out.size(), vertex_at = chunk_at + chunks * 18 * 4, sh_at = vertex_at + n * 16;
  out.resize(sh_at + n * 3 * k);
  static const char* const axis[3] = {"x", "y", "z"};
  for (std::size_t ch = 0; ch < chunks; ++ch) {
    const std::size_t b = ch * kChunk, e = std::min(n, b + kChunk);
    // The chunk's bounds: centre, log scale, colour (0.5 + C0 f_dc), each checked finite first.
    std::array<float, 18> bounds;
    for (std::size_t j = 0; j < 3; ++j) bounds[j] = bounds[6 + j] = bounds[12 + j] = INFINITY;
    for (std::size_t j = 0; j < 3; ++j) bounds[3 + j] = bounds[9 + j] = bounds[15 + j] = -INFINITY;
    std::vector<float> colour((e - b) * 3);
    for (std::size_t i = b; i < e; ++i)
      for (std::size_t j = 0; j < 3; ++j) {
        const float p = c.position[i * 3 + j], s = c.scale[i * 3 + j];
        if (!std::isfinite(p)) refuse(path, "compressed PLY", i, axis[j], p, -FLT_MAX, FLT_MAX);
        if (!(s >= -20 && s <= 20)) refuse(path, "compressed PLY", i, indexed("scale_", j), s, -20, 20);
        const float col = float(c.f_dc[i * 3 + j] * kC0 + 0.5);
        if (!std::isfinite(col))
          refuse(path, "compressed PLY", i, indexed("f_dc_", j), c.f_dc[i * 3 + j], -FLT_MAX, FLT_MAX);
        colour[(i - b) * 3 + j] = col;
        bounds[j] = std::min(bounds[j], p), bounds[3 + j] = std::max(bounds[3 + j], p);
        bounds[6 + j] = std::min(bounds[6 + j], s), bounds[9 + j] = std::max(bounds[9 + j], s);
        bounds[12 + j] = std::min(bounds[12 + j], col), bounds[15 + j] = std::max(bounds[15 + j], col);
      }
    for (std::size_t j = 0; j < 18; ++j) {
      const float f = bounds[j];
      std::memcpy(&out[chunk_at + (ch * 18 + j) * 4], &f, 4);  // little-endian hosts (as the PLY writers)
    }
    auto pack = [](double v, float lo, float hi, int bits) {
      const double t = hi > lo ? (v - lo) / (double(hi) - lo) : 0.0, top = double((1u << bits) - 1);
      return std::uint32_t(std::clamp(std::floor(t * top + 0.5), 0.0, top));
    };
    for (std::size_t i = b; i < e; ++i) {
      const float* p = &c.position[i * 3];
      const float* s = &c.scale[i * 3];
      const float* col = &colour[(i - b) * 3];
      const std::uint32_t pp = pack(p[0], bounds[0], bounds[3], 11) << 21 | pack(p[1], bounds[1], bounds[4], 10) << 11 |
                               pack(p[2], bounds[2], bounds[5], 11);
      const std::uint32_t ps = pack(s[0], bounds[6], bounds[9], 11) << 21 |
                               pack(s[1], bounds[7], bounds[10], 10) << 11 | pack(s[2], bounds[8], bounds[11], 11);
      const double o = c.opacity[i];
      if (std::isnan(o)) refuse(path, "compressed PLY", i, "opacity", o, -INFINITY, INFINITY);
      const std::uint32_t pc =
          pack(col[0], bounds[12], bounds[15], 8) << 24 | pack(col[1], bounds[13], bounds[16], 8) << 16 |
          pack(col[2], bounds[14], bounds[17], 8) << 8 | std::uint32_t(std::round(sigmoid(o) * 255));
      double q[4];
      unit_quaternion(c, i, path, "compressed PLY", q);
      int largest = 0;
      for (int j = 1; j < 4; ++j)
        if (std::fabs(q[j]) > std::fabs(q[largest])) largest = j;
      const double sign = q[largest] < 0 ? -1 : 1;
      std::uint32_t pr = std::uint32_t(largest);
      for (int j = 0; j < 4; ++j)
        if (j != largest) pr = pr << 10 | pack(sign * q[j] * M_SQRT1_2 + 0.5, 0.f, 1.f, 10);
      const std::uint32_t words[4] = {pp, pr, ps, pc};
      std::memcpy(&out[vertex_at + i * 16], words, 16);
      for (std::size_t j = 0; j < 3 * k; ++j) {
        const double v = c.f_rest[i * 3 * k + j];
        if (!(v >= -4 && v <= 4)) refuse(path, "compressed PLY", i, indexed("f_rest_", j), v, -4, 4);
        // The nearest of the decoded values (the two ends are -4 and 4 exactly, the others bucket centres).
        const int t = int(std::clamp(std::floor((v + 4) * 32), 0.0, 255.0));
        int best = t;
        for (int d = t - 1; d <= t + 1; ++d)
          if (d >= 0 && d <= 255 && std::fabs(sh_value(unsigned(d)) - v) < std::fabs(sh_value(unsigned(best)) - v))
            best = d;
        out[sh_at + i * 3 * k + j] = char(best);
      }
    }
  }
  return out;
}

}  // namespace mlsdeform::files
