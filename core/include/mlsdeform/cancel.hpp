// mlsdeform: stopping a long call from outside it (a user's Ctrl-C, a deadline, a closed window).
#pragma once

#include <functional>
#include <stdexcept>

namespace mlsdeform {

/// A caller's request to stop a long call: the Deformer's construction and reset_rest_pose (checked between
/// blocks of kLanes vertices of the precomputation, and of the region's ring search), deform() (before every
/// 64 blocks of its MLS pass and every ARAP iteration) and ArapRefiner::refine (before every iteration). It may be
/// called from several of the library's worker threads at once, so it must be thread-safe, and it is called often
/// (every block), so it should be cheap: an atomic load, or a clock read that does more only now and then. Once it
/// returns true the call throws Cancelled as soon as each worker has finished its current block, with the
/// strong guarantee: the session and the caller's output are as they were before the call (one exception:
/// deform() without ARAP writes its output directly, and may leave it partly written: deformer.hpp). Empty
/// (the default): never cancelled, and nothing is checked.
using CancelCheck = std::function<bool()>;

/// Thrown by a call whose CancelCheck returned true.
class Cancelled : public std::runtime_error {
 public:
  Cancelled();
  ~Cancelled() override;
};

}  // namespace mlsdeform
