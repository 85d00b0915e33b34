// The ARAP energy as a by-product of the local step, for Anderson acceleration's safeguard (anderson.hpp):
// with S_i = sum_j w_ij (x_i - x_j)(p_i - p_j)^T and the step's rotation R_i,
//   E_i = sum_j w_ij |(x_i - x_j) - R_i (p_i - p_j)|^2
//       = sum_j w_ij |x_i - x_j|^2 - 2 trace(R_i^T S_i) + sum_j w_ij |p_i - p_j|^2,
// so the local step adds one sum per edge and nine products per vertex instead of a second pass over the
// one-rings. The terms cancel where a ring is nearly rigid; in double, against the ring's own size, that
// costs a few units of 1e-16 per vertex, far below the energy changes the safeguard compares.
#pragma once

#include "core/src/huge_pages.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cstddef>
#include <vector>

namespace mlsdeform::detail {

struct RingEnergy {
  /// Per vertex: S_i (9 values, row-major, unscaled) and sum_j w_ij |x_i - x_j|^2, written by the local step's
  /// sums (RingFrame::ring, kernels/contract.hpp).
  std::vector<double> ring;
  std::vector<double> q;       ///< per vertex: sum_j w_ij |p_i - p_j|^2, in the rest pose's units
  std::vector<double> chunks;  ///< E's partial sums per chunk of vertices

  /// Sized once: n vertices with CSR one-rings (start, nbr, w) over the rest positions P, chunks of `grain`;
  /// `ring` first touched on `threads` of `arena` (touch_pages).
  template <class Index, class Points>
  void init(const std::vector<Index>& start, const std::vector<Index>& nbr, const std::vector<double>& w,
            const Points& P, std::size_t grain, int threads = 1, tbb::task_arena* arena = nullptr) {
    const std::size_t n = std::size_t(P.rows());
    assign_huge(ring, 10 * n, 0.0, threads, arena);
    q.assign(n, 0.0);
    for (std::size_t i = 0; i < n; ++i)
      for (Index e = start[i]; e < start[i + 1]; ++e)
        q[i] += w[std::size_t(e)] * (P.row(Index(i)) - P.row(nbr[std::size_t(e)])).squaredNorm();
    chunks.assign((n + grain - 1) / grain, 0.0);
  }
  bool empty() const { return q.empty(); }

  /// Chunks [c0, c1) of `grain` vertices (of n): per chunk sum_i E_i with the rotations Rd (R_i^T row-major, 9
  /// per vertex, float or double), the rest terms scaled to the positions' units by rest_to_x.
  template <class T>
  void finish(std::size_t c0, std::size_t c1, std::size_t grain, std::size_t n, const T* Rd, double rest_to_x) {
    for (std::size_t c = c0; c < c1; ++c) {
      double E = 0;
      for (std::size_t i = c * grain; i < std::min(n, (c + 1) * grain); ++i) {
        double tr = 0;
        for (std::size_t k = 0; k < 9; ++k) tr += double(Rd[9 * i + 3 * (k % 3) + k / 3]) * ring[10 * i + k];
        E += ring[10 * i + 9] - 2 * rest_to_x * tr + rest_to_x * rest_to_x * q[i];
      }
      chunks[c] = E;
    }
  }

  /// E over all chunks, in chunk order (the same sum for any thread count).
  double total() const {
    double E = 0;
    for (const double c : chunks) E += c;
    return E;
  }
};

}  // namespace mlsdeform::detail
