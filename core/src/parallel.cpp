#include "core/src/parallel.hpp"
#include "core/src/threading.hpp"

#include <algorithm>

namespace mlsdeform::detail {

std::unique_ptr<tbb::task_arena> make_arena(int threads) {
  const int cap = tbb::info::default_concurrency();
  if (threads > 1 && cap > 1) return std::make_unique<tbb::task_arena>(std::min(threads, cap));
  return nullptr;
}

}  // namespace mlsdeform::detail
