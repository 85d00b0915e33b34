// The rest-pose precomputation of paper Sec. 5 (what is stored: data.hpp): validation, the local frame, the
// choice of weight storage, then the table (precompute_table.cpp) or the on-the-fly data
// (precompute_on_the_fly.cpp), over blocks of kLanes vertices in parallel.
#pragma once

#include "core/src/deformer/data.hpp"
#include "core/src/deformer/local_frame.hpp"
#include "core/src/threading.hpp"

#include <mlsdeform/deformer.hpp>

namespace mlsdeform::detail {

/// The last `count` point handles keep their rest positions as targets for good (a region's ring): where the
/// weights are precomputed, and there are more than kFoldedHandles of them, they are folded into that many
/// pseudo-handles with the fixed targets `targets` (fold.hpp; data.folded tells). On the fly they stay.
template <class T>
struct FixedHandles {
  std::size_t count = 0;
  Points<T> targets;  ///< fold_targets of those handles
};

/// Validates the rest pose and builds the session data. Throws std::invalid_argument (nothing is changed), or
/// Cancelled when `cancel` asks to stop (checked before each block of kLanes vertices).
template <class T>
DeformerData<T> precompute(const Points<T>& vertices, const Handles<T>& handles, const Options& o,
                           tbb::task_arena* arena, const CancelCheck& cancel, const FixedHandles<T>& fixed = {});

/// The coefficient table (data.table, p_star, vhat, D) of every block; with data.folded > 0 the last
/// data.folded point handles of `handles` are folded into fixed.targets.
template <class T>
void precompute_table(DeformerData<T>& data, const Points<T>& vertices, const LocalFrame& scene, const RestHandles& rh,
                      const Options& o, tbb::task_arena* arena, const CancelCheck& cancel, const Handles<T>& handles,
                      const FixedHandles<T>& fixed);

/// The on-the-fly session data: the rest vertices and handles in the local frame, each vertex's squared
/// distance to its nearest handle (weights are relative to it), and the handle a vertex sits on, if any; with
/// `weights_only` (WeightStorage::precomputed_weights), also each vertex's normalised weights and p*.
template <class T>
void precompute_on_the_fly(DeformerData<T>& data, const Points<T>& vertices, const LocalFrame& scene,
                           const RestHandles& rh, const Options& o, bool weights_only, tbb::task_arena* arena,
                           const CancelCheck& cancel);

}  // namespace mlsdeform::detail
