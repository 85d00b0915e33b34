// Large arrays on transparent huge pages (Linux). A first touch of fresh memory costs a page fault per 4 KiB
// page; in a virtual machine each fault is a trip through the hypervisor. ARAP's set-up on spot_loop3
// (737,986 vertices) writes more than a gigabyte of new arrays; on the 2-core AMD EPYC Zen 5 development VM
// a profile put a fifth of bench_arap_solver's time in the kernel, mostly in page faults, and with the whole
// process on huge pages (glibc's tunable glibc.malloc.hugetlb=1) the set-up took 3.4 s instead of 6.5. The library
// cannot set a tunable for its caller, so it advises its own large arrays, before their first touch, with
// madvise(MADV_HUGEPAGE): one fault per 2 MiB, and fewer TLB misses when the arrays are read. Where the kernel's THP
// setting is "never", or elsewhere than Linux (emscripten included), this is nothing; the contents are never affected.
#pragma once

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

/// v = n copies of `value`, in memory advised (advise_huge_pages) before it is first touched: v's old memory
/// is freed first, then fresh memory reserved, advised and filled.
template <class T, class A>
void assign_huge(std::vector<T, A>& v, std::size_t n, const T& value = T()) {
  std::vector<T, A>().swap(v);
  v.reserve(n);
  advise_huge_pages(v.data(), n * sizeof(T));
  v.assign(n, value);
}

/// An Eigen::SparseMatrix's index and value arrays resized to n entries and advised (advise_huge_pages) before
/// their first touch: Eigen allocates them without writing them; the caller fills them.
template <class Sparse>
void resize_nonzeros_huge(Sparse& m, std::size_t n) {
  m.resizeNonZeros(static_cast<decltype(m.nonZeros())>(n));
  advise_huge_pages(m.innerIndexPtr(), n * sizeof(*m.innerIndexPtr()));
  advise_huge_pages(m.valuePtr(), n * sizeof(*m.valuePtr()));
}

}  // namespace mlsdeform::detail
