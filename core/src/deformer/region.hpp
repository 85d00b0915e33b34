// A region of interest (Options::region): only the named vertices move, every other vertex keeps its rest
// position bitwise. The region's rest vertices are compacted into their own point set, which the
// precomputation and the kernels see as the whole model; the result is scattered into the output, the other
// vertices copied from the rest pose. Continuity across the region's border: the ring of outside vertices
// next to the region becomes fixed point handles at their rest positions (targets = rest positions), which
// MLS interpolates (Sec. 3: f(p_i) = q_i), so region vertices approaching the ring approach their rest
// positions. Their targets never change, so where the weights are precomputed the ring's handles are folded
// into four (fold.hpp): a frame costs the caller's handles plus four, however long the ring (a region chosen
// by index range can have a ring of thousands).
#pragma once

#include "core/src/deformer/precompute.hpp"

#include <mlsdeform/arap.hpp>
#include <mlsdeform/deformer.hpp>

#include <cstddef>
#include <memory>
#include <mutex>
#include <vector>

namespace mlsdeform::detail {

/// Without triangles, an outside vertex is on the ring when it is among the kRingNeighbours nearest
/// vertices of some region vertex.
inline constexpr int kRingNeighbours = 8;

template <class T>
struct RegionStage {
  Eigen::Index n = 0;                 ///< vertices of the whole model
  std::vector<Eigen::Index> inside;   ///< the region, ascending: compact vertex r is model vertex inside[r]
  std::vector<Eigen::Index> outside;  ///< the other vertices, ascending
  Points<T> rest_inside;              ///< the region's rest vertices (the precomputation's model)
  Points<T> rest_outside;             ///< copied into every output
  Handles<T> rest_handles;            ///< the caller's handles, then the ring's fixed points
  Eigen::Index user_points = 0;       ///< the caller's point handles: rest_handles.points.topRows(user_points)
  Points<T> fold_targets;             ///< the ring folded (fold.hpp): 4 targets; empty for a ring of 4 or fewer
  Handles<T> moved;                   ///< scratch: the caller's targets, then the ring at rest or folded
  Points<T> compact;                  ///< scratch: the kernels' output over the region
  std::mutex mutex;                   ///< deform() is const: concurrent calls take turns on the scratch

  /// Checks the region's indices (std::invalid_argument: out of range, repeated), finds the ring (outside
  /// vertices sharing a triangle with a region vertex; without triangles, among the kRingNeighbours nearest
  /// vertices of a region vertex) and adds a fixed point handle at each ring vertex's rest position, once
  /// per position, and none where the caller has a point handle or segment end already. `cancel` is checked
  /// before each region vertex's scan (without triangles).
  static std::unique_ptr<RegionStage> make(const Points<T>& rest_vertices, const Triangles& triangles,
                                           const Handles<T>& rest_handles, const Options& options,
                                           const CancelCheck& cancel);

  /// The fixed point handles added at the ring.
  Eigen::Index ring_handles() const { return rest_handles.points.rows() - user_points; }
  /// The ring as precompute() may fold it (precompute.hpp).
  FixedHandles<T> fixed() const { return {std::size_t(ring_handles()), fold_targets}; }
  /// After precompute(): `moved` ends with the ring's targets as the table has them (folded or not).
  void set_folded(bool folded);

  /// `moved` with the caller's targets (same counts as the rest handles: checked by the caller).
  void set_targets(const Handles<T>& user);
  /// Writes the whole model from `compact` and the rest pose: vertex v, coordinate c at
  /// out[c * cstride + v * vstride].
  void scatter(T* out, std::size_t vstride, std::size_t cstride) const;
  std::size_t bytes() const;
};

}  // namespace mlsdeform::detail
