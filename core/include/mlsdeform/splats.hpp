// mlsdeform: 3D Gaussian splats carried through a deformation (core/src/splats/). A splat of the 3DGS layout
// (docs/splats.md) is a centre, a covariance Sigma = R S S^T R^T (R from the quaternion rot_0..3 = w x y z,
// S = diag(exp(scale_0..2))) and view-dependent colour as real spherical harmonics (f_dc_*, band 0, and f_rest_*,
// bands 1-3). The deformer moves the centres; these functions move the rest by each splat's local transform:
// the rotation (and similarity scale) or the affine linear part that MLS computed at its centre.
#pragma once

#include <cstddef>

namespace mlsdeform {

/// The per-splat arrays of n splats, updated in place; a null array is not touched. Every array is row-major,
/// one splat after the other (numpy's C-contiguous (n, k) arrays, the PLY's property columns gathered).
template <class T>
struct SplatArrays {
  /// n x 4: rot_0..rot_3 = w x y z. Any nonzero length (3DGS stores them unnormalised); written normalised.
  T* rotations = nullptr;
  /// n x 3: scale_0..scale_2, the natural logarithms of the standard deviations along the splat's axes.
  T* log_scales = nullptr;
  /// n x 3 x k: f_rest_*, channel-major as 3DGS writes them (the k coefficients of R, then G, then B), with
  /// k = (sh_degree + 1)^2 - 1 (3, 8 or 15); the basis is 3DGS's (docs/splats.md), m = -l..l within a band.
  T* sh_rest = nullptr;
  /// 0 (no f_rest_*), 1, 2 or 3.
  int sh_degree = 0;
};

/// The number of f_rest_* values per splat for an SH degree: 3 ((degree + 1)^2 - 1), or 0 for degree 0.
/// Throws std::invalid_argument for a degree outside 0..3.
int splat_sh_rest_count(int sh_degree);

/// The SH degree (0..3) whose f_rest_* count is `count` (0, 9, 24 or 45), or -1 if no degree has it.
int splat_sh_degree_of(int count);

/// Rigid or similarity motion of n splats: splat i turns by the unit quaternion quaternions[4 i .. 4 i + 3]
/// (w x y z) and, if `scales` is given, grows by scales[i] > 0 about its centre.
/// - rotations: q' = normalise(q_R * q) (the Hamilton product; R Sigma R^T is then the new covariance),
/// - log_scales: + log(s) on each axis (s^2 Sigma),
/// - sh_rest: bands 1-3 rotated so that the colour seen from direction R d is the colour formerly seen from d.
/// A splat whose transform is exactly the identity (q_R = (+-1, 0, 0, 0), s = 1) keeps every bit, its
/// unnormalised quaternion included. Each splat's result depends on its inputs alone (bitwise the same for any
/// `threads`: 1 the calling thread, 0 all cores). Throws std::invalid_argument, having written nothing, naming
/// the splat and the array: a NaN or infinite value anywhere, a transform quaternion whose length is not 1 to
/// within sqrt(epsilon) (a raw or wrongly ordered array, not rounding), a scale <= 0, a zero splat quaternion,
/// a bad sh_degree, a null `quaternions` with n > 0. Allocates nothing.
template <class T>
void rotate_splats(const SplatArrays<T>& splats, std::size_t n, const T* quaternions, const T* scales = nullptr,
                   int threads = 1);

/// Affine motion of n splats: splat i is mapped by the row-major 3 x 3 linear part linear[9 i .. 9 i + 8] (M).
/// - Sigma' = M Sigma M^T, decomposed again (symmetric eigenproblem): log_scales = log(sqrt(eigenvalues)) and
///   rotations = the eigenvectors' quaternion, normalised; the eigenvectors are matched to the images M R e_k of
///   the old axes (so scale_k stays the axis it was for a mild M) and signed to keep a right-handed frame
///   (det +1). rotations and log_scales are both needed (both or neither given).
/// - sh_rest: rotated by the polar rotation of M (its nearest rotation, the shear and stretch set aside); a
///   reflecting M (det < 0) rotates by -Q and mirrors (odd bands change sign), Q the orthogonal polar factor.
/// A splat whose M is exactly the identity keeps every bit. Throws std::invalid_argument, having written
/// nothing, as rotate_splats does, and for a singular M (det 0). Allocates nothing.
template <class T>
void transform_splats_affine(const SplatArrays<T>& splats, std::size_t n, const T* linear, int threads = 1);

extern template void rotate_splats<float>(const SplatArrays<float>&, std::size_t, const float*, const float*, int);
extern template void rotate_splats<double>(const SplatArrays<double>&, std::size_t, const double*, const double*, int);
extern template void transform_splats_affine<float>(const SplatArrays<float>&, std::size_t, const float*, int);
extern template void transform_splats_affine<double>(const SplatArrays<double>&, std::size_t, const double*, int);

}  // namespace mlsdeform
