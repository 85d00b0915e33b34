// The dispatch table between core/ (baseline flags) and the kernels: plain function pointers and declarations
// only. One table per ISA (kernels/isa_<name>.cpp) and one for the scalar reference
// (core/src/scalar_kernels.cpp), chosen at run time by core/src/dispatch.cpp. Nothing here may be an inline
// function or be instantiated in an ISA translation unit, or the linker could pick an AVX copy of the weak
// symbol for the baseline path.
#pragma once

#include "kernels/contract.hpp"

#include <mlsdeform/stats.hpp>

#include <cstddef>

namespace mlsdeform::kernels {

/// Batched rotation fit over matrices [begin, end) of a 3 x 3 x n structure-of-arrays layout:
/// entry (r, c) of matrix i is H[(3 r + c) * stride + i], likewise R. H must be finite. Adds to
/// stats->careful_lanes (when stats is not null) the lanes that took the careful path.
template <class T>
using FitRotationsFn = void (*)(const T* H, T* R, std::size_t stride, std::size_t begin, std::size_t end,
                                BatchStats* stats);

/// One frame of the MLS deformation, blocks [block_begin, block_end) of kLanes vertices.
template <class T>
using DeformBlocksFn = void (*)(const DeformFrame<T>& frame, std::size_t block_begin, std::size_t block_end);

/// The ARAP local step's one-ring sums, or the global step's rotated ones, over blocks [block_begin,
/// block_end) of kLanes vertices (RingFrame).
template <class T>
using RingCorrelationFn = void (*)(const RingFrame<T>& frame, std::size_t block_begin, std::size_t block_end);

struct KernelTable {
  const char* name;         ///< "scalar", "sse4_2", "avx2", "avx512", "neon"
  std::size_t lanes_float;  ///< SIMD lanes for float and double (1 for the scalar reference)
  std::size_t lanes_double;
  FitRotationsFn<float> fit_axis_angle_f;
  FitRotationsFn<double> fit_axis_angle_d;
  /// The same fits, bitwise, writing R past the caches where the ISA can (fit_range_axis_angle's kStream): for a
  /// batch whose rotations would leave the caches before anyone reads them (fit_rotations' rule).
  FitRotationsFn<float> fit_axis_angle_stream_f;
  FitRotationsFn<double> fit_axis_angle_stream_d;
  FitRotationsFn<float> fit_horn_f;  ///< Horn 1987 quaternion (SIMD: by cyclic Jacobi on the 4x4 matrix)
  FitRotationsFn<double> fit_horn_d;
  DeformBlocksFn<float> deform_f;  ///< SIMD: the methods axis_angle and horn_quaternion; scalar: all
  DeformBlocksFn<double> deform_d;
  RingCorrelationFn<float> ring_correlation_f;  ///< the sums in double either way; H rounded to float or double
  RingCorrelationFn<double> ring_correlation_d;
  RingCorrelationFn<float> ring_rhs_f;  ///< the global step's b_i, in double; R_i in float or double
  RingCorrelationFn<double> ring_rhs_d;
  bool (*all_finite_f)(const float* x, std::size_t count);  ///< kernels/all_finite.hpp, with the ISA's flags
  bool (*all_finite_d)(const double* x, std::size_t count);
};

/// Defined in kernels/isa_<name>.cpp and core/src/scalar_kernels.cpp; each returns its table. Only the ISAs of
/// the target architecture are built (kernels/CMakeLists.txt: sse4_2, avx2, avx512 on x86-64; neon on aarch64).
const KernelTable& kernel_table_scalar();
const KernelTable& kernel_table_sse4_2();
const KernelTable& kernel_table_avx2();
const KernelTable& kernel_table_avx512();
const KernelTable& kernel_table_neon();

}  // namespace mlsdeform::kernels
