// The ARAP local step's one-ring sums (Sorkine & Alexa 2007, eq. (5): the covariance whose rotation the local
// step fits), the scalar reference of the stage whose SIMD twin is kernels/arap/ring_correlation.hpp:
//   S_i = sum_j w_ij (x_i - x_j)(p_i - p_j)^T        over the one-ring of i, in the CSR order,
// with w_ij (p_i - p_j) precomputed per directed edge, and, for the energy (ring_energy.hpp),
//   sum_j w_ij |x_i - x_j|^2.
// The fit is invariant under positive scaling of S_i, so S_i is scaled by a power of two to max |S_i| in
// [1, 2), exactly, and rounded once to T: rounding to float neither overflows nor drops a ring whose
// deformation is small against the mesh.
//
// Error bound (the stage test's): each term is (x_i - x_j) rounded once times a_j rounded once, and the
// sum of K terms adds K - 1 roundings, so |S_i - exact| <= gamma_{K+1} sum_j |x_i - x_j| |a_j| entrywise
// (Higham, gamma_k = k u / (1 - k u), u = 2^-53), likewise the energy sum within gamma_{K+5} of
// sum_j w_ij |x_i - x_j|^2 (six roundings in a term, K - 1 in the sum); the scaling is exact and the rounding to T adds
// u_T |H|.
#pragma once

#include "core/src/threading.hpp"
#include "kernels/contract.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace mlsdeform::detail {

/// The one-rings padded into blocks of kernels::kLanes vertices, as the SIMD twin reads them (RingFrame's
/// slot_begin, self, slot_x, slot_a, slot_w: kernels/contract.hpp). Built once per rest pose.
struct PaddedRings {
  std::vector<std::size_t> slot_begin;  ///< blocks + 1
  std::vector<std::int64_t> self;       ///< kLanes per block
  std::vector<std::int64_t> slot_x;     ///< kLanes per slot
  std::vector<double> slot_a;           ///< 3 kLanes per slot
  std::vector<double> slot_w;           ///< kLanes per slot
  std::size_t memory_bytes() const;
};

/// n vertices' CSR one-rings (start: n + 1 offsets; nbr, w, and we = w_ij (p_i - p_j), 3 per edge), padded; the
/// arrays first touched on `threads` of `arena` (touch_pages, huge_pages.hpp).
PaddedRings pad_one_rings(std::span<const Eigen::Index> start, std::span<const Eigen::Index> nbr,
                          std::span<const double> w, std::span<const double> we, int threads = 1,
                          tbb::task_arena* arena = nullptr);

/// The frame over a session's one-rings: both layouts, the positions x (row-major n x 3), the output H
/// (3 x 3 x n SoA) and, where not null, the energy's per-vertex record `ring` (10 values per vertex); for
/// ring_rhs, the rotations R, c and the output b (RingFrame).
template <class T>
kernels::RingFrame<T> ring_frame(std::size_t n, const double* x, std::span<const Eigen::Index> start,
                                 std::span<const Eigen::Index> nbr, std::span<const double> w,
                                 std::span<const double> we, const PaddedRings& padded, T* H, double* ring,
                                 const T* R = nullptr, const double* c = nullptr, double* b = nullptr) {
  return {n,
          x,
          start.data(),
          nbr.data(),
          w.data(),
          we.data(),
          padded.slot_begin.data(),
          padded.self.data(),
          padded.slot_x.data(),
          padded.slot_a.data(),
          padded.slot_w.data(),
          H,
          ring,
          R,
          c,
          b};
}

/// The scalar reference over the CSR one-rings: the vertices of blocks [block_begin, block_end) below fr.n,
/// one at a time (the kernel table's ring_correlation entry of the scalar table).
template <class T>
void ring_correlation(const kernels::RingFrame<T>& fr, std::size_t block_begin, std::size_t block_end);

extern template void ring_correlation<float>(const kernels::RingFrame<float>&, std::size_t, std::size_t);
extern template void ring_correlation<double>(const kernels::RingFrame<double>&, std::size_t, std::size_t);

/// The global step's rotated one-ring sums (Sorkine & Alexa 2007, eq. (9)'s right-hand side, before the held
/// neighbours' terms), the scalar reference of the stage whose SIMD twin is kernels/arap/ring_rhs.hpp:
///   b_i = sum_j (w_ij / 2)(R_i + R_j)(p_i - p_j) = (R_i c_i + sum_j R_j w_ij (p_i - p_j)) / 2,
/// for the vertices of blocks [block_begin, block_end) below fr.n, one at a time: the term of R_i c_i first,
/// then one term per neighbour in the CSR order, each term (R a)_r = (R_r0 a_0 + R_r1 a_1) + R_r2 a_2 halved
/// (R widened to double exactly) and added to b_r. Reads fr.R, fr.c, fr.start, fr.nbr, fr.we; writes fr.b.
/// Error bound (the stage test's): each halved term is a 3-term dot product (gamma_3 of sum_k |R_rk a_k| / 2,
/// the halving exact above double's subnormals) and K + 1 terms add K roundings, so
/// |b_ir - exact| <= gamma_{K+3} (sum over the K + 1 terms of sum_k |R_rk a_k|) / 2.
template <class T>
void ring_rhs(const kernels::RingFrame<T>& fr, std::size_t block_begin, std::size_t block_end);

extern template void ring_rhs<float>(const kernels::RingFrame<float>&, std::size_t, std::size_t);
extern template void ring_rhs<double>(const kernels::RingFrame<double>&, std::size_t, std::size_t);

}  // namespace mlsdeform::detail
