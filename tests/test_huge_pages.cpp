// core/src/huge_pages.hpp: the set-ups' large arrays, advised to be huge pages and first touched on the
// session's threads (touch_pages writes a zero byte into each 4 KiB page of the fresh storage before the fill).
// The contents must be exactly the fill, whatever the threads and sizes (a touch after the fill, or past the
// storage, shows here, the latter under the sanitizers), and a sparse matrix's arrays keep what the caller
// writes into them.
#include "core/src/huge_pages.hpp"

#include <Eigen/SparseCore>

#include "tests/support/catch.hpp"

#include <algorithm>
#include <cstddef>
#include <vector>

using mlsdeform::detail::assign_huge;
using mlsdeform::detail::kParallelTouch;
using mlsdeform::detail::make_arena;
using mlsdeform::detail::resize_nonzeros_huge;

TEST_CASE("assign_huge: n copies of the value for any threads, below and above the parallel touch", "[huge]") {
  const std::size_t big = kParallelTouch / sizeof(double);
  for (const int threads : {1, 2, 0})
    for (const std::size_t n : {std::size_t(0), std::size_t(1000), big - 1, big, big + 513, 3 * big + 7}) {
      INFO("threads " << threads << ", n = " << n);
      const auto arena = make_arena(threads);
      std::vector<double> v(17, -1.0);  // old contents, freed first
      assign_huge(v, n, 3.5, threads, arena.get());
      REQUIRE(v.size() == n);
      CHECK(std::count(v.begin(), v.end(), 3.5) == std::ptrdiff_t(n));
      std::vector<int> w;
      assign_huge(w, 2 * n + 1, 7, threads, arena.get());
      CHECK(std::count(w.begin(), w.end(), 7) == std::ptrdiff_t(2 * n + 1));
    }
}

TEST_CASE("resize_nonzeros_huge: a fresh matrix's arrays hold what the caller writes", "[huge]") {
  const std::size_t n = 3 * kParallelTouch / sizeof(double) + 11;
  for (const int threads : {1, 2}) {
    INFO("threads " << threads);
    const auto arena = make_arena(threads);
    Eigen::SparseMatrix<double> m(Eigen::Index(n), 1);
    resize_nonzeros_huge(m, n, threads, arena.get());
    REQUIRE(std::size_t(m.data().size()) == n);
    for (std::size_t k = 0; k < n; ++k) m.innerIndexPtr()[k] = int(k), m.valuePtr()[k] = double(k) + 0.25;
    m.outerIndexPtr()[0] = 0, m.outerIndexPtr()[1] = int(n);
    std::size_t right = 0;
    for (Eigen::SparseMatrix<double>::InnerIterator it(m, 0); it; ++it) right += it.value() == double(it.row()) + 0.25;
    CHECK(right == n);
  }
}
