// The supernodal factorisation's numeric phase and its entry (supernodal_ldlt.hpp).
#include "core/src/arap/nested_dissection.hpp"
#include "core/src/arap/supernodal_ldlt.hpp"
#include "core/src/huge_pages.hpp"
#include "core/src/parallel.hpp"
#include "core/src/threading.hpp"

#include <Eigen/Cholesky>
#include <Eigen/OrderingMethods>

#include <algorithm>
#include <atomic>
#include <limits>
#include <new>
#include <utility>

namespace mlsdeform::detail {

namespace {

using Sparse = Eigen::SparseMatrix<double>;
using Block = Eigen::Map<Eigen::MatrixXd, 0, Eigen::OuterStride<>>;
using ConstBlock = Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>>;

/// A thread's scratch: where each row of L sits in the supernode being computed, and the update's product.
struct Scratch {
  std::vector<int> map;
  std::vector<double> W;
};

/// Subtracts from columns [c0, c1) of supernode t's block B (nr rows; w.map: where each row of L sits in it)
/// its descendants' updates, in the order of update_start (ascending descendants). Each update is d's
/// G(p0 .., :) G(p0 .. p1, :)^T, its lower trapezoid, restricted to those columns: the product of d's rows
/// from the first such column down with those columns' rows.
void subtract_updates(const SupernodalSymbolic& s, std::size_t t, const double* values, double* B, int nr, int c0,
                      int c1, const std::vector<int>& map, std::vector<double>& scratch) {
  const int f0 = s.first[t];
  for (std::size_t u = s.update_start[t]; u < s.update_start[t + 1]; ++u) {
    const SupernodalSymbolic::Update up = s.updates[u];
    const auto d = std::size_t(up.d);
    const int dc = s.first[d + 1] - s.first[d], dr = s.row_start[d + 1] - s.row_start[d];
    const int* drows = s.rows.data() + s.row_start[d];
    // d's rows p0 .. p1 are t's columns, ascending: those in [c0, c1) are positions a .. b.
    const int a = int(std::lower_bound(drows + up.p0, drows + up.p1, f0 + c0) - drows),
              b = int(std::lower_bound(drows + a, drows + up.p1, f0 + c1) - drows);
    if (a == b) continue;
    const int m = dr - a, k = b - a;
    const ConstBlock G(values + s.value_start[d], dr, dc, Eigen::OuterStride<>(dr));
    scratch.resize(std::size_t(m) * std::size_t(k));
    Eigen::Map<Eigen::MatrixXd> W(scratch.data(), m, k);
    W.noalias() = G.middleRows(a, m) * G.middleRows(a, k).transpose();
    for (int cc = 0; cc < k; ++cc) {
      double* column = B + std::size_t(drows[a + cc] - f0) * std::size_t(nr);
      for (int rr = cc; rr < m; ++rr) column[map[std::size_t(drows[a + rr])]] -= W(rr, cc);
    }
  }
}

/// Supernode t's block G(rows, columns) from A's columns and its descendants' updates (subtract_updates; in
/// chunks of split_columns / 2 columns, on up to `threads` threads of `arena`, where it has at least
/// split_columns), then factorised in place: G_11 = chol(A_11 - updates), G_21 = (A_21 - updates) G_11^-T.
/// False where the diagonal block is not positive definite.
bool factor_supernode(const Sparse& A, const SupernodalSymbolic& s, std::size_t t, double* values, Scratch& w,
                      int split_columns, int threads, tbb::task_arena* arena) {
  const int f0 = s.first[t], nc = s.first[t + 1] - f0, nr = s.row_start[t + 1] - s.row_start[t];
  const int* rows = s.rows.data() + s.row_start[t];
  double* B = values + s.value_start[t];
  std::fill(B, B + std::size_t(nc) * std::size_t(nr), 0.0);
  for (int r = 0; r < nr; ++r) w.map[std::size_t(rows[r])] = r;
  for (int c = 0; c < nc; ++c)
    for (Sparse::InnerIterator it(A, s.order[std::size_t(f0 + c)]); it; ++it) {
      const int i = s.pos[std::size_t(it.row())];
      if (i >= f0 + c) B[std::size_t(c) * std::size_t(nr) + std::size_t(w.map[std::size_t(i)])] += it.value();
    }
  if (nc < split_columns) {
    subtract_updates(s, t, values, B, nr, 0, nc, w.map, w.W);
  } else {
    const int chunk = std::max(1, split_columns / 2);
    parallel_ranges(std::size_t((nc + chunk - 1) / chunk), threads, arena, [&](std::size_t k0, std::size_t k1) {
      std::vector<double> scratch;
      for (std::size_t k = k0; k < k1; ++k)
        subtract_updates(s, t, values, B, nr, int(k) * chunk, std::min(nc, int(k + 1) * chunk), w.map, scratch);
    });
  }
  Block G(B, nr, nc, Eigen::OuterStride<>(nr));
  auto top = G.topRows(nc);
  Eigen::Ref<Eigen::MatrixXd> diagonal(top);
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(diagonal);  // in place: G_11 in the lower triangle
  if (llt.info() != Eigen::Success) return false;
  if (nr > nc)
    diagonal.triangularView<Eigen::Lower>().transpose().solveInPlace<Eigen::OnTheRight>(G.bottomRows(nr - nc));
  return true;
}

}  // namespace

void cut_tree(const std::vector<int>& super_parent, const std::vector<double>& own, std::size_t threads,
              std::vector<std::pair<int, int>>& parts, std::vector<int>& top) {
  const std::size_t ns = super_parent.size();
  std::vector<double> work(own);
  std::vector<int> size(ns, 1), roots;
  std::vector<std::vector<int>> children(ns);
  double total = 0;
  for (std::size_t t = 0; t < ns; ++t) {  // children come before their parent
    total += own[t];
    if (super_parent[t] >= 0) {
      const auto p = std::size_t(super_parent[t]);
      work[p] += work[t], size[p] += size[t];
      children[p].push_back(int(t));
    } else {
      roots.push_back(int(t));
    }
  }
  const auto heavier = [&](int a, int b) {
    return work[std::size_t(a)] != work[std::size_t(b)] ? work[std::size_t(a)] > work[std::size_t(b)] : a < b;
  };
  top.clear();
  std::sort(roots.begin(), roots.end(), heavier);
  while (threads > 1 && !roots.empty() && work[std::size_t(roots.front())] * 8.0 * double(threads) > total) {
    const int t = roots.front();
    roots.erase(roots.begin());
    top.push_back(t);
    roots.insert(roots.end(), children[std::size_t(t)].begin(), children[std::size_t(t)].end());
    std::sort(roots.begin(), roots.end(), heavier);
  }
  std::sort(top.begin(), top.end());
  parts.clear();
  for (const int r : roots) parts.emplace_back(r - size[std::size_t(r)] + 1, r);
}

ColumnLdlt to_columns(const SupernodalFactor& f, bool drop_zeros, int threads, tbb::task_arena* arena) {
  const std::size_t ns = f.first.size() - 1, n = f.perm.size();
  const auto kept = [&](double v) { return !drop_zeros || v != 0; };
  std::size_t entries = 0;  // sized first: no reallocation, and the peak is the final size
  for (std::size_t t = 0; t < ns; ++t) {
    const int nc = f.first[t + 1] - f.first[t], nr = f.row_start[t + 1] - f.row_start[t];
    const double* B = f.values.data() + f.value_start[t];
    for (int c = 0; c < nc; ++c)
      for (int r = c + 1; r < nr; ++r) entries += kept(B[std::size_t(c) * std::size_t(nr) + std::size_t(r)]);
  }
  ColumnLdlt out;
  out.D.resize(n);
  out.col_start.resize(n + 1);
  assign_huge(out.rows, entries, 0, threads, arena);
  assign_huge(out.values, entries, 0.0, threads, arena);
  std::size_t to = 0;
  for (std::size_t t = 0; t < ns; ++t) {
    const int f0 = f.first[t], nc = f.first[t + 1] - f0, nr = f.row_start[t + 1] - f.row_start[t];
    const int* rows = f.rows.data() + f.row_start[t];
    const double* B = f.values.data() + f.value_start[t];
    for (int c = 0; c < nc; ++c) {
      const double g = B[std::size_t(c) * std::size_t(nr) + std::size_t(c)];
      out.D[std::size_t(f0 + c)] = g * g;
      out.col_start[std::size_t(f0 + c)] = int(to);
      for (int r = c + 1; r < nr; ++r) {
        const double v = B[std::size_t(c) * std::size_t(nr) + std::size_t(r)];
        if (!kept(v)) continue;
        out.rows[to] = rows[r];
        out.values[to++] = v / g;
      }
    }
  }
  out.col_start[n] = int(to);
  return out;
}

void amd_order(const Sparse& A, Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int>& P) {
  if (!A.isCompressed()) {
    Sparse B = A;
    B.makeCompressed();
    return amd_order(B, P);
  }
  const Eigen::Index n = A.rows(), nnz = A.nonZeros(), room = nnz + nnz / 5 + 2 * n;
  Sparse C(n, n);
  resize_nonzeros_huge(C, std::size_t(room));
  std::copy(A.outerIndexPtr(), A.outerIndexPtr() + n + 1, C.outerIndexPtr());
  std::copy(A.innerIndexPtr(), A.innerIndexPtr() + nnz, C.innerIndexPtr());
  std::copy(A.valuePtr(), A.valuePtr() + nnz, C.valuePtr());
  C.resizeNonZeros(nnz);  // within the room: no reallocation, here or in minimum_degree_ordering
  Eigen::internal::minimum_degree_ordering(C, P);
}

bool supernodal_cholesky(const Sparse& A, const Eigen::Matrix<double, Eigen::Dynamic, 3>* points, int threads,
                         SupernodalFactor& out, int split_columns) {
  const auto n = std::size_t(A.rows());
  // The order: the dissection where the rows' points are given, or AMD's, whichever leaves fewer entries.
  // The two orders are found side by side (spot_loop3: AMD and its analysis 0.75-0.95 s, the dissection and its
  // analysis 0.5 s).
  const auto arena = make_arena(threads);
  SupernodalSymbolic s;
  {
    SupernodalSymbolic nd;
    parallel_ranges(points ? 2 : 1, threads, arena.get(), [&](std::size_t k0, std::size_t k1) {
      for (std::size_t k = k0; k < k1; ++k)
        if (k == 0) {
          Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> P;
          amd_order(A, P);  // P.indices()(k): the row eliminated k-th
          s = analyse_order(A, std::vector<int>(P.indices().data(), P.indices().data() + n));
        } else {
          nd = analyse_order(A, coordinate_nested_dissection(A, *points));
        }
    });
    if (points && nd.entries <= s.entries) s = std::move(nd);
  }
  find_supernodes(A, s);
  const std::size_t ns = s.first.size() - 1;
  std::vector<double> values;
  assign_huge(values, s.value_start[ns], 0.0, threads, arena.get());

  const std::size_t bins =
      threads == 1 ? 1 : std::size_t(arena ? arena->max_concurrency() : tbb::this_task_arena::max_concurrency());
  std::vector<std::pair<int, int>> parts;
  std::vector<int> top;
  {
    std::vector<double> work(ns);  // the block's multiplies
    for (std::size_t t = 0; t < ns; ++t) {
      const double c = s.first[t + 1] - s.first[t], r = s.row_start[t + 1] - s.row_start[t];
      work[t] = c * r * r;
    }
    cut_tree(s.super_parent, work, bins, parts, top);
  }
  // The parts' supernodes take their chunks serially: a thread waiting on nested chunks could take up another
  // part, and with it its own Scratch, in use. The top's, after the parts, in parallel.
  tbb::enumerable_thread_specific<Scratch> scratch([n] { return Scratch{std::vector<int>(n, 0), {}}; });
  std::atomic<bool> failed{false};
  parallel_ranges(parts.size(), threads, arena.get(), [&](std::size_t k0, std::size_t k1) {
    Scratch& w = scratch.local();
    for (std::size_t k = k0; k < k1 && !failed; ++k)
      for (int t = parts[k].first; t <= parts[k].second; ++t)
        if (!factor_supernode(A, s, std::size_t(t), values.data(), w, split_columns, 1, nullptr)) failed = true;
  });
  if (failed) return false;
  {
    Scratch& w = scratch.local();
    for (const int t : top)
      if (!factor_supernode(A, s, std::size_t(t), values.data(), w, split_columns, threads, arena.get())) return false;
  }
  scratch.clear();

  out.first = std::move(s.first), out.row_start = std::move(s.row_start), out.rows = std::move(s.rows);
  out.super_parent = std::move(s.super_parent), out.perm = std::move(s.pos);
  out.value_start = std::move(s.value_start), out.values = std::move(values);
  return true;
}

}  // namespace mlsdeform::detail
