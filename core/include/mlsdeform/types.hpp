// mlsdeform: shared types.
#pragma once

#include <Eigen/Core>

namespace mlsdeform {

/// n x 3 points, column-major (the libigl convention; already structure-of-arrays in memory: all x, then
/// all y, then all z).
template <class T>
using Points = Eigen::Matrix<T, Eigen::Dynamic, 3>;

/// n x 3 points in row-major order (interleaved xyz, as OpenGL buffers and mesh loaders hold them).
template <class T>
using PointsRowMajor = Eigen::Matrix<T, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// A read-only view of interleaved xyz data (x0 y0 z0 x1 y1 z1 ...), e.g. a mapped vertex buffer.
template <class T>
using ConstInterleavedView = Eigen::Map<const PointsRowMajor<T>>;
/// A writable view of interleaved xyz data.
template <class T>
using InterleavedView = Eigen::Map<PointsRowMajor<T>>;

}  // namespace mlsdeform
