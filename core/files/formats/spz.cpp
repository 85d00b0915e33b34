// mlsdeform files: SPZ (nianticlabs/spz, docs/splats.md "SPZ"). Versions 2-3: one gzip stream holding a
// 16-byte header and six arrays; version 4: a 32-byte plain header, a table of contents and one zstd frame per
// array. The arrays, splat after splat: positions (3 x 24-bit fixed point), alphas (sigmoid, 8 bits), colours
// (band 0 as 0.15 * 255 f + 127.5, 8 bits), scales ((log + 10) * 16, 8 bits), rotations (version 2: x y z at 8
// bits; 3-4: the smallest three of x y z w at 9 bits and a sign, the largest's index in 2 bits), SH (bands
// 1-3, coefficient-major with the channel inner, (x * 128 + 128) at 8 bits). Axes: right, up, back.
#include "core/files/formats/splat_codecs.hpp"
#include "core/files/formats/splat_support.hpp"

#ifndef MLSDEFORM_NO_ZLIB  // the web page's module has no zlib (it decompresses gzip itself)
#include <zlib.h>
#endif
#if MLSDEFORM_HAVE_ZSTD
#include <zstd.h>
#endif

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

namespace mlsdeform::files {

using namespace splat_detail;

namespace {

constexpr std::uint32_t kMagic = 0x5053474e;  // "NGSP"
constexpr double kColourScale = 0.15;
constexpr int kFractionalBits = 12;
// What encode_spz writes: version 4 (zstd, level 3: zstd's default, fast at a ratio near gzip's best) where the
// build has zstd, else version 3 (gzip). Both are what splat-transform and Niantic's library read.
#if MLSDEFORM_HAVE_ZSTD
constexpr int kZstdLevel = 3;
#elif !defined(MLSDEFORM_NO_ZLIB)
constexpr int kGzipLevel = 6;
#endif

// SPZ keeps right-up-back axes, 3DGS PLY right-down-forward: the two differ by the half turn F = diag(1, -1, -1)
// about x. A position's y and z change sign, a quaternion (w, x, y, z) becomes (w, x, -y, -z) (F q F), and an
// SH basis function, a polynomial in x y z, changes sign with its parity in y and z (3DGS's order within each
// band, m = -l..l: y z x | xy yz (3z^2-r^2) xz (x^2-y^2) | y(3x^2-y^2) xyz y(5z^2-r^2) z(5z^2-3r^2) x(5z^2-r^2)
// z(x^2-y^2) x(x^2-3y^2)). F is its own inverse: the same signs read and write.
constexpr std::array<float, 15> kShFlip = {-1, -1, 1, -1, 1, 1, -1, 1, -1, 1, -1, -1, 1, -1, 1};

struct Arrays {
  std::size_t rotation_bytes = 4, sh_values = 0;
  std::array<std::size_t, 6> sizes{};  // positions, alphas, colours, scales, rotations, sh
};

Arrays arrays_for(std::uint64_t n, int version, int degree) {
  Arrays a;
  a.rotation_bytes = version >= 3 ? 4 : 3;
  a.sh_values = std::size_t((degree + 1) * (degree + 1) - 1) * 3;
  a.sizes = {std::size_t(n * 9),
             std::size_t(n),
             std::size_t(n * 3),
             std::size_t(n * 3),
             std::size_t(n * a.rotation_bytes),
             std::size_t(n * a.sh_values)};
  return a;
}

std::string problem(const std::string& what) { return "SPZ: " + what; }

void check_header(const std::string& path, std::uint32_t version, std::uint64_t n, int degree, int bits,
                  std::uint8_t flags, std::size_t max_bytes) {
  if (version == 1) throw InputError(path, problem("version 1 (half-float positions, never released) is not read"));
  if (n == 0) throw InputError(path, problem("no splats (the header's count is 0)"));
  if (degree > 3)
    throw InputError(
        path, problem("SH degree " + std::to_string(degree) + ": the 3DGS layout holds degrees 0 to 3; nothing read"));
  if (bits > 23) throw InputError(path, problem(std::to_string(bits) + " fractional bits (at most 23 are read)"));
  if (flags & 0x2)
    throw InputError(path, problem("the file carries extension records (flag 0x2), which are not read (one may "
                                   "name other axes)"));
  if (flags & ~0x3u) throw InputError(path, problem("unknown flags " + std::to_string(flags)));
  // The floats the splats take once decoded (the 3DGS PLY's size), against the input limit.
  const std::uint64_t decoded = n * (14 + std::uint64_t((degree + 1) * (degree + 1) - 1) * 3) * 4;
  if (decoded > max_bytes)
    throw InputError(path, problem(std::to_string(n) + " splats would take " + std::to_string(decoded) +
                                   " bytes decoded, more than the input limit of " + std::to_string(max_bytes)));
}

// Fills the cloud from the six arrays (`s[k]` points at array k), converting to 3DGS conventions and axes.
SplatCloud unpack(const std::array<const unsigned char*, 6>& s, std::size_t n, int version, int degree, int bits,
                  const std::string& path) {
  SplatCloud c;
  c.resize(n, degree);
  const std::size_t k = c.sh_per_channel();
  const double unit = std::ldexp(1.0, -bits);
  for (std::size_t i = 0; i < n; ++i) {
    for (int j = 0; j < 3; ++j) {
      const unsigned char* p = s[0] + i * 9 + std::size_t(j) * 3;
      std::int32_t v = std::int32_t(p[0] | p[1] << 8 | p[2] << 16);
      if (v & 0x800000) v -= 0x1000000;  // sign of the 24-bit value
      c.position[i * 3 + std::size_t(j)] = float(v * unit) * (j == 0 ? 1.f : -1.f);
      c.scale[i * 3 + std::size_t(j)] = float(s[3][i * 3 + std::size_t(j)] / 16.0 - 10.0);
      c.f_dc[i * 3 + std::size_t(j)] = float((s[2][i * 3 + std::size_t(j)] / 255.0 - 0.5) / kColourScale);
    }
    c.opacity[i] = logit_of(s[1][i], 255);
    double q[4];  // x y z w, as SPZ orders them
    if (version >= 3) {
      std::uint32_t comp = load_u32(s[4] + i * 4);
      const int largest = int(comp >> 30);
      double sum = 0;
      for (int j = 3; j >= 0; --j) {
        if (j == largest) continue;
        const double mag = M_SQRT1_2 * double(comp & 511u) / 511.0;
        q[j] = (comp >> 9 & 1u) ? -mag : mag;
        sum += q[j] * q[j];
        comp >>= 10;
      }
      // The three stored are at most the largest in size, so their squares sum to at most 3/4 (plus rounding).
      if (sum > 1)
        throw InputError(path, problem("splat " + std::to_string(i) +
                                       ": corrupt rotation (its three stored "
                                       "components square to more than 1)"));
      q[largest] = std::sqrt(1 - sum);
    } else {
      double sum = 0;
      for (int j = 0; j < 3; ++j) {
        q[j] = s[4][i * 3 + std::size_t(j)] / 127.5 - 1;
        sum += q[j] * q[j];
      }
      q[3] = std::sqrt(std::max(0.0, 1 - sum));
    }
    float* r = &c.rot[i * 4];
    r[0] = float(q[3]), r[1] = float(q[0]), r[2] = float(-q[1]), r[3] = float(-q[2]);
    for (std::size_t ch = 0; ch < 3; ++ch)
      for (std::size_t j = 0; j < k; ++j)
        c.f_rest[i * 3 * k + ch * k + j] = float((s[5][i * 3 * k + j * 3 + ch] - 128.0) / 128.0) * kShFlip[j];
  }
  return c;
}

// Versions 1-3 without their gzip layer: the 16-byte header and the arrays.
SplatCloud decode_legacy_payload(std::string_view data, const std::string& path, std::size_t max_bytes) {
  if (data.size() < 16) throw InputError(path, problem("the decompressed data ends inside the 16-byte header"));
  const auto* p = reinterpret_cast<const unsigned char*>(data.data());
  if (load_u32(p) != kMagic) throw InputError(path, problem("no 'NGSP' magic at the start of the gzip data"));
  const std::uint32_t version = load_u32(p + 4), n = load_u32(p + 8);
  if (version < 1 || version > 3)
    throw InputError(path, problem("version " + std::to_string(version) + " inside gzip data (2 and 3 are read)"));
  check_header(path, version, n, p[12], p[13], p[14], max_bytes);
  const Arrays a = arrays_for(n, int(version), p[12]);
  std::uint64_t total = 16;
  for (std::size_t sz : a.sizes) total += sz;
  if (data.size() != total)
    throw InputError(
        path, problem(std::to_string(n) + " splats of degree " + std::to_string(p[12]) + " take " +
                      std::to_string(total) + " bytes; the decompressed data has " + std::to_string(data.size())));
  std::array<const unsigned char*, 6> s{};
  const unsigned char* at = p + 16;
  for (std::size_t j = 0; j < 6; ++j) s[j] = at, at += a.sizes[j];
  SplatCloud c = unpack(s, n, int(version), p[12], p[13], path);
  c.antialiased = p[14] & 1;
  return c;
}

SplatCloud decode_legacy(std::string_view bytes, const std::string& path, std::size_t max_bytes) {
#ifndef MLSDEFORM_NO_ZLIB
  return decode_legacy_payload(gunzip(bytes, path, max_bytes), path, max_bytes);
#else
  (void)bytes, (void)max_bytes;
  throw InputError(path, problem("versions 2-3 are gzip data, which this build does not decompress (the same "
                                 "bytes without their gzip layer are read)"));
#endif
}

SplatCloud decode_ngsp(std::string_view bytes, const std::string& path, std::size_t max_bytes) {
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  if (bytes.size() < 32) throw InputError(path, problem("the file ends inside the 32-byte header"));
  const std::uint32_t version = load_u32(p + 4), n = load_u32(p + 8), toc = load_u32(p + 16);
  if (version != 4)
    throw InputError(path, problem("version " + std::to_string(version) + " with a plain header (4 is read)"));
  check_header(path, version, n, p[12], p[13], p[14], max_bytes);
  for (int j = 20; j < 32; ++j)
    if (p[j] != 0) throw InputError(path, problem("reserved header bytes are not zero (a newer layout?)"));
#if !MLSDEFORM_HAVE_ZSTD
  (void)toc;
  throw InputError(path, problem("version 4 is zstd-compressed, and this build has no zstd (version 2-3 files, "
                                 "gzip, are read)"));
#else
  const Arrays a = arrays_for(n, 4, p[12]);
  const std::size_t streams = a.sizes[5] ? 6 : 5;  // empty arrays have no stream
  if (p[15] != streams)
    throw InputError(path, problem(std::to_string(p[15]) + " streams; degree " + std::to_string(p[12]) + " needs " +
                                   std::to_string(streams)));
  if (toc != 32) throw InputError(path, problem("the table of contents is not at byte 32"));
  if (bytes.size() < 32 + streams * 16) throw InputError(path, problem("the file ends inside the table of contents"));
  std::vector<std::vector<unsigned char> > out(streams);
  std::uint64_t at = 32 + streams * 16;
  for (std::size_t j = 0; j < streams; ++j) {
    const std::uint64_t packed = load_u64(p + 32 + j * 16), size = load_u64(p + 40 + j * 16);
    if (size != a.sizes[j])
      throw InputError(path, problem("stream " + std::to_string(j) + " holds " + std::to_string(size) + " bytes; " +
                                     std::to_string(n) + " splats need " + std::to_string(a.sizes[j])));
    if (packed > bytes.size() - at)
      throw InputError(path, problem("stream " + std::to_string(j) + " runs past the end of the file"));
    const void* src = p + at;
    if (ZSTD_findFrameCompressedSize(src, packed) != packed)
      throw InputError(path, problem("stream " + std::to_string(j) + " is not one whole zstd frame"));
    out[j].resize(a.sizes[j]);
    const std::size_t got = ZSTD_decompress(out[j].data(), out[j].size(), src, packed);
    if (ZSTD_isError(got) || got != a.sizes[j])
      throw InputError(path, problem("stream " + std::to_string(j) + ": corrupt zstd data" +
                                     (ZSTD_isError(got) ? std::string(" (") + ZSTD_getErrorName(got) + ")" : "")));
    at += packed;
  }
  if (at != bytes.size())
    throw InputError(path, problem(std::to_string(bytes.size() - at) + " bytes follow the last stream"));
  std::array<const unsigned char*, 6> s{};
  for (std::size_t j = 0; j < 6; ++j) s[j] = j < streams ? out[j].data() : nullptr;
  SplatCloud c = unpack(s, n, 4, p[12], p[13], path);
  c.antialiased = p[14] & 1;
  return c;
#endif
}

#if !MLSDEFORM_HAVE_ZSTD && !defined(MLSDEFORM_NO_ZLIB)
std::string gzip_level(std::string_view data, int level) {
  z_stream zs{};
  if (deflateInit2(&zs, level, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)  // 16: a gzip header
    throw std::runtime_error("zlib: deflateInit2 failed");
  std::string out(deflateBound(&zs, uLong(data.size())), '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  zs.avail_in = uInt(data.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = uInt(out.size());
  const int ret = deflate(&zs, Z_FINISH);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  if (ret != Z_STREAM_END) throw std::runtime_error("zlib: deflate did not finish");
  return out;
}
#endif

}  // namespace

SplatCloud decode_spz(std::string_view bytes, const std::string& path, std::size_t max_bytes) {
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  if (bytes.size() >= 8 && load_u32(p) == kMagic && load_u32(p + 4) <= 3)  // a legacy file with its gzip removed
    return decode_legacy_payload(bytes, path, max_bytes);
  if (bytes.size() >= 4 && load_u32(p) == kMagic) return decode_ngsp(bytes, path, max_bytes);
  if (bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == 0x1f && static_cast<unsigned char>(bytes[1]) == 0x8b)
    return decode_legacy(bytes, path, max_bytes);
  throw InputError(path, problem(bytes.empty() ? "empty file"
                                               : "neither 'NGSP' (version 4) nor gzip data (versions "
                                                 "2-3) at the start"));
}

namespace {

// The legacy header and the six arrays of `version` (3 or 4: the arrays are the same), uncompressed.
std::string pack(const SplatCloud& c, const std::string& path, std::uint32_t version) {
  const std::size_t n = c.count, k = c.sh_per_channel();
  if (n == 0) throw InputError(path, problem("no splats to write"));
  if (n > 0xffffffffu) throw InputError(path, problem("more splats than SPZ's 32-bit count holds"));
  const Arrays a = arrays_for(n, int(version), c.sh_degree);
  // The legacy header first (version 3 is gzip of header and arrays); version 4 writes its own header.
  std::string raw;
  store_u32(raw, kMagic);
  store_u32(raw, version);
  store_u32(raw, std::uint32_t(n));
  raw += char(c.sh_degree), raw += char(kFractionalBits), raw += char(c.antialiased ? 1 : 0), raw += '\0';
  const std::size_t base = raw.size();
  raw.resize(base + a.sizes[0] + a.sizes[1] + a.sizes[2] + a.sizes[3] + a.sizes[4] + a.sizes[5]);
  auto* pos = reinterpret_cast<unsigned char*>(raw.data()) + base;
  unsigned char *alpha = pos + a.sizes[0], *col = alpha + a.sizes[1], *scl = col + a.sizes[2], *rot = scl + a.sizes[3],
                *sh = rot + a.sizes[4];
  // Each quantity rounded to the nearest step; one outside the steps' range is refused, never clamped.
  static const char* const axis[3] = {"x", "y", "z"};
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < 3; ++j) {
      const double p = c.position[i * 3 + j], u = std::round(std::ldexp(j == 0 ? p : -p, kFractionalBits));
      if (!(u >= -(1 << 23) && u <= (1 << 23) - 1)) refuse(path, "SPZ", i, axis[j], p, -2048, 2047.9997);
      const auto v = std::int32_t(u);
      unsigned char* at = pos + i * 9 + j * 3;
      at[0] = std::uint8_t(v), at[1] = std::uint8_t(v >> 8), at[2] = std::uint8_t(v >> 16);
      const double s = c.scale[i * 3 + j], us = std::round((s + 10) * 16);
      if (!(us >= 0 && us <= 255)) refuse(path, "SPZ", i, indexed("scale_", j), s, -10.03125, 5.96875);
      scl[i * 3 + j] = std::uint8_t(us);
      const double f = c.f_dc[i * 3 + j], uf = std::round(f * kColourScale * 255 + 127.5);
      if (!(uf >= 0 && uf <= 255)) refuse(path, "SPZ", i, indexed("f_dc_", j), f, -3.3464, 3.3464);
      col[i * 3 + j] = std::uint8_t(uf);
    }
    const double o = c.opacity[i];
    if (std::isnan(o)) refuse(path, "SPZ", i, "opacity", o, -INFINITY, INFINITY);
    alpha[i] = std::uint8_t(std::round(sigmoid(o) * 255));
    double q[4];  // w x y z, unit
    unit_quaternion(c, i, path, "SPZ", q);
    const double x[4] = {q[1], -q[2], -q[3], q[0]};  // SPZ's x y z w in its axes
    int largest = 0;
    for (int j = 1; j < 4; ++j)
      if (std::fabs(x[j]) > std::fabs(x[largest])) largest = j;
    const bool negate = x[largest] < 0;
    std::uint32_t comp = std::uint32_t(largest);
    for (int j = 0; j < 4; ++j) {
      if (j == largest) continue;
      const auto mag = std::uint32_t(std::min(511.0, std::round(511 * std::fabs(x[j]) / M_SQRT1_2)));
      comp = comp << 10 | std::uint32_t((x[j] < 0) != negate) << 9 | mag;
    }
    for (int b = 0; b < 4; ++b) rot[i * 4 + std::size_t(b)] = std::uint8_t(comp >> (8 * b));
    for (std::size_t ch = 0; ch < 3; ++ch)
      for (std::size_t j = 0; j < k; ++j) {
        const double v = c.f_rest[i * 3 * k + ch * k + j] * kShFlip[j], u = std::round(v * 128);
        if (!(u >= -128 && u <= 127))
          refuse(path, "SPZ", i, indexed("f_rest_", ch * k + j), c.f_rest[i * 3 * k + ch * k + j], -1.0039, 0.9960);
        sh[i * 3 * k + j * 3 + ch] = std::uint8_t(u + 128);
      }
  }
  return raw;
}

}  // namespace

std::string encode_spz_payload(const SplatCloud& cloud, const std::string& path) { return pack(cloud, path, 3); }

std::string encode_spz(const SplatCloud& cloud, const std::string& path) {
#if MLSDEFORM_HAVE_ZSTD
  const std::string raw = pack(cloud, path, 4);
  const Arrays a = arrays_for(cloud.count, 4, cloud.sh_degree);
  // Version 4: the 32-byte header (the legacy one, then the stream count, the table's offset and 12 zero
  // bytes), a table of (compressed, uncompressed) sizes, one zstd frame per non-empty array.
  std::string out = raw.substr(0, 15);
  const std::size_t streams = a.sizes[5] ? 6 : 5;
  out += char(streams);
  store_u32(out, 32);
  out.append(12, '\0');
  std::vector<std::string> packed(streams);
  const char* at = raw.data() + 16;
  for (std::size_t j = 0; j < streams; ++j) {
    packed[j].resize(ZSTD_compressBound(a.sizes[j]));
    const std::size_t got = ZSTD_compress(packed[j].data(), packed[j].size(), at, a.sizes[j], kZstdLevel);
    if (ZSTD_isError(got)) throw std::runtime_error(std::string("zstd: ") + ZSTD_getErrorName(got));
    packed[j].resize(got);
    at += a.sizes[j];
    store_u64(out, got);
    store_u64(out, a.sizes[j]);
  }
  for (const auto& p : packed) out += p;
  return out;
#elif !defined(MLSDEFORM_NO_ZLIB)
  return gzip_level(pack(cloud, path, 3), kGzipLevel);
#else
  (void)cloud;
  throw InputError(path, problem("this build has neither zstd nor zlib to compress SPZ with (encode_spz_payload "
                                 "gives version 3's bytes to gzip)"));
#endif
}

}  // namespace mlsdeform::files
