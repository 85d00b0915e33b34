// The TBB vocabulary the library uses (task_arena, parallel_for, enumerable_thread_specific, the concurrency
// queries), or, with MLSDEFORM_SERIAL (the WebAssembly build: no threads), serial stand-ins under the same
// names. Every caller already gives bitwise the same results for any thread count, so running each range
// whole on the calling thread is the threads == 1 path the native build takes too.
#pragma once

#if MLSDEFORM_SERIAL

#include <functional>
#include <optional>
#include <utility>

namespace tbb {

/// An arena of one thread: execute() runs the work on the caller.
class task_arena {
 public:
  explicit task_arena(int = 1) {}
  int max_concurrency() const { return 1; }
  template <class F>
  void execute(const F& f) {
    f();
  }
};

namespace info {
inline int default_concurrency() { return 1; }
}  // namespace info

namespace this_task_arena {
inline int max_concurrency() { return 1; }
}  // namespace this_task_arena

/// One thread, so one value, made by the factory on first use as TBB's is.
template <class T>
class enumerable_thread_specific {
 public:
  template <class Factory>
  explicit enumerable_thread_specific(Factory factory) : make_(std::move(factory)) {}
  T& local() {
    if (!value_) value_.emplace(make_());
    return *value_;
  }
  void clear() { value_.reset(); }

 private:
  std::function<T()> make_;
  std::optional<T> value_;
};

}  // namespace tbb

#else

#include <tbb/enumerable_thread_specific.h>
#include <tbb/info.h>
#include <tbb/task_arena.h>

#endif
