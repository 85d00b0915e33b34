// mlsdeform: batched rotation fits in SIMD lanes, and the run-time choice of instruction set.
#pragma once

#include <mlsdeform/cancel.hpp>
#include <mlsdeform/rotation.hpp>
#include <mlsdeform/stats.hpp>

#include <cstddef>
#include <string_view>
#include <vector>

namespace mlsdeform {

/// Instruction sets the kernels are built for. The library is compiled once for generic x86-64 and picks
/// the best one the CPU runs; the environment variable MLSDEFORM_ISA=scalar|sse4_2|avx2|avx512 forces one
/// (read once, at the first call that needs it; an unknown or unsupported value throws).
/// The tests run every ISA the CPU reports (avx512 wherever it has AVX-512F); set_isa or MLSDEFORM_ISA=avx2
/// reproduces an AVX2-only machine.
enum class Isa { scalar, sse4_2, avx2, avx512 };

std::string_view to_string(Isa isa);
/// The instruction sets this CPU can run, best last (scalar is always there).
std::vector<Isa> supported_isas();
/// The one in use.
Isa active_isa();
/// Force one (throws std::invalid_argument if this CPU cannot run it). Not thread-safe against running fits.
void set_isa(Isa isa);
/// SIMD lanes of the active ISA for float or double (1 for scalar).
std::size_t simd_lanes(bool double_precision);

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
