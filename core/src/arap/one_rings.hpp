// The ARAP session's mesh structure (arap.hpp documents the weights): cotangent weights per edge, made safe,
// and each vertex's one-ring in CSR form; and the union-find that groups vertices into components.
#pragma once

#include <mlsdeform/arap.hpp>

#include "core/src/threading.hpp"

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <cstddef>
#include <numeric>
#include <vector>

namespace mlsdeform::detail {

/// One-rings, CSR: the neighbours of i are nbr[start[i] .. start[i + 1]) with weights w, ascending.
struct OneRings {
  std::vector<Eigen::Index> start, nbr;
  std::vector<double> w;
  std::size_t clamped = 0;  ///< edges whose cotangent weight was negative, clamped at zero
};

/// A one-ring structure held elsewhere (the refiner's session keeps its own arrays).
struct OneRingsView {
  const std::vector<Eigen::Index>& start;
  const std::vector<Eigen::Index>& nbr;
  const std::vector<double>& w;
};

/// w_ij = (cot alpha + cot beta) / 2 over the triangles sharing the edge (degenerate triangles and repeated
/// corners contribute nothing), clamped below at zero, plus 1e-6 of the mean weight on every edge. Throws
/// std::invalid_argument for a triangle index outside [0, P.rows()). Its large arrays are first touched on
/// `threads` of `arena` (touch_pages, huge_pages.hpp).
OneRings cotangent_one_rings(const Eigen::Matrix<double, Eigen::Dynamic, 3>& P, const Triangles& triangles,
                             int threads = 1, tbb::task_arena* arena = nullptr);

/// The cotangent Laplacian reduced to the free vertices (row[i] >= 0 their row, -1 for a held vertex, in
/// the order of free_vertices, which ascends): L_ii = sum_j w_ij, L_ij = -w_ij between free vertices. `threads`,
/// `arena`: as cotangent_one_rings'.
Eigen::SparseMatrix<double> reduced_laplacian(const OneRingsView& rings, const std::vector<Eigen::Index>& row,
                                              const std::vector<Eigen::Index>& free_vertices, int threads = 1,
                                              tbb::task_arena* arena = nullptr);

/// Union-find with path halving.
struct Disjoint {
  std::vector<Eigen::Index> parent;
  explicit Disjoint(Eigen::Index n) : parent(static_cast<std::size_t>(n)) {
    std::iota(parent.begin(), parent.end(), Eigen::Index(0));
  }
  Eigen::Index find(Eigen::Index i) {
    while (parent[std::size_t(i)] != i) i = parent[std::size_t(i)] = parent[std::size_t(parent[std::size_t(i)])];
    return i;
  }
  void unite(Eigen::Index a, Eigen::Index b) { parent[std::size_t(find(a))] = find(b); }
};

}  // namespace mlsdeform::detail
