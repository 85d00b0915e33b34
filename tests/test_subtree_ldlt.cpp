// detail::SubtreeLdlt (core/src/arap/subtree_ldlt.hpp), the ARAP global step's solver, on its own, with
// each factorisation the build has: the same bits for any number of parts (the schedule) and any thread
// count, and a residual within the backward-error bound of the L D L^T solve.
//
// The bound, with u = eps / 2, gamma_k = k u / (1 - k u), and w = 1 + the most entries in a row or column of
// L (every inner product below has at most w terms; terms that are exact zeros add no rounding).
// - Simplicial: Eigen factors P A P^T = L D L^T (no pivoting; A is symmetric positive definite). By the
//   standard analysis (Higham, "Accuracy and Stability of Numerical Algorithms", 2nd ed., Thm 8.5 for the
//   triangular solves and Thm 10.3 for the factorisation), the computed x solves (A + dA) x = b with
//   |dA| <= gamma_{3w+2} P^T |L| |D| |L^T| P.
// - Supernodal (CHOLMOD's, and ours, supernodal_ldlt.hpp, by Eigen's dense LLT, triangular solve and
//   products on the blocks): computes P A P^T + E1 = G G^T with |E1| <= gamma_{w+1} |G| |G^T| (Thm 10.3, for any
//   order of the inner products, so for blocked BLAS too), then D_c = fl(G_cc^2) and L_rc = fl(G_rc / G_cc),
//   one rounding each: L D L^T = G G^T + E2 with |E2| <= gamma_3 |L| |D| |L^T|, and |G| |G^T| <=
//   (1 + gamma_3) |L| |D| |L^T|. The solve with L, D, L^T adds gamma_{2w+1} |L| |D| |L^T| (as above).
//   Altogether (gamma_a + gamma_b + gamma_a gamma_b <= gamma_{a+b}): |dA| <= gamma_{3w+6} P^T |L| |D| |L^T| P.
// So |b - A x| <= gamma_k P^T |L| |D| |L^T| P |x| componentwise, k as above, which the test checks in long
// double with the solver's own L and D.
#include "core/src/arap/subtree_ldlt.hpp"
#include "tests/test_ldlt_common.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>
#include "tests/support/catch.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <vector>

using mlsdeform::detail::SubtreeLdlt;
using mlsdeform::testing::grid_points;
using mlsdeform::testing::Rng;
using mlsdeform::testing::spd;
using LD = long double;
using mlsdeform::testing::Sparse;

namespace {

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
  using Method = SubtreeLdlt::Method;
  // supernodal_mit three times: substituted by its blocks (column_limit 0) and converted to columns (any limit
  // at least its size: these matrices are all small); and with every supernode of 16 columns or more taking its
  // updates 8 columns at a time (split_columns 16: by default only supernodes of 256, which only the last
  // shape's top has), so that the chunks' bounds fall everywhere: on supernodes with rows below their
  // columns, and inside descendants' updates.
  struct Variant {
    Method method;
    std::size_t column_limit;
    int split_columns;
  };
  constexpr std::size_t blocks = 0, columns = SubtreeLdlt::kColumnLimit;
  constexpr int whole = mlsdeform::detail::kSplitColumns, chunked = 16;
  std::vector<Variant> variants{{Method::simplicial, columns, whole},
                                {Method::supernodal_mit, blocks, whole},
                                {Method::supernodal_mit, columns, whole},
                                {Method::supernodal_mit, columns, chunked}};
  if (mlsdeform::detail::supernodal_available())
    variants.push_back({Method::supernodal, columns, whole});
  else
    WARN("this build has no supernodal factorisation (MLSDEFORM_CHOLMOD=OFF): simplicial only");
  for (const auto [method, column_limit, split_columns] : variants) {
    const bool supernodal = method != Method::simplicial;
    // The supernodal factorisations in the order of coordinate_nested_dissection (as ArapRefiner gives the
    // rows' points) and, where no points are given, in AMD's order (CHOLMOD's, or Eigen's for ours).
    for (const bool with_points : supernodal ? std::vector<bool>{true, false} : std::vector<bool>{false}) {
      Rng g(20261124);
      struct Shape {
        int pieces, rows, cols, extra;
      };
      for (const Shape sh :
           {Shape{1, 1, 1, 0}, Shape{1, 1, 2, 0}, Shape{3, 1, 1, 0}, Shape{1, 7, 9, 5}, Shape{4, 10, 12, 20},
            Shape{2, 45, 50, 200},
            Shape{1, 40, 40, 1500}}) {  // the last: random edges, a dense top (blocks shared by threads)
        const Sparse A = spd(g, sh.pieces, sh.rows, sh.cols, sh.extra);
        const Eigen::Index n = A.rows();
        const auto points = grid_points(sh.pieces, sh.rows, sh.cols);
        const auto* x = with_points ? &points : nullptr;
        INFO((method == Method::supernodal_mit
                  ? (column_limit == blocks ? "supernodal_mit (blocks)" : "supernodal_mit (columns)")
              : supernodal ? "supernodal"
                           : "simplicial")
             << (with_points ? " (points)" : "") << ", split_columns " << split_columns << ", n = " << n << ", "
             << sh.pieces << " pieces");
        Eigen::MatrixX3d b(n, 3);
        for (Eigen::Index i = 0; i < n; ++i)
          for (int k = 0; k < 3; ++k) b(i, k) = g.uniform<double>(-1, 1);

        SubtreeLdlt ref;
        REQUIRE(ref.compute(A, 1, method, x, column_limit, split_columns));
        std::vector<double> y1 = packed(ref, b);
        ref.solve(y1, 1, nullptr);
        for (const std::size_t bins : {2, 3, 5, 8})
          for (const int threads : {1, 0}) {
            SubtreeLdlt s;
            REQUIRE(s.compute(A, bins, method, x, column_limit, split_columns));
            std::vector<double> y = packed(s, b);
            s.solve(y, threads, nullptr);
            INFO("bins " << bins << ", threads " << threads);
            CHECK(std::memcmp(y.data(), y1.data(), sizeof(double) * y.size()) == 0);
          }

        // The bound of the file comment, from the solver's own factor.
        const SubtreeLdlt::Factor f = ref.factor();
        REQUIRE(f.D.size() == std::size_t(n));
        const auto column = [&](Eigen::Index c, auto&& visit) {  // visit(row, L_rc) for column c's entries
          for (int p = f.col_start[std::size_t(c)]; p < f.col_start[std::size_t(c) + 1]; ++p)
            visit(Eigen::Index(f.rows[std::size_t(p)]), f.values[std::size_t(p)]);
        };
        std::vector<int> count(static_cast<std::size_t>(n), 0);
        int w = 1;
        for (Eigen::Index c = 0; c < n; ++c) {
          w = std::max(w, f.col_start[std::size_t(c) + 1] - f.col_start[std::size_t(c)] + 1);
          column(c, [&](Eigen::Index r, double) {
            REQUIRE(r > c);  // strictly lower
            w = std::max(w, ++count[std::size_t(r)] + 1);
          });
        }
        const LD u = std::numeric_limits<double>::epsilon() / 2, k = supernodal ? 3 * w + 6 : 3 * w + 2;
        const LD gamma = k * u / (1 - k * u);
        LD worst = 0;
        for (int col = 0; col < 3; ++col) {
          // x in the factor's order (x_p[row_of(i)] = x_i), then |L| |D| |L^T| |x_p|.
          const auto size = std::size_t(n);
          std::vector<LD> xp(size, 0), t(size, 0), m(size, 0);
          for (Eigen::Index r = 0; r < n; ++r)
            xp[std::size_t(r)] = std::abs(LD(y1[3 * std::size_t(r) + std::size_t(col)]));
          for (Eigen::Index c = 0; c < n; ++c) {  // t = |L^T| xp: t_c = xp_c + sum_r |L_rc| xp_r
            t[std::size_t(c)] = xp[std::size_t(c)];
            column(c, [&](Eigen::Index r, double v) { t[std::size_t(c)] += std::abs(LD(v)) * xp[std::size_t(r)]; });
          }
          for (Eigen::Index c = 0; c < n; ++c) t[std::size_t(c)] *= std::abs(LD(f.D[std::size_t(c)]));
          for (Eigen::Index c = 0; c < n; ++c) {  // m = |L| t: m_c += t_c, m_r += |L_rc| t_c
            m[std::size_t(c)] += t[std::size_t(c)];
            column(c, [&](Eigen::Index r, double v) { m[std::size_t(r)] += std::abs(LD(v)) * t[std::size_t(c)]; });
          }
          for (Eigen::Index i = 0; i < n; ++i) {  // residual of row i of A, in long double
            LD r = b(i, col);
            for (Sparse::InnerIterator it(A, i); it; ++it)  // A is symmetric: column i is row i
              r -= LD(it.value()) * LD(y1[3 * std::size_t(ref.row_of(it.row())) + std::size_t(col)]);
            const LD bound = gamma * m[std::size_t(ref.row_of(i))];
            worst = std::max(worst, std::abs(r) / bound);
            if (!(std::abs(r) <= bound))
              FAIL_CHECK("row " << i << " column " << col << ": residual " << double(r) << " > bound "
                                << double(bound));
          }
        }
        INFO("worst residual / bound " << double(worst));
        CHECK(worst <= 1);
      }
    }
  }
}

namespace {

/// The reduced Laplacian of ArapRefiner's global step on `pieces` grids of rows x cols vertices (edges as in
/// spd(), weights in [0.1, 1], no shift), each with `held` random vertices constrained: their rows and
/// columns removed, their edges left on their neighbours' diagonals. Every piece keeps a constrained vertex,
/// so the matrix is positive definite, its conditioning that of a grid held at a few points. `points`: the
/// free rows' points (grid_points's).
Sparse reduced_laplacian(Rng& g, int pieces, int rows, int cols, int held,
                         Eigen::Matrix<double, Eigen::Dynamic, 3>& points) {
  const Sparse full = spd(g, pieces, rows, cols, 0);
  const auto all = grid_points(pieces, rows, cols);
  const int per = rows * cols;
  std::vector<int> row(std::size_t(pieces * per), 0);
  for (int p = 0; p < pieces; ++p)
    for (int h = 0; h < held; ++h) row[std::size_t(p * per + int(g.uniform<double>(0, per - 1e-9)))] = -1;
  int nf = 0;
  for (int& r : row) r = r < 0 ? -1 : nf++;
  std::vector<Eigen::Triplet<double>> t;
  points.resize(nf, 3);
  for (int c = 0; c < full.outerSize(); ++c) {
    if (row[std::size_t(c)] < 0) continue;
    points.row(row[std::size_t(c)]) = all.row(c);
    for (Sparse::InnerIterator it(full, c); it; ++it) {
      const int r = row[std::size_t(it.row())];
      // spd()'s shift of the diagonal is dropped: the diagonal is minus the sum of the off-diagonal row
      if (it.row() == c) continue;
      t.emplace_back(row[std::size_t(c)], row[std::size_t(c)], -it.value());
      if (r >= 0) t.emplace_back(r, row[std::size_t(c)], it.value());
    }
  }
  Sparse A(nf, nf);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

/// max_i (|L| |D| |L^T| 1)_i = || |L| |D| |L^T| ||_1 (nonnegative and symmetric), in long double, for L's
/// strictly lower part by columns (col_start, rows, values) and D.
template <class Index>
LD ldl_norm(Eigen::Index n, const Index* col_start, const Index* rows, const double* values, const double* D) {
  const auto size = static_cast<std::size_t>(n);
  std::vector<LD> t(size, 0), m(size, 0);
  for (Eigen::Index c = 0; c < n; ++c) {  // t = |D| |L^T| 1
    LD sum = 1;
    for (Index p = col_start[c]; p < col_start[c + 1]; ++p) sum += std::abs(LD(values[p]));
    t[std::size_t(c)] = sum * std::abs(LD(D[c]));
  }
  for (Eigen::Index c = 0; c < n; ++c) {  // m = |L| t
    m[std::size_t(c)] += t[std::size_t(c)];
    for (Index p = col_start[c]; p < col_start[c + 1]; ++p)
      m[std::size_t(rows[p])] += std::abs(LD(values[p])) * t[std::size_t(c)];
  }
  return *std::max_element(m.begin(), m.end());
}

/// 1 + the most entries in a row or a column of L (the file comment's w).
template <class Index>
int longest(Eigen::Index n, const Index* col_start, const Index* rows) {
  std::vector<int> count(std::size_t(n), 0);
  int w = 1;
  for (Eigen::Index c = 0; c < n; ++c) {
    w = std::max(w, int(col_start[c + 1] - col_start[c]) + 1);
    for (Index p = col_start[c]; p < col_start[c + 1]; ++p) w = std::max(w, ++count[std::size_t(rows[p])] + 1);
  }
  return w;
}

}  // namespace

// Ours against Eigen's SimplicialLDLT, each solving A x = b. The file comment's componentwise bound gives the
// normwise |dA|_2 <= || |dA| ||_2 <= gamma_k || P^T |L| |D| |L^T| P ||_2 <= gamma_k || |L| |D| |L^T| ||_1 (a
// nonnegative symmetric matrix's 2-norm is at most its 1-norm), each factorisation with its own L, D, k. Then
// (A + dA) x = b gives x - A^-1 b = -A^-1 dA x, so |x - A^-1 b|_2 <= |dA|_2 |x|_2 / lambda_min(A), and the two
// solutions differ by at most the sum of their two bounds. lambda_min comes from Eigen's dense symmetric
// eigensolver, which is backward stable: its eigenvalues are within n u ||A||_2 <= n u ||A||_1 of the exact
// ones (a bound with a generous constant; the QR iteration's is a small multiple of u ||A||), subtracted
// before dividing.
TEST_CASE("SubtreeLdlt supernodal_mit: Eigen's SimplicialLDLT solution within the conditioning bound", "[arap][ldlt]") {
  using Method = SubtreeLdlt::Method;
  Rng g(20261125);
  struct Shape {
    int pieces, rows, cols, held;
  };
  for (const Shape sh : {Shape{1, 30, 30, 1}, Shape{3, 12, 15, 2}, Shape{2, 20, 22, 6}, Shape{4, 1, 9, 1}})
    for (const bool with_points : {true, false})
      for (const std::size_t column_limit : {std::size_t(0), SubtreeLdlt::kColumnLimit}) {  // blocks, columns
        Eigen::Matrix<double, Eigen::Dynamic, 3> points;
        const Sparse A = reduced_laplacian(g, sh.pieces, sh.rows, sh.cols, sh.held, points);
        const Eigen::Index n = A.rows();
        INFO("n = " << n << ", " << sh.pieces << " pieces, " << sh.held << " held each"
                    << (with_points ? ", points" : "") << (column_limit ? ", columns" : ", blocks"));
        Eigen::MatrixX3d b(n, 3);
        for (Eigen::Index i = 0; i < n; ++i)
          for (int k = 0; k < 3; ++k) b(i, k) = g.uniform<double>(-1, 1);
        SubtreeLdlt s;
        REQUIRE(s.compute(A, 2, Method::supernodal_mit, with_points ? &points : nullptr, column_limit));
        std::vector<double> y = packed(s, b);
        s.solve(y, 0, nullptr);
        Eigen::SimplicialLDLT<Sparse> eigen(A);
        REQUIRE(eigen.info() == Eigen::Success);
        const Eigen::MatrixX3d xe = eigen.solve(b);

        const Eigen::MatrixXd dense = Eigen::MatrixXd(A);
        const LD u = std::numeric_limits<double>::epsilon() / 2, norm1 = dense.cwiseAbs().colwise().sum().maxCoeff();
        const LD lambda =
            LD(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(dense, Eigen::EigenvaluesOnly).eigenvalues()(0)) -
            LD(n) * u * norm1;
        REQUIRE(lambda > 0);
        const auto gamma = [&](int k) { return LD(k) * u / (1 - LD(k) * u); };
        const SubtreeLdlt::Factor f = s.factor();
        const LD ours = gamma(3 * longest(n, f.col_start.data(), f.rows.data()) + 6) *
                        ldl_norm(n, f.col_start.data(), f.rows.data(), f.values.data(), f.D.data());
        const auto& Le = eigen.matrixL().nestedExpression();
        const Eigen::VectorXd De = eigen.vectorD();
        const LD theirs = gamma(3 * longest(n, Le.outerIndexPtr(), Le.innerIndexPtr()) + 2) *
                          ldl_norm(n, Le.outerIndexPtr(), Le.innerIndexPtr(), Le.valuePtr(), De.data());
        for (int k = 0; k < 3; ++k) {
          LD diff = 0, x2 = 0, xe2 = 0;
          for (Eigen::Index i = 0; i < n; ++i) {
            const LD x = y[3 * std::size_t(s.row_of(i)) + std::size_t(k)];
            diff += (x - LD(xe(i, k))) * (x - LD(xe(i, k))), x2 += x * x, xe2 += LD(xe(i, k)) * LD(xe(i, k));
          }
          const LD bound = (ours * std::sqrt(x2) + theirs * std::sqrt(xe2)) / lambda;
          INFO("column " << k << ": |x - x_eigen| " << double(std::sqrt(diff)) << ", bound " << double(bound));
          CHECK(std::sqrt(diff) <= bound);
        }
      }
}

TEST_CASE("SubtreeLdlt: the supernodal factorisation where the build has none is an error", "[arap][ldlt]") {
  if (mlsdeform::detail::supernodal_available()) return;  // the build has it: the test above covers it
  SubtreeLdlt s;
  Rng g(1);
  CHECK_THROWS_AS(s.compute(spd(g, 1, 3, 3, 0), 1, SubtreeLdlt::Method::supernodal), std::invalid_argument);
}
