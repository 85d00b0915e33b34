// A fill-reducing ordering for the ARAP global step's supernodal factorisation: nested dissection by
// coordinate bisection, for a matrix whose rows are points of a surface (the free vertices of a mesh).
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <vector>

namespace mlsdeform::detail {

/// The elimination order of A's rows (order[k] = the row eliminated k-th), A symmetric, row i at point
/// points.row(i). Each set of rows is cut at the median of its longest bounding-box axis; the rows of the
/// smaller side that have a neighbour (an off-diagonal entry of A) on the other side form the separator,
/// ordered after both halves, which are ordered the same way in turn, down to sets of at most 16 rows.
/// Leaves and separators are listed by ascending row, and ties in a coordinate are broken by the row, so
/// the order depends on A's pattern and the points only.
///
/// On a surface mesh the separators are the vertices along a plane's cut, O(sqrt n) of them: on the
/// 737,986-vertex spot_loop3 (free vertices) it orders in 0.2-0.4 s, leaving 45 million entries in L
/// against METIS's 40 million (which takes 3.5 s to order) and AMD's 58 million (0.7 s). A plane through a
/// body's thin limbs cuts poorly: on the 6,890-vertex human AMD leaves fewer (the caller compares).
std::vector<int> coordinate_nested_dissection(const Eigen::SparseMatrix<double>& A,
                                              const Eigen::Matrix<double, Eigen::Dynamic, 3>& points);

}  // namespace mlsdeform::detail
