// The interface between core/ (baseline flags) and the per-ISA kernel objects: plain function pointers and
// declarations only. Nothing here may be an inline function or be instantiated in an ISA translation unit,
// or the linker could pick an AVX copy for the baseline path (../shared/TOOLCHAIN.md pitfall 3).
#pragma once

#include <cstddef>
#include <cstdint>

namespace mlsdeform::kernels {

/// Lanes that left the regular path of the batched axis/angle fit (see rotation_axis.hpp).
struct RotationStats {
  std::size_t near_double = 0;      ///< near-double root: the shifted adjugate ran (in the lanes)
  std::size_t scalar_fallback = 0;  ///< triple root: handed to the scalar reference (rare)
};

/// Batched rotation fit over matrices [begin, end) of a 3 x 3 x n structure-of-arrays layout:
/// entry (r, c) of matrix i is H[(3 r + c) * stride + i], likewise R. H must be finite.
template <class T>
using FitRotationsFn = void (*)(const T* H, T* R, std::size_t stride, std::size_t begin, std::size_t end,
                                RotationStats* stats);

/// One block of B = 16 vertices of the precomputed rigid/similarity deformation; see deform_kernel.hpp.
struct DeformBlockArgsF;
struct DeformBlockArgsD;

struct KernelTable {
  const char* name;          ///< "sse4_2", "avx2", "avx512"
  std::size_t lanes_float;   ///< SIMD lanes for float and double
  std::size_t lanes_double;
  FitRotationsFn<float> fit_axis_angle_f;
  FitRotationsFn<double> fit_axis_angle_d;
  FitRotationsFn<float> fit_horn_f;    ///< Horn 1987 quaternion by cyclic Jacobi on the 4x4 matrix
  FitRotationsFn<double> fit_horn_d;
};

/// Defined in kernels/isa_<name>.cpp; nullptr-free: each returns its table.
const KernelTable& kernel_table_sse4_2();
const KernelTable& kernel_table_avx2();
const KernelTable& kernel_table_avx512();

/// The scalar reference for one lane that the SIMD path hands over (defined in core/, baseline flags):
/// h9 row-major normalised H, r9 row-major rotation out.
template <class T>
void fit_rotation_lane_fallback(const T* h9, T* r9);

}  // namespace mlsdeform::kernels
