// The local frame of the precomputation and the pseudo-handles' rest positions in it.
#pragma once

#include <mlsdeform/deformer.hpp>

#include <Eigen/Core>

#include <cmath>
#include <cstddef>
#include <vector>

namespace mlsdeform::detail {

/// The local frame of the precomputation: the scene (rest vertices and handles) translated to its
/// bounding-box centre and scaled by 2^-e, e = ilogb(diagonal), an exact power of two. Distances in it are
/// O(1): no overflow or underflow, and scaling the scene by a power of two changes nothing at all.
struct LocalFrame {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  int e = 0;
  double size_local = 0;  ///< bounding-box diagonal in local units: in [1, 2), or 0 for a single point

  Eigen::Vector3d local(const Eigen::Vector3d& x) const {
    const Eigen::Vector3d d = x - centre;
    return Eigen::Vector3d(std::ldexp(d[0], -e), std::ldexp(d[1], -e), std::ldexp(d[2], -e));
  }
};

/// The local frame of rest vertices and handles; throws std::invalid_argument when the scene is too large
/// for the precision.
template <class T>
LocalFrame make_local_frame(const Points<T>& vertices, const Handles<T>& handles);

/// Everything the precomputation needs besides the vertices.
struct RestHandles {
  std::vector<Eigen::Vector3d> P;  ///< pseudo-handle rest positions, local frame
  std::size_t k = 0, s = 0;
};

/// Pseudo-handle j's rest position (deformer/data.hpp: points, then each segment's two ends), local frame.
template <class T>
RestHandles make_rest_handles(const Handles<T>& h, const LocalFrame& scene);

}  // namespace mlsdeform::detail
