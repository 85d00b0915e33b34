// The deformer's optional last stage: surface-ARAP iterations over the rest mesh, started from the MLS
// result (Options::arap_iterations; mlsdeform/arap.hpp has the method). The handles constrain the vertices
// nearest to them, held where MLS put them, so that the iterations keep what MLS interpolates.
#pragma once

#include <mlsdeform/arap.hpp>
#include <mlsdeform/deformer.hpp>

#include <memory>
#include <mutex>
#include <vector>

namespace mlsdeform::detail {

template <class T>
struct ArapStage {
  ArapRefiner<T> refiner;
  std::vector<Eigen::Index> constrained;  ///< vertex indices, in handle order, duplicates dropped
  Points<T> mls, targets;                 ///< scratch, sized once
  std::vector<T> rotations;               ///< scratch for the frames: the refined R_i (9 per vertex), sized once
  /// Options::arap_warm_start: the last result (caller's units) and its targets (scaled), sized once; the
  /// jump limit in the caller's units (the rest bounding-box diagonal times arap_warm_start_limit).
  bool warm_start = false, has_last = false, last_was_warm = false;
  double jump = 0;
  Points<T> last, last_targets;
  std::mutex mutex;  ///< deform() is const: concurrent calls take turns on the scratch

  ArapStage(ArapRefiner<T>&& r, std::vector<Eigen::Index> c, Eigen::Index n);

  /// Constrains the rest vertex nearest to each point handle and to each segment handle's two ends; throws
  /// std::invalid_argument on a triangle index out of range.
  static std::unique_ptr<ArapStage> make(const Points<T>& rest_vertices, const Triangles& triangles,
                                         const Handles<T>& rest_handles, const Options& options);

  /// `x` holds MLS's result (n x 3) times 2^-exponent (the deformer's local frame, data.hpp): refined in
  /// place, `iterations` times, into the caller's units (Cancelled: x is left as it was, still scaled). With
  /// warm_start the iterations start from the last result unless the targets jumped (Options::arap_warm_start).
  void run(Points<T>& x, int iterations, int exponent, const CancelCheck& cancel);
};

/// Throws std::invalid_argument unless every index of `triangles` is in [0, n).
void check_triangles(const Triangles& triangles, Eigen::Index n);

}  // namespace mlsdeform::detail
