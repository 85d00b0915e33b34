// The orders the supernodal factorisation chooses between (supernodal_ldlt.hpp): the coordinate nested
// dissection (nested_dissection.hpp) and Eigen's AMD on the matrix's own pattern (amd_order).
#include "core/src/arap/nested_dissection.hpp"
#include "core/src/arap/supernodal_ldlt.hpp"
#include "tests/test_ldlt_common.hpp"

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include "tests/support/catch.hpp"

#include <vector>

using mlsdeform::testing::grid_points;
using mlsdeform::testing::Rng;
using mlsdeform::testing::Sparse;
using mlsdeform::testing::spd;

TEST_CASE("coordinate_nested_dissection: a permutation, separators last, less fill than the natural order",
          "[arap][ldlt]") {
  using mlsdeform::detail::coordinate_nested_dissection;
  Rng g(7);
  // A grid with random extra edges, and points that all coincide (every cut is then by row index alone).
  for (const bool coincident : {false, true}) {
    const Sparse A = spd(g, 2, 40, 60, coincident ? 50 : 0);
    auto points = grid_points(2, 40, 60);
    if (coincident) points.setConstant(0.5);
    const std::vector<int> order = coordinate_nested_dissection(A, points);
    INFO((coincident ? "coincident points" : "grid points"));
    REQUIRE(order.size() == std::size_t(A.rows()));
    std::vector<int> seen(order.size(), 0);
    for (const int v : order) {
      REQUIRE((v >= 0 && v < A.rows()));
      CHECK(seen[std::size_t(v)]++ == 0);
    }
    CHECK(coordinate_nested_dissection(A, points) == order);  // deterministic
    if (coincident) continue;
    // Fill: entries of L (Eigen's symbolic factorisation of the permuted matrix, natural order) against the
    // grid's natural order; a 40 x 60 grid's band profile fills about 40 per row, a dissection far less.
    const auto fill = [&](const std::vector<int>& o) {
      Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> P(A.rows());
      for (std::size_t k = 0; k < o.size(); ++k) P.indices()(o[k]) = int(k);
      const Sparse B = P * A * P.transpose();
      Eigen::SimplicialLDLT<Sparse, Eigen::Lower, Eigen::NaturalOrdering<int>> f;
      f.analyzePattern(B);
      f.factorize(B);
      return f.matrixL().nestedExpression().nonZeros();
    };
    std::vector<int> natural(order.size());
    for (std::size_t k = 0; k < natural.size(); ++k) natural[k] = int(k);
    const auto nd = fill(order), band = fill(natural);
    INFO("entries of L: nested dissection " << nd << ", natural " << band);
    CHECK(nd * 2 < band);
  }
}

TEST_CASE("amd_order: Eigen::AMDOrdering's permutation, for compressed and uncompressed matrices", "[arap][ldlt]") {
  // amd_order runs Eigen's minimum degree on A's own pattern instead of the pattern of A^T + A that
  // AMDOrdering forms: for a structurally symmetric A the two are one pattern, so the orders must be equal,
  // index for index. Several pieces (a forest), random extra edges (irregular degrees), and one matrix left
  // uncompressed with room to spare in its columns.
  Rng g(11);
  for (const int extra : {0, 40, 400}) {
    Sparse A = spd(g, 3, 17, 23, extra);
    Eigen::AMDOrdering<int> amd;
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> P, Q;
    amd(A, P);
    mlsdeform::detail::amd_order(A, Q);
    INFO("extra edges " << extra);
    CHECK(P.indices() == Q.indices());
    if (extra == 40) {
      A.reserve(Eigen::VectorXi::Constant(A.cols(), 3));  // uncompressed
      REQUIRE(!A.isCompressed());
      mlsdeform::detail::amd_order(A, Q);
      CHECK(P.indices() == Q.indices());
    }
  }
}
