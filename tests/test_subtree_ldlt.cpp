// detail::SubtreeLdlt (core/src/arap/subtree_ldlt.hpp), the ARAP global step's solver, on its own: the
// same bits for any number of parts (the schedule) and any thread count, and a residual within the
// backward-error bound of an LDL^T solve.
//
// The bound: Eigen factors P A P^T = L D L^T (no pivoting; A is symmetric positive definite), and the
// solve runs forward substitution, the diagonal and backward substitution with the computed factors, each
// an inner product of at most w terms, w = 1 + the most entries in a row or column of L. By the standard
// analysis (Higham, "Accuracy and Stability of Numerical Algorithms", 2nd ed., Thm 8.5 for the triangular
// solves and Thm 10.3 for the factorisation, with the inner products' lengths for n), the computed x solves
// (A + dA) x = b with |dA| <= gamma_{3w+2} P^T |L| |D| |L^T| P, gamma_k = k eps / (1 - k eps): so
// |b - A x| <= gamma_{3w+2} P^T |L| |D| |L^T| P |x| componentwise, which the test checks in long double.
#include "arap/subtree_ldlt.hpp"
#include "random.hpp"

#include <catch2/catch.hpp>

#include <cstring>
#include <limits>
#include <vector>

using mlsdeform::detail::SubtreeLdlt;
using mlsdeform::testing::Rng;
using LD = long double;
using Sparse = Eigen::SparseMatrix<double>;

namespace {

/// A weighted graph Laplacian plus a positive diagonal: `pieces` grids of rows x cols vertices (4-neighbour
/// edges and one diagonal per cell), plus `extra` random edges inside each piece; weights in [0.1, 1],
/// shifts in [1e-3, 1e-2]. The pieces share no edge: the elimination forest has several trees.
Sparse spd(Rng& g, int pieces, int rows, int cols, int extra) {
  const int per = rows * cols, n = pieces * per;
  std::vector<Eigen::Triplet<double>> t;
  const auto edge = [&](int a, int b) {
    const double w = g.uniform<double>(0.1, 1.0);
    t.emplace_back(a, b, -w), t.emplace_back(b, a, -w), t.emplace_back(a, a, w), t.emplace_back(b, b, w);
  };
  for (int p = 0; p < pieces; ++p) {
    const int o = p * per;
    for (int i = 0; i < rows; ++i)
      for (int j = 0; j < cols; ++j) {
        const int v = o + i * cols + j;
        if (j + 1 < cols) edge(v, v + 1);
        if (i + 1 < rows) edge(v, v + cols);
        if (i + 1 < rows && j + 1 < cols) edge(v, v + cols + 1);
      }
    for (int e = 0; e < extra && per > 1; ++e) {
      const int a = o + int(g.uniform<double>(0, per - 1e-9)), b = o + int(g.uniform<double>(0, per - 1e-9));
      if (a != b) edge(a, b);
    }
  }
  for (int v = 0; v < n; ++v) t.emplace_back(v, v, g.uniform<double>(1e-3, 1e-2));
  Sparse A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

/// y for b: 3 values per row of A at 3 * row_of(i).
std::vector<double> packed(const SubtreeLdlt& s, const Eigen::MatrixX3d& b) {
  std::vector<double> y(3 * std::size_t(b.rows()));
  for (Eigen::Index i = 0; i < b.rows(); ++i)
    for (int k = 0; k < 3; ++k) y[3 * std::size_t(s.row_of(i)) + std::size_t(k)] = b(i, k);
  return y;
}

}  // namespace

TEST_CASE("SubtreeLdlt: the same bits for any schedule and thread count, residual within the LDL^T bound",
          "[arap][ldlt]") {
  Rng g(20261124);
  struct Shape {
    int pieces, rows, cols, extra;
  };
  for (const Shape sh : {Shape{1, 1, 1, 0}, Shape{1, 1, 2, 0}, Shape{3, 1, 1, 0}, Shape{1, 7, 9, 5},
                         Shape{4, 10, 12, 20}, Shape{2, 45, 50, 200}}) {
    const Sparse A = spd(g, sh.pieces, sh.rows, sh.cols, sh.extra);
    const Eigen::Index n = A.rows();
    INFO("n = " << n << ", " << sh.pieces << " pieces");
    Eigen::MatrixX3d b(n, 3);
    for (Eigen::Index i = 0; i < n; ++i)
      for (int k = 0; k < 3; ++k) b(i, k) = g.uniform<double>(-1, 1);

    SubtreeLdlt ref;
    REQUIRE(ref.compute(A, 1));
    std::vector<double> y1 = packed(ref, b);
    ref.solve(y1, 1, nullptr);
    for (const std::size_t bins : {2, 3, 5, 8})
      for (const int threads : {1, 0}) {
        SubtreeLdlt s;
        REQUIRE(s.compute(A, bins));
        std::vector<double> y = packed(s, b);
        s.solve(y, threads, nullptr);
        INFO("bins " << bins << ", threads " << threads);
        CHECK(std::memcmp(y.data(), y1.data(), sizeof(double) * y.size()) == 0);
      }

    // The bound of the file comment, from Eigen's factors of the same A (the same deterministic factorisation).
    Eigen::SimplicialLDLT<Sparse> f(A);
    REQUIRE(f.info() == Eigen::Success);
    const Sparse& L = f.matrixL().nestedExpression();  // strictly lower, by columns; P A P^T = L D L^T
    const Eigen::VectorXd D = f.vectorD();
    std::vector<int> count(static_cast<std::size_t>(n), 0);
    int w = 1;
    for (Eigen::Index c = 0; c < n; ++c) {
      w = std::max(w, int(L.outerIndexPtr()[c + 1] - L.outerIndexPtr()[c]) + 1);
      for (Sparse::InnerIterator it(L, c); it; ++it) w = std::max(w, ++count[std::size_t(it.row())] + 1);
    }
    const LD u = std::numeric_limits<double>::epsilon() / 2, k = 3 * w + 2, gamma = k * u / (1 - k * u);
    LD worst = 0;
    for (int col = 0; col < 3; ++col) {
      // x in the factor's order (x_p[row_of(i)] = x_i), then |L| |D| |L^T| |x_p|.
      const auto size = std::size_t(n);
      std::vector<LD> xp(size, 0), t(size, 0), m(size, 0);
      for (Eigen::Index r = 0; r < n; ++r) xp[std::size_t(r)] = std::abs(LD(y1[3 * std::size_t(r) + std::size_t(col)]));
      for (Eigen::Index c = 0; c < n; ++c) {  // t = |L^T| xp: t_c = xp_c + sum_r |L_rc| xp_r
        t[std::size_t(c)] = xp[std::size_t(c)];
        for (Sparse::InnerIterator it(L, c); it; ++it)
          t[std::size_t(c)] += std::abs(LD(it.value())) * xp[std::size_t(it.row())];
      }
      for (Eigen::Index c = 0; c < n; ++c) t[std::size_t(c)] *= std::abs(LD(D(c)));
      for (Eigen::Index c = 0; c < n; ++c) {  // m = |L| t: m_c += t_c, m_r += |L_rc| t_c
        m[std::size_t(c)] += t[std::size_t(c)];
        for (Sparse::InnerIterator it(L, c); it; ++it)
          m[std::size_t(it.row())] += std::abs(LD(it.value())) * t[std::size_t(c)];
      }
      for (Eigen::Index i = 0; i < n; ++i) {  // residual of row i of A, in long double
        LD r = b(i, col);
        for (Sparse::InnerIterator it(A, i); it; ++it)  // A is symmetric: column i is row i
          r -= LD(it.value()) * LD(y1[3 * std::size_t(ref.row_of(it.row())) + std::size_t(col)]);
        const LD bound = gamma * m[std::size_t(ref.row_of(i))];
        worst = std::max(worst, std::abs(r) / bound);
        if (!(std::abs(r) <= bound))
          FAIL_CHECK("row " << i << " column " << col << ": residual " << double(r) << " > bound " << double(bound));
      }
    }
    INFO("worst residual / bound " << double(worst));
    CHECK(worst <= 1);
  }
}
