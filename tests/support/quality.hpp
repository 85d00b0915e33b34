// Shape quality of a deformed triangle mesh against its rest pose: the measures of bench/bench_quality.cpp.
//   local rigidity of vertex i: sqrt(sum_j |e'_j - R_i e_j|^2 / sum_j |e_j|^2) over its one-ring, e_j = p_j - p_i
//     at rest, e'_j = x_j - x_i deformed, R_i = fit_rotation(sum_j e'_j e_j^T) (the best rotation of the ring's
//     edges, unweighted). 0 where the ring moved rigidly; a uniform scale by s gives |s - 1|.
//   edge ratio: deformed / rest length of every edge (each undirected edge once).
//   flipped triangle: its deformed normal n' points against its rest normal n turned by the ring rotation of
//     at least two of its three corners (n' . R_c n < 0 for two or three corners c). The corners' rotations
//     take the local motion out, so a triangle carried along by a large rotation is not flipped, and the
//     two-of-three vote keeps one badly fitted corner from deciding. A flat ring cannot tell a mirror image
//     from a rotation by 180 degrees, so a whole flat region mirrored is not counted; a triangle that folds
//     over its neighbours is. A deformed triangle of zero area (n' = 0) is not counted.
//   dihedral-angle change of an interior edge (one of exactly two triangles): |theta' - theta| in degrees,
//     theta the angle between the two triangles' unit normals at rest, theta' deformed: the smoothness measure
//     of Fig. 8 (tools/cli/figures/measures.cpp's dihedral_change, which the program keeps for itself); a kink
//     shows as a tail of large values along a line of edges.
#pragma once

#include "tests/support/meshes.hpp"

#include <mlsdeform/rotation.hpp>

#include <Eigen/Core>

#include <utility>
#include <vector>

namespace mlsdeform::testing {

/// The sorted neighbours of every vertex through the triangles' edges (empty for a vertex in no triangle).
std::vector<std::vector<int>> one_rings(Eigen::Index vertex_count, const Triangles& triangles);

/// Every undirected edge of the triangles once, as (smaller index, larger index), sorted.
std::vector<std::pair<int, int>> unique_edges(const Triangles& triangles);

/// The p-quantile (0 <= p <= 1) of the values by linear interpolation between the closest ranks
/// (position p (n - 1) in the sorted values, numpy's default). Throws std::invalid_argument when empty.
double quantile(std::vector<double> values, double p);

struct ShapeQuality {
  std::vector<double> rigidity;    ///< per vertex with a non-degenerate one-ring (sum_j |e_j|^2 > 0)
  std::vector<double> edge_ratio;  ///< per unique edge of non-zero rest length
  Eigen::Index flipped = 0;        ///< triangles flipped by the definition above
  Eigen::Index triangles = 0;
};

/// The measures above for `deformed` (same rows as `rest`).
ShapeQuality shape_quality(const PointsD& rest, const PointsD& deformed, const Triangles& triangles);

/// The dihedral-angle change above for every interior edge, in the order of unique_edges (degrees, >= 0).
std::vector<double> dihedral_change(const PointsD& rest, const PointsD& deformed, const Triangles& triangles);

}  // namespace mlsdeform::testing
