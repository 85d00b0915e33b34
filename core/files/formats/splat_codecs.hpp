// mlsdeform files: the compact splat formats people capture and view with (docs/splats.md, "Other formats"):
// Niantic's SPZ, PlayCanvas's compressed PLY and the antimatter15 `.splat` layout, decoded into and encoded
// from the 3DGS conventions the pipeline works in (log scales, logit opacity, quaternion w x y z, SH bands 1-3
// channel-major, PLY's axes). Every quantisation's error bound is derived in docs/splats.md; the tests hold
// both directions against an independent converter (tests/splat_judge). Strict: a truncated, corrupt or
// oversized input is refused with InputError naming the file, and so is a splat a format cannot hold (a value
// out of its range, an SH degree it lacks), naming the splat and the property; nothing is clamped silently.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace mlsdeform::files {

/// Splats in the 3DGS PLY conventions, one array per property, splat after splat.
struct SplatCloud {
  std::size_t count = 0;
  int sh_degree = 0;            ///< 0..3
  std::vector<float> position;  ///< n x 3, x y z in PLY's axes (3DGS: right, down, forward)
  std::vector<float> f_dc;      ///< n x 3, band 0 of the colour's SH, R G B
  std::vector<float> f_rest;    ///< n x 3k, f_rest_0..f_rest_(3k-1): channel-major, k = (degree+1)^2 - 1
  std::vector<float> opacity;   ///< n, before the sigmoid (+-infinity: alpha exactly 1 or 0)
  std::vector<float> scale;     ///< n x 3, natural logarithms of the standard deviations
  std::vector<float> rot;       ///< n x 4, w x y z
  bool antialiased = false;     ///< SPZ's flag (trained with mip-splatting's filter), kept for an SPZ output

  /// SH coefficients per colour channel beyond band 0: 0, 3, 8 or 15.
  std::size_t sh_per_channel() const { return std::size_t((sh_degree + 1) * (sh_degree + 1) - 1); }
  void resize(std::size_t n, int degree);
};

/// The SH degree that `coefficients` f_rest_* values make (0, 9, 24 or 45), or -1.
int sh_degree_of(std::size_t coefficients);

/// Which compact format a file name asks for: ".spz", ".splat", ".compressed.ply" (any case), else none.
enum class SplatFormat { none, spz, splat, compressed_ply };
SplatFormat splat_format(std::string_view path);
/// "SPZ", ".splat", "compressed PLY" for messages.
const char* splat_format_name(SplatFormat f);
/// Whether `bytes` start like a compressed PLY (a PLY header declaring a `chunk` element and a
/// `packed_position` property), so that one named plainly `.ply` can be read as what it is.
bool looks_like_compressed_ply(std::string_view bytes);

/// SPZ (nianticlabs/spz): versions 2 and 3 (gzip, or without their gzip layer) and 4 (zstd streams; refused,
/// saying so, by a build without zstd). Axes converted from SPZ's right-up-back to PLY's right-down-forward (y and z
/// negated, the quaternion and SH turned with them), as splat-transform and Niantic's library do. `max_bytes` bounds
/// the decompressed size, checked before anything is allocated for it.
SplatCloud decode_spz(std::string_view bytes, const std::string& path, std::size_t max_bytes);
/// SPZ version 4 (zstd streams) where the build has zstd, else version 3 (gzip): 24-bit positions with 12
/// fractional bits, 8-bit everything else, SH at the full 8 bits (no coarser buckets). Refuses, naming the
/// splat, values outside the format's ranges.
std::string encode_spz(const SplatCloud& cloud, const std::string& path);
/// SPZ version 3 before its gzip layer (the 16-byte header and the arrays): what a caller with its own gzip
/// (the web page) compresses into a version 3 file. decode_spz reads these bytes too.
std::string encode_spz_payload(const SplatCloud& cloud, const std::string& path);

/// PlayCanvas's compressed PLY: chunks of 256 splats with their bounds, each splat in 4 packed uint32,
/// the SH bands in an `sh` element of uchar. Read as written (the order kept).
SplatCloud decode_compressed_ply(std::string_view bytes, const std::string& path);
/// Written in the file's splat order (chunk bounds per 256 consecutive splats, colour bounds included).
std::string encode_compressed_ply(const SplatCloud& cloud, const std::string& path);

/// The antimatter15 `.splat` layout: 32 bytes a splat (float centre, float linear scales, RGBA bytes,
/// quaternion bytes w x y z), SH degree 0. Read only.
SplatCloud decode_splat(std::string_view bytes, const std::string& path);

}  // namespace mlsdeform::files
