// The session's side of the frames (mlsdeform/frames.hpp): the checks of a FramesOut, the region's frames
// moved to their vertices' rows, and the ARAP refinement's rotations written as frames.
#pragma once

#include <mlsdeform/arap.hpp>
#include <mlsdeform/enums.hpp>
#include <mlsdeform/frames.hpp>

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace mlsdeform::detail {

/// Throws std::invalid_argument naming the output unless each wanted output of `frames` has its size for n
/// vertices (quaternions 4 n, rotations 9 n, scales n, linear 9 n) and `transform` has it (affine: linear
/// alone, and only when `affine_frames`, Options::affine_frames, built its table).
template <class T>
void check_frames(const FramesOut<T>& frames, std::size_t n, Transform transform, bool affine_frames);

/// Options::region: the wanted outputs hold the region's frames in their first inside.size() rows (compact
/// vertex r in row r); moves row r to row inside[r] (inside ascending, so inside[r] >= r: from the last row
/// down nothing is overwritten before it moves) and writes the identity into the other rows.
template <class T>
void scatter_frames(const FramesOut<T>& frames, const std::vector<Eigen::Index>& inside);

/// With ARAP refinement: the refined local rotations (ArapRefiner::rotations) into the wanted outputs, via
/// `scratch` (9 n values) where `frames` has no 9-wide output; scales 1, linear R.
template <class T>
void write_rotations(const FramesOut<T>& frames, ArapRefiner<T>& refiner, std::vector<T>& scratch);

}  // namespace mlsdeform::detail
