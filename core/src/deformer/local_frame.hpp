// The local frame of the precomputation and the pseudo-handles' rest positions in it.
#pragma once

#include <mlsdeform/deformer.hpp>

#include <Eigen/Core>

#include <cmath>
#include <cstddef>
#include <vector>

namespace mlsdeform::detail {

/// The local frame of the precomputation: the scene (rest vertices and handles) translated to the centre of the
/// handles' bounding box and scaled by 2^-e, e = ilogb(diagonal of the whole scene's box), an exact power of two.
/// Distances in it are O(1) (every point is within the diagonal of the handles' centre: |local| < 2): no overflow
/// or underflow, and scaling the scene by a power of two changes nothing at all. The origin is the handles', not
/// the scene's box's: the on-the-fly storages keep the rest vertices and handles in T in this frame, where a stray
/// vertex far from the model would otherwise move the origin away from every handle, and round every vertex near
/// them to the spacing of T at that distance (a stray at 3,000 diagonals cost 1e-4 of the diagonal in float). The box's
/// centre and diagonal, and the translation, are computed on the coordinates scaled by 2^-e0 (e0 the exponent
/// of the largest), so that this holds for subnormal coordinates too; in the normal range every such scaling
/// is exact, and local(x) is (x - centre) 2^-e to the bit.
struct LocalFrame {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  ///< the box's centre, in the caller's units (rounded)
  int e = 0;
  double size_local = 0;  ///< bounding-box diagonal in local units: in [1, 2), or 0 for a single point
  int e0 = 0;             ///< the exponent of the largest coordinate
  Eigen::Vector3d centre0 = Eigen::Vector3d::Zero();  ///< the box's centre times 2^-e0

  Eigen::Vector3d local(const Eigen::Vector3d& x) const {
    Eigen::Vector3d r;
    for (int c = 0; c < 3; ++c) r[c] = std::ldexp(std::ldexp(x[c], -e0) - centre0[c], e0 - e);
    return r;
  }
};

/// The local frame of rest vertices and handles; throws std::invalid_argument when the scene is too large
/// for the precision, or smaller than its smallest normal number (the scales 2^-e and 2^e the kernels
/// multiply by must both be numbers of T).
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
