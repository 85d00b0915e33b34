// The library's own supernodal factorisation (MIT, every build) of the ARAP global step's matrix: P A P^T =
// G G^T by supernodes (sets of consecutive columns of L with one row structure, stored as dense column-major
// blocks and factorised by Eigen's dense kernels), left-looking, the elimination tree's independent subtrees
// on the threads.
//
// The analysis (supernodal_symbolic.cpp) follows the classical sequence (Liu's elimination tree, a
// postorder, column counts from the row subtrees, fundamental supernodes, relaxed amalgamation as CHOLMOD
// relaxes, the supernodes' row structures); the numeric phase (supernodal_numeric.cpp) computes each
// supernode from A's columns and the updates of its descendants, in ascending order of the descendants,
// whichever thread runs it: the factor's bits do not depend on the thread count. supernodal_solve.hpp
// substitutes with the blocks.
#pragma once

#include "core/src/threading.hpp"

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <cstddef>
#include <utility>
#include <vector>

namespace mlsdeform::detail {

struct SupernodalSymbolic {
  std::vector<int> order;   ///< order[k]: the row of A eliminated k-th (postordered along its tree)
  std::vector<int> pos;     ///< its inverse: row i of A is column pos[i] of L
  std::vector<int> parent;  ///< the elimination tree: parent[k] > k, -1 at a root
  std::vector<int> count;   ///< entries of L strictly below the diagonal in column k (exact structure)
  std::size_t entries = 0;  ///< the sum of count

  /// Relaxed supernodes: supernode s holds columns first[s] .. first[s + 1), its rows are
  /// rows[row_start[s] .. row_start[s + 1]) (its own columns, then the rows below them, ascending), its
  /// values a column-major block of (rows x columns) at value_start[s]; super_parent[s]: -1 at a root.
  std::vector<int> first, row_start, rows, super_parent, super_of;
  std::vector<std::size_t> value_start;
  /// The updates supernode s receives: update_start[s] .. update_start[s + 1) into `updates`, by ascending
  /// descendant d; d's rows p0 .. p1 (positions in its row list) are s's columns.
  struct Update {
    int d, p0, p1;
  };
  std::vector<std::size_t> update_start;
  std::vector<Update> updates;
};

/// The elimination tree, the postorder and the column counts of A in the order `order` (order[k] = the row
/// eliminated k-th); fills order (postordered), pos, parent, count, entries.
SupernodalSymbolic analyse_order(const Eigen::SparseMatrix<double>& A, const std::vector<int>& order);

/// The supernodes of an analysed order: first, rows, row_start, super_parent, super_of, value_start,
/// update_start and updates.
void find_supernodes(const Eigen::SparseMatrix<double>& A, SupernodalSymbolic& s);

/// The factor G (P A P^T = G G^T) by supernodes: supernode s holds columns first[s] .. first[s + 1), its rows
/// rows[row_start[s] .. row_start[s + 1]) (its own columns, then those below, ascending) and its block, column
/// major (rows x columns), at values[value_start[s]]: G_11 in the diagonal block's lower triangle (its upper
/// triangle is unused), G_21 below. perm[i]: the column of row i of A.
struct SupernodalFactor {
  std::vector<int> first, row_start, rows, super_parent, perm;
  std::vector<std::size_t> value_start;
  std::vector<double> values;
};

/// The factor as L D L^T by columns (L_rc = G_rc / G_cc, D_c = G_cc^2; the relaxed supernodes' zeros kept, or
/// with `drop_zeros` every entry that is zero dropped): L's strictly lower part, rows ascending, column c's at
/// rows[col_start[c] .. col_start[c + 1]). Its arrays first touched on `threads` of `arena` (touch_pages).
struct ColumnLdlt {
  std::vector<int> col_start, rows;
  std::vector<double> values, D;
};
ColumnLdlt to_columns(const SupernodalFactor& f, bool drop_zeros = false, int threads = 1,
                      tbb::task_arena* arena = nullptr);

/// Eigen's AMD (Eigen::AMDOrdering's) on A's own pattern. AMDOrdering first forms the pattern of A^T + A (two
/// transposed copies), which for A (both triangles stored, so structurally symmetric) is A's, in the same order:
/// the same permutation (checked on spot_loop3 and the body's subdivisions). minimum_degree_ordering takes its
/// matrix as work space, grown to nnz + nnz / 5 + 2 n entries: the copy is made that large at once, on huge
/// pages (huge_pages.hpp), so that neither it nor its growth faults per 4 KiB page. spot_loop3 (AMD EPYC Zen 5):
/// 1.17-1.32 -> 0.52-0.72 s.
void amd_order(const Eigen::SparseMatrix<double>& A, Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int>& P);

/// supernodal_cholesky's default split_columns. A supernode of at least that many columns receives its
/// descendants' updates split_columns / 2 of its columns at a time: each chunk from every descendant in
/// ascending order, so each entry sees its terms in one order whatever the thread count (the cut depends on
/// the supernode alone), and at the top of the tree, above the threads' subtrees, the chunks in parallel. Only
/// a large mesh's top separators are that wide: spot_loop3's widest has 2,066 columns and 3,169 updates, which
/// took 0.58 s of the serial top's 1.42 s; the bundled body's widest has 137.
inline constexpr int kSplitColumns = 256;

/// Factorises A (symmetric positive definite, both triangles stored) on at most `threads` threads (0: the
/// calling arena's), in the order of coordinate_nested_dissection where `points` are given and that leaves
/// fewer entries in L than Eigen's AMD, else in AMD's (the two found side by side). False where A is not
/// numerically positive definite. `split_columns`: see kSplitColumns (the tests lower it to reach every
/// supernode).
bool supernodal_cholesky(const Eigen::SparseMatrix<double>& A, const Eigen::Matrix<double, Eigen::Dynamic, 3>* points,
                         int threads, SupernodalFactor& out, int split_columns = kSplitColumns);

/// The supernodes' tree (super_parent, a postorder) cut for `threads` threads: `parts`, ranges [lo, hi] of
/// consecutive supernodes, each a whole subtree (ending at its root), heaviest first; `top`, the supernodes
/// above them, ascending. The heaviest subtree is split (its root to the top, its children to the parts)
/// while it holds more than 1/(8 threads) of the work (work[s]: supernode s's own).
void cut_tree(const std::vector<int>& super_parent, const std::vector<double>& work, std::size_t threads,
              std::vector<std::pair<int, int>>& parts, std::vector<int>& top);

}  // namespace mlsdeform::detail
