// Run-time ISA selection (core/, baseline flags). See <mlsdeform/dispatch.hpp> for the public side.
#pragma once

#include <mlsdeform/dispatch.hpp>
#include <mlsdeform/enums.hpp>

#include "kernels/kernel_table.hpp"

namespace mlsdeform::detail {

/// The kernels of `isa` (for Isa::scalar, the scalar reference's table); the caller checks that the CPU runs it.
const kernels::KernelTable& kernels_for(Isa isa);
/// kernels_for(active_isa()).
const kernels::KernelTable& active_kernels();

/// Matrices [begin, end) of a 3 x 3 x n layout fitted one at a time by fit_rotation (every method; the
/// scalar table's fit entries, and fit_rotations' path for the methods without a SIMD kernel).
template <class T>
void fit_rotations_one_at_a_time(const T* H, T* R, std::size_t stride, std::size_t begin, std::size_t end,
                                 RotationMethod method);

}  // namespace mlsdeform::detail
