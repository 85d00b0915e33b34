// mlsdeform files: 3D Gaussian splat files (the 3DGS PLY layout, docs/splats.md) recognised among PLY point clouds
// and carried through the deformation: the centres are the mesh's vertices (moved by MLS); each splat's rot_*,
// scale_* and f_rest_* are transformed by the rotation (and similarity scale) or the affine matrix the deformer
// fits at its centre;
// every other property passes through as read.
#pragma once

#include "core/files/attributes.hpp"

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace mlsdeform::files {

/// Where the vertex element of a PLY file keeps its splats' properties (property indices).
struct SplatLayout {
  std::array<std::size_t, 4> rot;    ///< rot_0..rot_3 (w x y z)
  std::array<std::size_t, 3> scale;  ///< scale_0..scale_2 (log standard deviations)
  std::vector<std::size_t> f_rest;   ///< f_rest_0..f_rest_(3k-1), channel-major; empty for SH degree 0
  int sh_degree = 0;
};

/// The splat layout of `ply`'s vertex element, or none if it is no splat file: a vertex element with rot_0 is
/// one. Throws InputError naming `path` if it is one only in part (a rot_*, scale_* property missing, f_rest_*
/// not numbered 0..N-1 with N = 9, 24 or 45, or one of them neither float nor double), which transformed in
/// part or passed through would come out wrong.
std::optional<SplatLayout> splat_layout(const PlyLayout& ply, const std::string& path);

/// Writes into `out`'s vertex element the splats of `in`'s (both splat files of the same splats: `out` a copy of
/// `in`, perhaps with other properties removed, so that each frame of an animation starts from the rest pose's
/// splats) transformed by per-vertex unit quaternions (n x 4, w x y z) and, if given, similarity scales (n):
/// rotate_splats (mlsdeform/splats.hpp) on the properties gathered in double, stored back in their own types. A
/// splat whose transform is exactly the identity keeps every bit. Throws InputError naming `path` for values
/// rotate_splats refuses (NaN, a zero rot_*), naming the splat (vertex), and for a transformed value its
/// property's type cannot hold (a float f_rest_* near float's largest, rotated), naming the splat and the
/// property.
template <class T>
void transform_splats(const PlyLayout& in, PlyLayout& out, const T* quaternions, const T* scales, int threads,
                      const std::string& path);

/// The same for affine fits: each splat mapped by its centre's linear part (n x 9 row-major, FramesOut::linear)
/// through transform_splats_affine (mlsdeform/splats.hpp: covariance M Sigma M^T decomposed again, f_rest_* by
/// M's polar rotation). Throws InputError naming `path` and the splat for what it refuses (a singular M), and
/// for a value beyond its property's type as transform_splats does.
template <class T>
void transform_splats_linear(const PlyLayout& in, PlyLayout& out, const T* linear, int threads,
                             const std::string& path);

}  // namespace mlsdeform::files
