// Large arrays on transparent huge pages (Linux). A first touch of fresh memory costs a page fault per 4 KiB
// page; in a virtual machine each fault is a trip through the hypervisor. ARAP's set-up on spot_loop3
// (737,986 vertices) writes more than a gigabyte of new arrays; on the 2-core AMD EPYC Zen 5 development VM
// a profile put a fifth of bench_arap_solver's time in the kernel, mostly in page faults, and with the whole
// process on huge pages (glibc's tunable glibc.malloc.hugetlb=1) the set-up took 3.4 s instead of 6.5. The library
// cannot set a tunable for its caller, so it advises its own large arrays, before their first touch, with
// madvise(MADV_HUGEPAGE): one fault per 2 MiB, and fewer TLB misses when the arrays are read. Where the kernel's THP
// setting is "never", or elsewhere than Linux (emscripten included), this is nothing; the contents are never affected.
//
// First touch in parallel. The kernel zeroes each fresh page in the thread that first writes it, and in a VM
// whose guest memory the host has taken back (as it does with memory freed for a while) each such page is a trip
// through the host as well: on the 2-core AMD EPYC Zen 5 VM, memset of 1 GiB of fresh memory took 2.4-2.7 s on
// one thread after 15 idle seconds and 1.3-1.5 s on two (36-77 ms either way when run back to back). So the
// large arrays of a set-up that may use several threads are first touched by them (touch_pages): spot_loop3's
// ARAP set-up (two threads), 12 idle seconds before each run, 3.7-4.3 -> 3.0-3.3 s; back to back 2.2-2.6 -> 2.0-2.2 s.
#pragma once

#include "core/src/parallel.hpp"

#include <algorithm>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <vector>

#if defined(__linux__) && !defined(__EMSCRIPTEN__)
#include <sys/mman.h>
#endif

namespace mlsdeform::detail {

inline constexpr std::size_t kHugePage = std::size_t(2) << 20;

/// Advises the whole 2 MiB pages inside [p, p + bytes) to be transparent huge pages, where there are at least
/// two (smaller arrays: nothing). Advice only: a refusal changes nothing.
inline void advise_huge_pages(const void* p, std::size_t bytes) {
#if defined(MADV_HUGEPAGE)
  const auto a = reinterpret_cast<std::uintptr_t>(p);
  const std::uintptr_t b = (a + kHugePage - 1) & ~std::uintptr_t(kHugePage - 1),
                       e = (a + bytes) & ~std::uintptr_t(kHugePage - 1);
  if (e >= b + 2 * kHugePage) static_cast<void>(madvise(reinterpret_cast<void*>(b), e - b, MADV_HUGEPAGE));
#else
  static_cast<void>(p), static_cast<void>(bytes);
#endif
}

/// Arrays of at least this many bytes are first touched in parallel (touch_pages) where threads allow.
inline constexpr std::size_t kParallelTouch = std::size_t(8) << 20;

/// Writes one zero byte into each 4 KiB page of the fresh storage [p, p + bytes) (not yet holding any object's
/// value: the caller fills it next), the pages spread over parallel_ranges(threads, arena), so that the kernel
/// (and a VM's host) provide and zero them on all those threads at once (above). Nothing where threads == 1 or
/// the storage is smaller than kParallelTouch.
inline void touch_pages(void* p, std::size_t bytes, int threads, tbb::task_arena* arena) {
  if (threads == 1 || bytes < kParallelTouch) return;
  constexpr std::size_t page = 4096, per_task = kHugePage / page;
  volatile unsigned char* const base = static_cast<unsigned char*>(p);
  const std::size_t pages = (bytes + page - 1) / page;
  parallel_ranges((pages + per_task - 1) / per_task, threads, arena, [&](std::size_t c0, std::size_t c1) {
    for (std::size_t k = c0 * per_task; k < std::min(pages, c1 * per_task); ++k) base[k * page] = 0;
  });
}

/// v = n copies of `value`, in memory advised (advise_huge_pages) before it is first touched: v's old memory
/// is freed first, then fresh memory reserved, advised, touched (touch_pages, on `threads` of `arena`; the
/// default: none, the fill touches it) and filled.
template <class T, class A>
void assign_huge(std::vector<T, A>& v, std::size_t n, const T& value = T(), int threads = 1,
                 tbb::task_arena* arena = nullptr) {
  std::vector<T, A>().swap(v);
  v.reserve(n);
  advise_huge_pages(v.data(), n * sizeof(T));
  touch_pages(v.data(), n * sizeof(T), threads, arena);
  v.assign(n, value);
}

/// A fresh (empty) Eigen::SparseMatrix's index and value arrays resized to n entries, advised (advise_huge_pages)
/// and touched (touch_pages) before the caller fills them: Eigen allocates them without writing them.
template <class Sparse>
void resize_nonzeros_huge(Sparse& m, std::size_t n, int threads = 1, tbb::task_arena* arena = nullptr) {
  assert(m.data().size() == 0);  // the touch writes zeros over what the arrays hold
  m.resizeNonZeros(static_cast<decltype(m.nonZeros())>(n));
  advise_huge_pages(m.innerIndexPtr(), n * sizeof(*m.innerIndexPtr()));
  advise_huge_pages(m.valuePtr(), n * sizeof(*m.valuePtr()));
  touch_pages(m.innerIndexPtr(), n * sizeof(*m.innerIndexPtr()), threads, arena);
  touch_pages(m.valuePtr(), n * sizeof(*m.valuePtr()), threads, arena);
}

}  // namespace mlsdeform::detail
