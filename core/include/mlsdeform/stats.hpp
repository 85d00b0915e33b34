// mlsdeform: what the batched rotation fit reports (fit_rotations in fit_rotations.hpp); a header of its own so that
// the per-ISA kernels (kernels/kernel_table.hpp) fill the same struct without seeing Eigen.
#pragma once

#include <cstddef>

namespace mlsdeform {

/// Lanes that left the batched axis/angle fit's regular path (kernels/rotation/axis_angle.hpp).
struct BatchStats {
  /// axis_angle: lanes its fast path could not settle (a nearly multiple root of (13), a gap s2 + d s3 below
  /// cbrt(eps) s1), solved on the careful path, still in the lanes (the top eigenvector of K by Jacobi).
  std::size_t careful_lanes = 0;
};

}  // namespace mlsdeform
