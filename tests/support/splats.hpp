// Generated 3D Gaussian splats (the 3DGS layout, docs/splats.md) for the tests and the benchmark: random splats
// along a bar, and their binary little-endian PLY file with 3DGS's property order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace mlsdeform::testing {

/// n splats as 3DGS stores them, each array row-major (one splat after the other).
struct SplatCloud {
  std::size_t n = 0;
  int sh_degree = 3;
  std::vector<float> positions;   // n x 3: x y z
  std::vector<float> normals;     // n x 3: nx ny nz (3DGS writes zeros)
  std::vector<float> f_dc;        // n x 3
  std::vector<float> f_rest;      // n x 3 x k, channel-major, k = (sh_degree + 1)^2 - 1
  std::vector<float> opacity;     // n
  std::vector<float> log_scales;  // n x 3: scale_0..2
  std::vector<float> rotations;   // n x 4: rot_0..3 = w x y z, unnormalised as 3DGS leaves them
};

/// n random splats in the box [-w, w] x [-w, w] x [0, length] (a bar along z, to bend), w = length / 10:
/// log scales around log(length / 100), quaternions of length 0.5 to 2, SH coefficients of a trained scene's
/// magnitude (f_dc ~ 1, f_rest ~ 0.1). The same seed gives the same splats on every platform (SplitMix64).
SplatCloud random_splat_cloud(std::size_t n, std::uint64_t seed, int sh_degree = 3, float length = 2);

/// The PLY header of a splat file: binary_little_endian 1.0, one element vertex of float properties in 3DGS's
/// order: x y z nx ny nz f_dc_0..2 f_rest_0..(3 k - 1) opacity scale_0..2 rot_0..3.
std::string splat_ply_header(std::size_t n, int sh_degree);

/// The whole file's bytes (header and records).
std::vector<char> splat_ply_bytes(const SplatCloud& cloud);

/// Writes splat_ply_bytes to `path`; throws std::runtime_error if it cannot.
void write_splat_ply(const std::string& path, const SplatCloud& cloud);

/// The benchmarks' handles file (the program's format) for a bar along z from 0 to 2: 16 point handles, those at
/// z = 0 and 0.1 staying, those at z = 1.9 and 2 turned 60 degrees about x around (0, 0, 1.5).
std::string bent_bar_handles();

}  // namespace mlsdeform::testing
