// mlsdeform: batched rotation fits in SIMD lanes (core/src/rotation/fit_rotations.cpp), on the instruction set
// dispatch.hpp picks.
#pragma once

#include <mlsdeform/cancel.hpp>
#include <mlsdeform/dispatch.hpp>
#include <mlsdeform/rotation.hpp>
#include <mlsdeform/stats.hpp>

#include <cstddef>

namespace mlsdeform {

/// n rotation fits at once. Layout (3 x 3 x n, structure of arrays): entry (r, c) of matrix i is
/// H[(3 r + c) * n + i]; R is written the same way. Each result equals fit_rotation(H_i, method) to within
/// rounding. axis_angle and horn_quaternion run in SIMD lanes (one matrix per lane); the other methods loop
/// over the scalar code. threads: 1 runs on the calling thread, 0 uses all cores (TBB); the result does not
/// depend on it. Throws std::invalid_argument, writing nothing, if any entry of H is NaN or infinite.
/// Allocates nothing.
template <class T>
void fit_rotations(const T* H, T* R, std::size_t n, RotationMethod method = RotationMethod::axis_angle, int threads = 1,
                   BatchStats* stats = nullptr);

extern template void fit_rotations<float>(const float*, float*, std::size_t, RotationMethod, int, BatchStats*);
extern template void fit_rotations<double>(const double*, double*, std::size_t, RotationMethod, int, BatchStats*);

/// The same fits on n row-major 3 x 3 matrices one after the other (numpy's C-contiguous (n, 3, 3) array, an
/// array of Eigen's RowMajor Matrix3): entry (r, c) of matrix i is H[9 i + 3 r + c]; R is written the same way,
/// and may be H itself (in place) but must not otherwise overlap it. Each tile of 128 matrices is transposed to
/// the lanes' layout and back in the L1 cache of the thread that fits it, so the result is bitwise that of
/// fit_rotations on the transposed batch, for any thread count. Throws std::invalid_argument, writing nothing,
/// naming the first NaN or infinite entry as H[i, r, c]. cancel (cancel.hpp) is asked before each chunk of
/// 2,048 matrices; once it says stop, throws Cancelled with R partly written. Allocates nothing.
template <class T>
void fit_rotations_interleaved(const T* H, T* R, std::size_t n, RotationMethod method = RotationMethod::axis_angle,
                               int threads = 1, BatchStats* stats = nullptr, const CancelCheck& cancel = {});

extern template void fit_rotations_interleaved<float>(const float*, float*, std::size_t, RotationMethod, int,
                                                      BatchStats*, const CancelCheck&);
extern template void fit_rotations_interleaved<double>(const double*, double*, std::size_t, RotationMethod, int,
                                                       BatchStats*, const CancelCheck&);

}  // namespace mlsdeform
