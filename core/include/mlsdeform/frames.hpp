// mlsdeform: per-vertex frames out of the deformer, and the helpers that carry oriented data (normals,
// tangents) through them. MLS fits a transform at every vertex (a rotation R, for similarity a scale s and
// the linear part s R; the paper's eqs. (13)-(15) and Sec. 6.1); Deformer::deform can write it beside the
// positions (docs/api.md, "Frames").
#pragma once

#include <cstddef>
#include <span>

namespace mlsdeform {

/// Optional per-vertex outputs of Deformer::deform, each the caller's storage, row-major, one row per vertex
/// of the model (vertex_count()); an empty span is "not wanted". A span of another size is refused with
/// std::invalid_argument before anything is written.
///   quaternions  n x 4, (w, x, y, z): the vertex's rotation as a unit quaternion, w >= 0
///   rotations    n x 9: the rotation matrix R, row-major (R(r, c) at 9 v + 3 r + c)
///   scales       n: the similarity scale s (Transform::similarity); 1 for rigid; refused for affine
///   linear       n x 9, row-major: the transform's linear part, x -> L x: R (rigid), s R (similarity), the
///                fit's matrix M (affine: Schaefer et al.'s M = G^-1 sum_j w_j phat_j^T qhat_j in their
///                row-vector convention, transposed; not orthogonal, normals go by its inverse transpose)
/// With Options::arap_iterations > 0 the rotation is the ARAP refinement's local rotation of the result (the
/// rotation of its one-ring, as a local step computes it), the scale 1 and the linear part that rotation.
/// Outside Options::region the identity (scale 1). A vertex on a point handle (snapped: data.hpp) takes the
/// rotation (affine: the matrix) of the fit's limit at the handle with WeightStorage::precomputed (scale 1),
/// the identity with on_the_fly and precomputed_weights (docs/api.md, "Frames"). Affine, on a segment handle:
/// with exact_integral weights the zero matrix (no frame there: transform_normals then keeps the normal), with
/// paper_constant the fit to that segment alone, of rank 1.
/// Affine sessions have no rotation: quaternions, rotations and scales are refused (a rotation of M, its polar
/// factor or another, is the caller's choice). linear needs Options::affine_frames: then their table holds M's
/// coefficients too, 3 values per vertex and pseudo-handle beside alpha's 1 (the memory of a rigid session's
/// table), and linear costs a second pass over the pseudo-handles in deform (bench/bench_frames.cpp).
template <class T>
struct FramesOut {
  std::span<T> quaternions;
  std::span<T> rotations;
  std::span<T> scales;
  std::span<T> linear;

  /// Whether any output is wanted.
  bool any() const { return !quaternions.empty() || !rotations.empty() || !scales.empty() || !linear.empty(); }
};

/// Carries normals through per-vertex linear parts (FramesOut::linear, n x 9 row-major): normal i becomes
/// L_i^-T n_i, renormalised, computed as sign(det L_i) cof(L_i) n_i (cof(L) = det(L) L^-T: no division, and
/// a singular L still maps a normal onto the collapsed plane's normal). `normals` and `out` are n x 3
/// interleaved (they may be the same array). A zero normal stays zero. Where L_i maps n_i to zero or to a
/// non-finite vector (L_i of rank 1 or 0, or with non-finite entries), the input normal is kept, unit
/// length: the frame carries no orientation there. Throws std::invalid_argument (nothing written) on sizes
/// that do not match (linear 9 n, normals and out 3 n) or a non-finite normal.
template <class T>
void transform_normals(std::span<const T> linear, std::span<const T> normals, std::span<T> out);

/// Carries tangents through per-vertex linear parts: tangent i (n x 4 interleaved: x, y, z and the
/// bitangent's sign w, as glTF's TANGENT) becomes L_i t_i, renormalised; w is kept, negated where
/// det L_i < 0 (a reflection flips the frame's handedness: bitangent = w (n x t) must follow L). Where L_i t_i
/// is zero or not finite the input tangent is kept, unit length. `tangents` and `out` may be the same
/// array. Throws std::invalid_argument (nothing written) on sizes that do not match (linear 9 n, tangents
/// and out 4 n) or a non-finite tangent.
template <class T>
void transform_tangents(std::span<const T> linear, std::span<const T> tangents, std::span<T> out);

extern template void transform_normals<float>(std::span<const float>, std::span<const float>, std::span<float>);
extern template void transform_normals<double>(std::span<const double>, std::span<const double>, std::span<double>);
extern template void transform_tangents<float>(std::span<const float>, std::span<const float>, std::span<float>);
extern template void transform_tangents<double>(std::span<const double>, std::span<const double>, std::span<double>);

}  // namespace mlsdeform
