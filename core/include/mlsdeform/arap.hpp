// mlsdeform: surface ARAP refinement (Sorkine & Alexa 2007) started from the MLS result. MLS gives every
// vertex the best transform for the handles; a few local/global ARAP iterations over the mesh's one-rings
// then make the surface locally rigid where few handles leave MLS too smooth (an arm bent by a hand handle).
#pragma once

#include <mlsdeform/cancel.hpp>
#include <mlsdeform/types.hpp>

#include <Eigen/Core>

#include <cstddef>
#include <memory>
#include <span>

namespace mlsdeform {

/// Triangles: m x 3 zero-based vertex indices. Polygons are triangulated by the caller (the command-line
/// program fans them).
using Triangles = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// The global step's sparse factorisation, done once per session (docs/api.md, "ARAP refinement").
enum class ArapFactorisation {
  automatic,       ///< supernodal where this build has it, else supernodal_mit
  simplicial,      ///< Eigen's SimplicialLDLT, AMD ordering: every build
  supernodal,      ///< CHOLMOD's supernodal Cholesky (GPL-2+): builds with MLSDEFORM_CHOLMOD=ON only
  supernodal_mit,  ///< the library's own supernodal Cholesky over Eigen's dense blocks (MIT): every build
};

/// Whether this build has ArapFactorisation::supernodal (the CMake option MLSDEFORM_CHOLMOD).
bool supernodal_factorisation_available();

/// How the local/global iterations are driven (docs/api.md, "ARAP refinement").
enum class ArapAcceleration {
  none,      ///< the plain local/global iteration (Sorkine & Alexa 2007)
  anderson,  ///< Anderson acceleration with an energy safeguard (Peng et al. 2018): the same fixed point, the
             ///< energy non-increasing, fewer iterations to a given energy; one more local step per refine()
};

struct ArapOptions {
  /// Worker threads for the local step and the substitution; 0 means all cores. The result is bitwise the
  /// same for any value.
  int threads = 0;
  ArapFactorisation factorisation = ArapFactorisation::automatic;
  ArapAcceleration acceleration = ArapAcceleration::none;
  /// Anderson acceleration's window m (the pairs of past iterates it extrapolates from), 1 .. 8. Its history
  /// holds 2 m + 3 copies of the positions in double, allocated with the session.
  int anderson_window = 5;
};

/// A refinement session over a triangle mesh at rest: the constructor builds the cotangent weights and
/// factorises the global step's system once, with the `constrained` vertices fixed; refine() runs the
/// iterations. Energy (column vectors, p the rest and x the current positions, N(i) the one-ring of i):
///   E(x) = sum_i sum_{j in N(i)} w_ij |(x_i - x_j) - R_i (p_i - p_j)|^2,
/// local step: R_i = argmax trace(R^T S_i), S_i = sum_j w_ij (x_i - x_j)(p_i - p_j)^T, all n fits in one
/// fit_rotations call (SIMD lanes); global step: L x = b with the cotangent Laplacian L and
/// b_i = sum_j (w_ij / 2)(R_i + R_j)(p_i - p_j), by a sparse Cholesky factorisation in double
/// (ArapOptions::factorisation). Weights: w_ij = (cot alpha_ij + cot beta_ij) / 2 clamped below at zero (negative
/// cotangents, from obtuse angles, make the energy indefinite) plus 1e-6 of the mean weight on every edge, so that a
/// sliver or a clamped edge never disconnects a vertex; degenerate triangles (zero area) contribute nothing.
/// Vertices in a connected component with no constrained vertex keep their start position.
/// Scale: the session works in frames scaled by powers of two to the rest pose and to the positions
/// (arap_refiner.cpp), so any input scale works, and scaling rest, start and targets by 2^k scales the result
/// by 2^k bitwise (only a result in T's subnormal range is rounded once more).
template <class T>
class ArapRefiner {
 public:
  /// Throws std::invalid_argument on a face index out of range, a non-finite vertex, a constrained index
  /// out of range or repeated, or ArapFactorisation::supernodal in a build without it.
  ArapRefiner(const Points<T>& rest_vertices, const Triangles& triangles, std::span<const Eigen::Index> constrained,
              const ArapOptions& options = {});
  ~ArapRefiner();
  ArapRefiner(ArapRefiner&&) noexcept;
  ArapRefiner& operator=(ArapRefiner&&) noexcept;

  /// `iterations` local/global steps from `start` (n x 3, e.g. the MLS result), with constrained vertex
  /// constrained[k] held at targets.row(k). Writes `out` (resized only if its size is wrong; it may be `start`
  /// itself); allocates nothing once `out` has its size. Not for concurrent calls (the session holds the
  /// scratch). iterations = 0 copies `start` with the constraints applied. Throws std::invalid_argument on
  /// sizes that do not match or non-finite input, and, leaving `out` unchanged, when a refined position
  /// overflows T. Any iteration count is allowed, each one costs the same: `cancel` (cancel.hpp) is checked
  /// before every iteration and throws Cancelled with `out` untouched.
  void refine(const Points<T>& start, const Points<T>& targets, int iterations, Points<T>& out,
              const CancelCheck& cancel = {});
  /// refine() with start and targets given as the positions times 2^-exponent (exact powers of two: a caller
  /// that holds them in a scaled frame, as the Deformer does, passes them without rounding them to its units
  /// first); `out` is in the caller's units.
  void refine_scaled(const Points<T>& start, const Points<T>& targets, int exponent, int iterations, Points<T>& out,
                     const CancelCheck& cancel = {});

  /// The local rotations of the last refine()'s result, as one more local step finds them (R_i = argmax
  /// trace(R^T S_i) over its one-ring, the batched axis/angle fit), row-major into `out` (9 values per
  /// vertex). Allocates nothing. Throws std::invalid_argument on a size other than 9 n, std::logic_error
  /// before any refine() has succeeded.
  void rotations(std::span<T> out);

  /// Extrapolated iterates that ArapAcceleration::anderson's safeguard replaced by the plain step in the last
  /// refine() (0 without acceleration).
  int rejected_iterates() const;

  /// E(x) with the optimal rotations for x (as one local step computes them), in double (in the units of the
  /// positions, squared: inf where that overflows double).
  double energy(const Points<T>& x) const;

  Eigen::Index vertex_count() const;
  /// Edges whose cotangent weight was negative (clamped to the floor).
  std::size_t clamped_weights() const;
  /// Bytes held: the factorisation, the one-ring weights and the scratch.
  std::size_t memory_bytes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

extern template class ArapRefiner<float>;
extern template class ArapRefiner<double>;

}  // namespace mlsdeform
