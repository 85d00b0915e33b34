// A vectorisable finiteness check for large arrays (the batched fits' input, the deformer's output): the
// baseline instantiation of kernels/all_finite.hpp. Hot callers take the active kernel table's
// (all_finite_f, all_finite_d: compiled for the ISA).
#pragma once

#include "kernels/all_finite.hpp"

namespace mlsdeform::detail {

using kernels::all_finite;

}  // namespace mlsdeform::detail
