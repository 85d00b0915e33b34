// coordinate_nested_dissection (nested_dissection.hpp).
#include "core/src/arap/nested_dissection.hpp"

#include <algorithm>
#include <cstddef>
#include <utility>

namespace mlsdeform::detail {

namespace {

constexpr std::size_t kLeaf = 16;  ///< sets this small are ordered as they are (their fill is small)

struct Dissection {
  const Eigen::SparseMatrix<double>& A;
  const Eigen::Matrix<double, Eigen::Dynamic, 3>& X;
  std::vector<int> order;
  std::vector<signed char> side;  ///< during a cut: 0 outside the set, 1 lower half, 2 upper half

  /// Whether row v has a neighbour on side `other`.
  bool touches(int v, signed char other) const {
    for (Eigen::SparseMatrix<double>::InnerIterator it(A, v); it; ++it)
      if (side[std::size_t(it.row())] == other) return true;
    return false;
  }

  /// Orders the rows s[0 .. n) (and reorders s).
  void run(int* s, std::size_t n) {
    if (n <= kLeaf) {
      std::sort(s, s + n);
      order.insert(order.end(), s, s + n);
      return;
    }
    int axis = 0;
    {
      Eigen::RowVector3d lo = X.row(s[0]), hi = lo;
      for (std::size_t k = 1; k < n; ++k) lo = lo.cwiseMin(X.row(s[k])), hi = hi.cwiseMax(X.row(s[k]));
      (hi - lo).maxCoeff(&axis);
    }
    const std::size_t mid = n / 2;
    std::nth_element(s, s + mid, s + n, [&](int a, int b) {
      const double xa = X(a, axis), xb = X(b, axis);
      return xa < xb || (xa == xb && a < b);
    });
    for (std::size_t k = 0; k < n; ++k) side[std::size_t(s[k])] = k < mid ? 1 : 2;
    // The smaller one-sided separator: the lower half's rows touching the upper half, or the reverse.
    std::size_t count[2] = {0, 0};
    for (std::size_t k = 0; k < n; ++k) count[k < mid ? 0 : 1] += touches(s[k], k < mid ? 2 : 1);
    const bool lower = count[0] <= count[1];
    int *first = lower ? s : s + mid, *last = lower ? s + mid : s + n, *kept = first;
    std::vector<int> cut;  // the separator, ordered after both halves
    for (int* p = first; p != last; ++p)
      if (touches(*p, lower ? 2 : 1))
        cut.push_back(*p);
      else
        *kept++ = *p;
    for (std::size_t k = 0; k < n; ++k) side[std::size_t(s[k])] = 0;  // the halves (and stale copies)
    for (const int v : cut) side[std::size_t(v)] = 0;
    std::sort(cut.begin(), cut.end());
    if (lower) {
      run(s, std::size_t(kept - s));
      run(s + mid, n - mid);
    } else {
      run(s, mid);
      run(s + mid, std::size_t(kept - (s + mid)));
    }
    order.insert(order.end(), cut.begin(), cut.end());
  }
};

}  // namespace

std::vector<int> coordinate_nested_dissection(const Eigen::SparseMatrix<double>& A,
                                              const Eigen::Matrix<double, Eigen::Dynamic, 3>& points) {
  const auto n = std::size_t(A.rows());
  Dissection d{A, points, {}, std::vector<signed char>(n, 0)};
  d.order.reserve(n);
  std::vector<int> rows(n);
  for (std::size_t i = 0; i < n; ++i) rows[i] = int(i);
  d.run(rows.data(), n);
  return std::move(d.order);
}

}  // namespace mlsdeform::detail
