// The library's one TBB driver: the deformer's frames and precomputation (over blocks of kLanes vertices) and
// the batched rotation fit (over chunks of matrices) both run through it, with one arena policy.
#pragma once

#include <mlsdeform/cancel.hpp>

#include "core/src/threading.hpp"

#if !MLSDEFORM_SERIAL
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#endif

#include <cstddef>
#include <memory>

namespace mlsdeform::detail {

/// The arena for Options::threads / fit_rotations' `threads`: 0 = TBB's default arena (all cores, nullptr);
/// 1 = serial, no TBB at all (nullptr); more = an arena of that many, capped at the hardware's (TBB would
/// ignore the excess anyway, with a warning on stderr).
std::unique_ptr<tbb::task_arena> make_arena(int threads);

/// Throws Cancelled if the caller's check (cancel.hpp) asks to stop; nothing to check when it is empty.
inline void throw_if_cancelled(const CancelCheck& cancel) {
  if (cancel && cancel()) throw Cancelled();
}

/// How parallel_ranges cuts its range: `balanced`, TBB's auto_partitioner (work stealing, for work that varies
/// from index to index); `fixed`, TBB's static_partitioner (one even piece per thread, the same pieces on every
/// call with the same count and arena: for uniform work repeated on the same data, such as a session's frames,
/// where each thread then finds its piece's data in its own core's cache).
enum class Split { balanced, fixed };

/// Calls f(begin, end) on sub-ranges covering [0, count): once with the whole range when threads == 1 or
/// count <= 1 (always in the serial build, core/src/threading.hpp), else from tbb::parallel_for (in `arena` if given,
/// else the calling thread's arena). Each index's work must not depend on how the range is cut (every caller's results
/// are bitwise the same for any thread count).
template <class F>
void parallel_ranges(std::size_t count, int threads, tbb::task_arena* arena, const F& f,
                     Split split = Split::balanced) {
  if (count == 0) return;
#if MLSDEFORM_SERIAL
  (void)threads, (void)arena, (void)split;
  f(std::size_t(0), count);
#else
  if (threads == 1 || count == 1) {
    f(std::size_t(0), count);
    return;
  }
  const tbb::blocked_range<std::size_t> all(0, count);
  const auto body = [&](const tbb::blocked_range<std::size_t>& r) { f(r.begin(), r.end()); };
  auto run = [&] {
    if (split == Split::fixed)
      tbb::parallel_for(all, body, tbb::static_partitioner());
    else
      tbb::parallel_for(all, body);
  };
  if (arena)
    arena->execute(run);
  else
    run();
#endif
}

}  // namespace mlsdeform::detail
