// The ARAP global step's linear algebra: a sparse symmetric positive definite matrix A factorised once,
// P A P^T = L D L^T (Eigen's SimplicialLDLT, AMD ordering, double), and the substitution for three
// right-hand sides at once (interleaved), disjoint subtrees of L's elimination tree on the threads at once,
// with nothing allocated. The result is bitwise the same for any thread count and schedule.
#pragma once

#include <tbb/task_arena.h>
#include <Eigen/SparseCholesky>

#include <cstddef>
#include <vector>

namespace mlsdeform::detail {

class SubtreeLdlt {
 public:
  /// Factorises A and schedules the substitution for `bins` threads; false where the factorisation fails.
  bool compute(const Eigen::SparseMatrix<double>& A, std::size_t bins);
  /// Where row i of A lives in the substitution's vectors: at 3 * row_of(i) (P's indices).
  int row_of(Eigen::Index i) const { return perm[std::size_t(i)]; }
  /// A x = b for three right-hand sides: y holds b in and x out, 3 values per row of A, at 3 * row_of(i).
  /// On at most `threads` threads (0: all) in `arena` (may be null).
  void solve(std::vector<double>& y, int threads, tbb::task_arena* arena) const;
  std::size_t memory_bytes() const;

 private:
  template <class Cols, class First, class Last>
  void forward(std::vector<double>& y, const Cols& cols, First p0, Last p1) const;
  void backward(std::vector<double>& y, std::size_t k0, std::size_t k1) const;
  void schedule(std::size_t bins);

  /// The factor (Eigen stores L's strictly lower part by columns: the unit diagonal is implicit), and D,
  /// copied once (vectorD() returns a copy).
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  std::vector<double> D;
  std::vector<int> perm;  ///< P as indices: P b puts b(i) at perm[i]
  /// The substitution's schedule (schedule() builds it): factor rows part by part, ascending in each part;
  /// part k is order[part_start[k] .. part_start[k + 1]). Parts 0 .. parts - 1 are disjoint sets of subtrees
  /// of the elimination tree, part `parts` (the top) holds all their ancestors.
  std::vector<int> order;
  std::vector<std::size_t> part_start;
  std::size_t parts = 0;
  /// Column c's entries in rows of the top part are L.innerIndex[top_start[c] .. Lp[c + 1]) (its rows
  /// ascend along its ancestors, the top's last); tail_cols: the columns with any, ascending.
  std::vector<int> top_start, tail_cols;
};

}  // namespace mlsdeform::detail
