// Run-time ISA selection (core/, baseline flags). See <mlsdeform/batch.hpp> for the public side.
#pragma once

#include <mlsdeform/batch.hpp>

#include "kernel_table.hpp"

namespace mlsdeform::detail {

/// The kernels of the active ISA, or nullptr when it is Isa::scalar.
const kernels::KernelTable* active_kernels();

}  // namespace mlsdeform::detail
