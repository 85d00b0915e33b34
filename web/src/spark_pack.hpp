// The page's splats in the layout its renderer reads, written by the module so that a drag hands the renderer
// arrays it uploads as they are (no JavaScript loop over the splats). The layout is Spark 2.2.0's PackedSplats
// (@sparkjsdev/spark, pinned by web/package-lock.json; its utils.ts setPackedSplat and encodeSh1Rgb..3Rgb):
// 16 bytes a splat (RGBA bytes; the centre as three halves; the log scales as bytes over [ln_scale_min,
// ln_scale_max]; the rotation as an octahedral axis and an angle, a byte each), and the SH bands 1-3 in
// extra arrays of 2, 4 and 4 words a splat (7, 8 and 6 signed bits a coefficient over [-max, max]). A change of
// Spark's version must be checked against these (web/tests/browser_splats.mjs decodes them with Spark's own
// unpackSplat).
#pragma once

#include <cstddef>
#include <cstdint>

namespace mlsdeform::web {

/// The ranges the bytes cover (Spark's SplatEncoding): set once per scene so that no splat is clamped.
struct SparkEncoding {
  float rgb_min = 0, rgb_max = 1;
  float ln_scale_min = -12, ln_scale_max = 9;  ///< Spark's LN_SCALE_MIN, LN_SCALE_MAX
  float sh_max[3] = {1, 1, 1};                 ///< bands 1, 2, 3
};

/// Spark's texture holds whole rows of 2048 splats (its computeMaxSplats): the arrays' length in splats.
std::size_t spark_capacity(std::size_t n);

/// Word 0 of a splat (its RGBA bytes) from 3DGS's opacity before the sigmoid and band 0 (f_dc) of each channel:
/// what no pose changes.
std::uint32_t pack_colour(float opacity, const float f_dc[3], const SparkEncoding& e);

/// Words 1-3 of a splat (`out4` its four words; word 0 kept) from its centre, its log scales and a quaternion
/// (w x y z, any length but 0).
void pack_pose(std::uint32_t* out4, const float centre[3], const float log_scale[3], const double q[4],
               const SparkEncoding& e);

/// The SH bands of one splat from 3DGS's f_rest (channel-major, k = 3, 8 or 15 per channel): band 1 into sh1 (2
/// words), band 2 into sh2 (4), band 3 into sh3 (4); a band the degree lacks is not written.
void pack_sh(const float* f_rest, int degree, const SparkEncoding& e, std::uint32_t* sh1, std::uint32_t* sh2,
             std::uint32_t* sh3);

}  // namespace mlsdeform::web
