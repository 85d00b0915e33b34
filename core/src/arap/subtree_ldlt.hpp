// The ARAP global step's linear algebra: a sparse symmetric positive definite matrix A factorised once,
// P A P^T = L D L^T in double, and the substitution for three right-hand sides at once (interleaved),
// disjoint subtrees of L's elimination tree on the threads at once, with nothing allocated. The result is
// bitwise the same for any thread count and schedule.
//
// Two factorisations give the same kind of factor (L's strictly lower part by columns, rows ascending, and D):
//  - simplicial: Eigen's SimplicialLDLT with its AMD ordering (always there; MIT-compatible, MPL-2.0);
//  - supernodal: CHOLMOD's supernodal Cholesky, dense blocks by the BLAS, in the order of
//    coordinate_nested_dissection (nested_dissection.hpp) where the rows' points are given and it leaves
//    fewer entries in L than CHOLMOD's AMD, else in AMD's; then converted to L D L^T (only in builds with
//    MLSDEFORM_CHOLMOD=ON; CHOLMOD's Supernodal module is GPL-2+);
//  - supernodal_mit: the library's own supernodal Cholesky over Eigen's dense blocks (supernodal_ldlt.hpp),
//    in the dissection's order or AMD's alike; every build (MIT). A large factor keeps its blocks, G G^T, and
//    substitutes with them (supernodal_solve.hpp), with the same guarantees; a small one is converted to the
//    others' columns (compute()'s column_limit).
#pragma once

#include "core/src/arap/supernodal_ldlt.hpp"
#include "core/src/threading.hpp"

#include <Eigen/SparseCore>

#include <cstddef>
#include <memory>
#include <span>
#include <vector>

namespace mlsdeform::detail {

/// Whether this build has the supernodal factorisation (MLSDEFORM_CHOLMOD).
bool supernodal_available();

class SupernodalSolve;

class SubtreeLdlt {
 public:
  enum class Method { simplicial, supernodal, supernodal_mit };
  /// compute()'s default column_limit, 2^24 values (128 MiB of blocks). Below it the columns substitute faster
  /// (the relaxed zeros dropped), measured on the 2-core AMD EPYC Zen 5: the 6,890-vertex body 320 -> 200 us (best of
  /// 2,000), its two 1:4 subdivisions (110,210 vertices, 4.7 million values) 16.1 -> 9.2-10.4 ms on two threads, as
  /// fast as CHOLMOD's columns. Above it (spot_loop3: 50.7 million values) the conversion's copy raised the set-up's
  /// peak memory by a third (1.67 against 1.24 GiB) and its time by 2.7 s, for little gain (one thread: 158 against
  /// 167-200 CPU ms per substitution; two: 107 against 102-143 ms, within the noise).
  static constexpr std::size_t kColumnLimit = std::size_t(1) << 24;
  SubtreeLdlt();
  ~SubtreeLdlt();
  SubtreeLdlt(SubtreeLdlt&&) noexcept;
  SubtreeLdlt& operator=(SubtreeLdlt&&) noexcept;

  /// Factorises A and schedules the substitution for `bins` threads; false where the factorisation fails.
  /// `points` (optional): row i's point, for the supernodal factorisation's ordering. Method::supernodal in
  /// a build without it throws std::invalid_argument.
  /// supernodal_mit's factor is substituted by columns, as the others', where its blocks hold at most
  /// `column_limit` values (relaxed zeros included; the conversion drops them), else by its blocks.
  /// `split_columns`: supernodal_mit's (supernodal_ldlt.hpp, kSplitColumns).
  bool compute(const Eigen::SparseMatrix<double>& A, std::size_t bins, Method method = Method::simplicial,
               const Eigen::Matrix<double, Eigen::Dynamic, 3>* points = nullptr,
               std::size_t column_limit = kColumnLimit, int split_columns = kSplitColumns);
  /// Where row i of A lives in the substitution's vectors: at 3 * row_of(i) (P's indices).
  int row_of(Eigen::Index i) const { return perm[std::size_t(i)]; }
  /// A x = b for three right-hand sides: y holds b in and x out, 3 values per row of A, at 3 * row_of(i).
  /// On at most `threads` threads (0: all) in `arena` (may be null).
  void solve(std::vector<double>& y, int threads, tbb::task_arena* arena) const;
  std::size_t memory_bytes() const;

  /// The factor: P A P^T = L D L^T, with L's strictly lower part by columns (column c's rows, ascending, are
  /// rows[col_start[c] .. col_start[c + 1]), its values alike) and P as row_of. A copy (supernodal_mit's is
  /// converted from its blocks: L_rc = G_rc / G_cc, D_c = G_cc^2), for tests.
  struct Factor {
    std::vector<int> col_start, rows;
    std::vector<double> values, D;
  };
  Factor factor() const;
  /// Entries of L below the diagonal (as stored: supernodal_mit's relaxed zeros included).
  std::size_t entries() const;

  struct Storage;  ///< whoever owns L's arrays (Eigen's factor or CHOLMOD's): subtree_ldlt.cpp

 private:
  template <class Cols, class First, class Last>
  void forward(std::vector<double>& y, const Cols& cols, First p0, Last p1) const;
  void backward(std::vector<double>& y, std::size_t k0, std::size_t k1) const;
  void schedule(std::size_t bins);

  /// L's owner; Lp, Li, Lx point into its arrays: L's strictly lower part by columns, the unit diagonal
  /// implicit.
  std::unique_ptr<Storage> storage;
  /// supernodal_mit's factor, with its own substitution by blocks (in storage); null for the others.
  const SupernodalSolve* blocks = nullptr;
  const int *Lp = nullptr, *Li = nullptr;
  const double* Lx = nullptr;
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
