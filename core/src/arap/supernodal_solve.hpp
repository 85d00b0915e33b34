// The substitution with supernodal_cholesky's factor (supernodal_ldlt.hpp): G G^T x = b for three
// right-hand sides at once (interleaved, 3 values per row), on the dense blocks: each supernode solves its
// diagonal block and updates the rows below from its block's columns, which stream once through memory
// (8 bytes per entry; the right-hand sides are gathered once per supernode row, not once per entry).
//
// Threads: the supernodes' tree is cut (cut_tree) into subtrees spread over `bins` parts, and a top, the
// supernodes above them. Forward: the parts in parallel, each supernode updating the rows below it that are
// not in the top; then the parts' supernodes with rows in the top sum their updates of those rows, in
// parallel, into a buffer (tail_sums); then, one thread, every supernode with rows in the top (ascending)
// subtracts them (the parts' from the buffer), and the top's supernodes solve their blocks in turn (the large
// blocks' rows shared by the threads). On one thread each supernode sums and subtracts in turn. Backward: the
// top (the large blocks' columns shared), then the parts in parallel. Forward, each row's update from a
// supernode is one sum over the supernode's columns in ascending order, whichever pass computes it, and the
// updates reach a row in ascending supernode order; backward, each column's sum over its block's rows is
// computed whole by one call, its even and odd rows apart (two chains: the rows stream at memory speed
// rather than at one add's latency), then added. So the same bits for any thread count and any cut.
// Nothing is allocated per solve (each part's scratch is sized by schedule()).
//
// Prefetch: in the parts, each supernode's step first prefetches the next one's block (the next in the pass:
// forward ascending, backward descending), its first kPrefetchBytes. Both passes read each block from its
// start, and most blocks are small (spot_loop3's median supernode has 2 columns and 10 rows; half its entries
// are in blocks under 64 KiB), so the hardware's stream prefetchers, which need a few lines to find a stream,
// missed the start of every block, and more so backward, where the blocks come in descending order. On
// spot_loop3 (AMD EPYC Zen 5, with and without, alternated in one process, median of 12): 158 -> 117 ms on one
// thread, 99.5 -> 78 ms on two. A window of the next 4-64 KiB in memory order instead gained half as much, caps
// above 32 KiB nothing more. Factors of at most SubtreeLdlt::kColumnLimit values (the body's two subdivisions
// included) are converted to columns and substituted by subtree_ldlt.cpp: neither this nor the parallel tail applies.
#pragma once

#include "core/src/arap/supernodal_ldlt.hpp"
#include "core/src/threading.hpp"

#include <cstddef>
#include <vector>

namespace mlsdeform::detail {

class SupernodalSolve {
 public:
  static constexpr std::size_t kPrefetchBytes = 32 * 1024;
  /// Takes the factor and cuts its tree for `bins` threads.
  SupernodalSolve(SupernodalFactor factor, std::size_t bins);
  /// y holds b in and x out, 3 values per row, row i of A at 3 * factor().perm[i].
  void solve(std::vector<double>& y, int threads, tbb::task_arena* arena) const;
  const SupernodalFactor& factor() const { return f; }
  std::size_t memory_bytes() const;

 private:
  void forward(double* y, std::size_t t, int p0, int p1, bool diagonal, double* acc, double* planar) const;
  /// forward's two halves below the diagonal block: acc = the rows p0 .. p1's sums (3 (p1 - p0) values), then
  /// y_r -= acc_r.
  void sums(const double* y, std::size_t t, int p0, int p1, double* acc) const;
  void scatter(double* y, std::size_t t, int p0, int p1, const double* acc) const;
  /// Prefetches the first kPrefetchBytes of supernode t's block (or all of a smaller one): see solve().
  void prefetch_block(std::size_t t) const;
  void gather(const double* y, std::size_t t, double* xb) const;
  void below(double* y, std::size_t t, int c0, int c1, const double* xb) const;
  void diagonal_back(double* y, std::size_t t, double* planar) const;
  void back_one(double* y, std::size_t t) const;

  SupernodalFactor f;
  std::vector<double> inverse;  ///< 1 / G_cc for each column c
  std::vector<int> top_start;   ///< supernode t's rows from row position top_start[t] on are in the top
  /// Part k's subtrees: ranges[range_start[k] .. range_start[k + 1]), each [lo, hi] of supernodes.
  std::vector<std::pair<int, int>> ranges;
  std::vector<std::size_t> range_start;
  std::vector<int> top, tail;  ///< the top's supernodes; those with rows in the top (top's included), ascending
  double shared_from = 0;      ///< blocks with at least this many entries are shared by the threads (solve())
  mutable std::vector<std::vector<double>> scratch;  ///< per part, and one for the top (the last)
  std::vector<std::size_t> planar_at;                ///< where each scratch's planar copy of a supernode's rows starts
  /// The tail's supernodes outside the top (ascending), where each one's sums for the top's rows start in
  /// tail_sums, and tail_sums (empty for one thread: there each is summed and subtracted in turn).
  std::vector<int> below_top;
  std::vector<std::size_t> sums_at;
  std::size_t below_sums = 0;
  mutable std::vector<double> tail_sums;
};

}  // namespace mlsdeform::detail
