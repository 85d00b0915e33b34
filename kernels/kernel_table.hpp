// The interface between core/ (baseline flags) and the per-ISA kernel objects: plain function pointers and
// declarations only. Nothing here may be an inline function or be instantiated in an ISA translation unit,
// or the linker could pick an AVX copy for the baseline path (../shared/TOOLCHAIN.md pitfall 3).
#pragma once

#include <cstddef>
#include <cstdint>

namespace mlsdeform::kernels {

/// Lanes that left the regular path of the batched axis/angle fit (see rotation_axis.hpp).
struct RotationStats {
  std::size_t near_double = 0;  ///< lanes on the careful path of the axis/angle fit (in the lanes)
};

/// Batched rotation fit over matrices [begin, end) of a 3 x 3 x n structure-of-arrays layout:
/// entry (r, c) of matrix i is H[(3 r + c) * stride + i], likewise R. H must be finite.
template <class T>
using FitRotationsFn = void (*)(const T* H, T* R, std::size_t stride, std::size_t begin, std::size_t end,
                                RotationStats* stats);

/// One frame of the MLS deformation over the precomputed session data of core/src/deformer_data.hpp
/// (blocks of 16 vertices; per block and pseudo-handle j the 16-lane arrays omega, Ax, Ay, Az, or alpha).
/// Targets come straight from the caller's handles: point j at (points[j], points[k + j], points[2k + j])
/// (column-major k x 3), then for each segment i its ends seg_a and seg_b (column-major s x 3).
template <class T>
struct DeformFrame {
  const T* table;         ///< coefficient table
  const T* vhat;          ///< vhat[c * padded + v] (rigid, similarity)
  const T* D;             ///< similarity: D[v]; else nullptr
  std::size_t padded;     ///< 16 * blocks
  const T* points;        ///< k x 3 column-major
  std::size_t k;
  const T* seg_a;         ///< s x 3 column-major
  const T* seg_b;
  std::size_t s;
  T centre[3];            ///< c: H = sum_j (q_j - c) A_j^T
  int transform;          ///< 0 rigid, 1 similarity, 2 affine
  int method;             ///< 0 axis_angle, 1 horn_quaternion (Jacobi)
  T* out;                 ///< vertex v, coordinate c at out[c * out_coord_stride + v * out_vertex_stride]
  std::size_t out_vertex_stride, out_coord_stride;
  std::size_t n;          ///< vertices (the last block may be partial)
  // WeightStorage::on_the_fly (core/src/deformer_data.hpp): no table, weights from distances per frame.
  bool on_the_fly;
  const T* v_local;       ///< rest vertices, local frame, SoA [c * padded + v]
  const T* dref2;         ///< squared nearest-handle distance [v]
  const T* snap;          ///< handle index a vertex sits on, or -1 [v]
  const T* p_local;       ///< point handles, local frame, SoA [c * k + j]
  T world_scale;          ///< 2^e of the local frame
  T half_u;               ///< u / 2
};

template <class T>
using DeformBlocksFn = void (*)(const DeformFrame<T>& frame, std::size_t block_begin, std::size_t block_end,
                                RotationStats* stats);

struct KernelTable {
  const char* name;          ///< "sse4_2", "avx2", "avx512"
  std::size_t lanes_float;   ///< SIMD lanes for float and double
  std::size_t lanes_double;
  FitRotationsFn<float> fit_axis_angle_f;
  FitRotationsFn<double> fit_axis_angle_d;
  FitRotationsFn<float> fit_horn_f;    ///< Horn 1987 quaternion by cyclic Jacobi on the 4x4 matrix
  FitRotationsFn<double> fit_horn_d;
  DeformBlocksFn<float> deform_f;
  DeformBlocksFn<double> deform_d;
};

/// Defined in kernels/isa_<name>.cpp; nullptr-free: each returns its table.
const KernelTable& kernel_table_sse4_2();
const KernelTable& kernel_table_avx2();
const KernelTable& kernel_table_avx512();

}  // namespace mlsdeform::kernels
