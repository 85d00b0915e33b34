// The sparse solver tests' own header (tests/test_subtree_ldlt.cpp, tests/test_orderings.cpp): symmetric
// positive definite test matrices with the structure of the ARAP global step's (graph Laplacians of meshes
// plus a positive diagonal, both triangles stored) and their rows' points.
#pragma once

#include "tests/support/random.hpp"

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <vector>

namespace mlsdeform::testing {

using Sparse = Eigen::SparseMatrix<double>;

/// A weighted graph Laplacian plus a positive diagonal: `pieces` grids of rows x cols vertices (4-neighbour
/// edges and one diagonal per cell), plus `extra` random edges inside each piece; weights in [0.1, 1],
/// shifts in [1e-3, 1e-2]. The pieces share no edge: the elimination forest has several trees.
inline Sparse spd(Rng& g, int pieces, int rows, int cols, int extra) {
  const int per = rows * cols, n = pieces * per;
  std::vector<Eigen::Triplet<double>> t;
  const auto edge = [&](int a, int b) {
    const double w = g.uniform<double>(0.1, 1.0);
    t.emplace_back(a, b, -w), t.emplace_back(b, a, -w), t.emplace_back(a, a, w), t.emplace_back(b, b, w);
  };
  for (int p = 0; p < pieces; ++p) {
    const int o = p * per;
    for (int i = 0; i < rows; ++i)
      for (int j = 0; j < cols; ++j) {
        const int v = o + i * cols + j;
        if (j + 1 < cols) edge(v, v + 1);
        if (i + 1 < rows) edge(v, v + cols);
        if (i + 1 < rows && j + 1 < cols) edge(v, v + cols + 1);
      }
    for (int e = 0; e < extra && per > 1; ++e) {
      const int a = o + int(g.uniform<double>(0, per - 1e-9)), b = o + int(g.uniform<double>(0, per - 1e-9));
      if (a != b) edge(a, b);
    }
  }
  for (int v = 0; v < n; ++v) t.emplace_back(v, v, g.uniform<double>(1e-3, 1e-2));
  Sparse A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

/// The rows' points for spd(pieces, rows, cols): piece p's grid in the plane z = p, cell (i, j) at (j, i).
inline Eigen::Matrix<double, Eigen::Dynamic, 3> grid_points(int pieces, int rows, int cols) {
  Eigen::Matrix<double, Eigen::Dynamic, 3> x(Eigen::Index(pieces) * rows * cols, 3);
  for (int p = 0; p < pieces; ++p)
    for (int i = 0; i < rows; ++i)
      for (int j = 0; j < cols; ++j) x.row((Eigen::Index(p) * rows + i) * cols + j) << j, i, p;
  return x;
}

}  // namespace mlsdeform::testing
