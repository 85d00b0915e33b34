// SubtreeLdlt (subtree_ldlt.hpp): the factor, the substitution's schedule, forward and backward substitution.
#include "core/src/arap/subtree_ldlt.hpp"

#include "core/src/arap/nested_dissection.hpp"
#include "core/src/arap/supernodal_ldlt.hpp"
#include "core/src/arap/supernodal_solve.hpp"
#include "core/src/parallel.hpp"

#include <Eigen/SparseCholesky>

#if MLSDEFORM_HAVE_CHOLMOD
#include <cholmod.h>
#endif

#include <algorithm>
#include <new>
#include <span>
#include <stdexcept>

namespace mlsdeform::detail {

struct SubtreeLdlt::Storage {
  virtual ~Storage() = default;
  virtual std::size_t bytes() const = 0;  ///< held by the factor's arrays
};

namespace {

/// Eigen's factor (AMD ordering): it stores L's strictly lower part by columns, rows ascending.
struct EigenStorage final : SubtreeLdlt::Storage {
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  std::size_t bytes() const override {  // L by columns, D, and the two permutations (about one more D)
    const auto& L = ldlt.matrixL().nestedExpression();
    return std::size_t(L.nonZeros()) * (sizeof(double) + sizeof(int)) +
           std::size_t(L.outerSize()) * (sizeof(int) + sizeof(double) + 2 * sizeof(int));
  }
};

/// The library's own supernodal factor and its substitution.
struct BlockStorage final : SubtreeLdlt::Storage {
  SupernodalSolve solve;
  explicit BlockStorage(SupernodalSolve s) : solve(std::move(s)) {}
  std::size_t bytes() const override { return solve.memory_bytes(); }
};

/// The library's own supernodal factor converted to columns, its relaxed zeros dropped (a small factor: see
/// SubtreeLdlt::compute).
struct ColumnStorage final : SubtreeLdlt::Storage {
  ColumnLdlt c;
  std::size_t bytes() const override {
    return c.col_start.size() * sizeof(int) + c.rows.size() * sizeof(int) + c.values.size() * sizeof(double);
  }
};

#if MLSDEFORM_HAVE_CHOLMOD
/// CHOLMOD's factor, converted to a simplicial L D L^T whose columns hold the diagonal (D) first; `start`
/// indexes the strictly lower rest, moved to the front of the arrays.
struct CholmodStorage final : SubtreeLdlt::Storage {
  cholmod_common common;
  cholmod_factor* L = nullptr;
  std::vector<int> start;
  CholmodStorage() {
    cholmod_start(&common);
    common.print = 0;  // failures are reported by compute()'s result, not on stdout
  }
  ~CholmodStorage() override {
    cholmod_free_factor(&L, &common);
    cholmod_finish(&common);
  }
  CholmodStorage(const CholmodStorage&) = delete;
  CholmodStorage& operator=(const CholmodStorage&) = delete;
  std::size_t bytes() const override {  // L's rows and values, its column and permutation arrays, `start`
    return L ? L->nzmax * (sizeof(double) + sizeof(int)) + L->n * (6 * sizeof(int)) + start.size() * sizeof(int) : 0;
  }

  /// Symbolic analysis in `order` (order[k] = the row of A eliminated k-th; null: CHOLMOD's AMD), postordered
  /// along its elimination tree (the same fill); `entries`: the entries of L it leaves.
  cholmod_factor* analyse(cholmod_sparse& S, int* order, double& entries) {
    common.nmethods = 1;
    common.method[0].ordering = order ? CHOLMOD_GIVEN : CHOLMOD_AMD;
    common.postorder = 1;
    cholmod_factor* F = cholmod_analyze_p(&S, order, nullptr, 0, &common);
    entries = common.lnz;
    return F;
  }

  /// P A P^T = L L^T by supernodes, in whichever of `order` (if not empty) and CHOLMOD's AMD leaves fewer
  /// entries in L: on spot_loop3 the dissection (45 million against 58; the two analyses take 0.3 and 0.7 s),
  /// on the 6,890-vertex body AMD (whose substitution was then 1.6x faster). Then L D L^T as a packed
  /// simplicial factor with the supernodes' relaxed zeros removed (final_resymbol): the same structure as
  /// Eigen's, rows ascending.
  bool factorise(const Eigen::SparseMatrix<double>& A, std::vector<int> order, std::vector<int>& perm,
                 std::vector<double>& D) {
    Eigen::SparseMatrix<double> lower = A.triangularView<Eigen::Lower>();
    lower.makeCompressed();
    cholmod_sparse S{};
    S.nrow = S.ncol = std::size_t(A.rows());
    S.nzmax = std::size_t(lower.nonZeros());
    S.p = lower.outerIndexPtr(), S.i = lower.innerIndexPtr(), S.x = lower.valuePtr();
    S.stype = -1, S.itype = CHOLMOD_INT, S.xtype = CHOLMOD_REAL, S.dtype = CHOLMOD_DOUBLE;
    S.sorted = 1, S.packed = 1;
    common.supernodal = CHOLMOD_SUPERNODAL;
    common.final_asis = 0, common.final_super = 0, common.final_ll = 0;
    common.final_pack = 1, common.final_monotonic = 1, common.final_resymbol = 1;
    double given = 0, amd = 0;
    L = order.empty() ? nullptr : analyse(S, order.data(), given);
    cholmod_factor* other = analyse(S, nullptr, amd);
    if (other && (!L || amd < given)) std::swap(L, other);
    cholmod_free_factor(&other, &common);
    const bool done = L && cholmod_factorize(&S, L, &common);
    if (common.status == CHOLMOD_OUT_OF_MEMORY) throw std::bad_alloc();
    if (!done || common.status != CHOLMOD_OK || L->minor < L->n || L->is_super || L->is_ll || !L->is_monotonic)
      return false;
    const std::size_t n = L->n;
    const int *p = static_cast<const int*>(L->p), *nz = static_cast<const int*>(L->nz);
    int* rows = static_cast<int*>(L->i);
    double* x = static_cast<double*>(L->x);
    const int* P = static_cast<const int*>(L->Perm);  // row k of P A P^T is row P[k] of A
    perm.resize(n);
    D.resize(n);
    start.assign(n + 1, 0);
    int to = 0;
    for (std::size_t c = 0; c < n; ++c) {  // each column: its diagonal (D_c), then its rows below, ascending
      if (nz[c] < 1 || rows[p[c]] != int(c)) return false;  // not CHOLMOD's documented layout
      perm[std::size_t(P[c])] = int(c);
      D[c] = x[p[c]];
      start[c] = to;
      for (int q = p[c] + 1, above = int(c); q < p[c] + nz[c]; above = rows[q++], ++to) {
        if (rows[q] <= above) return false;  // rows not ascending: not CHOLMOD's documented layout either
        rows[to] = rows[q], x[to] = x[q];
      }
    }
    start[n] = to;
    // Only the prefix is used now (CHOLMOD's own column pointers no longer describe the arrays, which are
    // only ever freed after this): give the rest back.
    return cholmod_reallocate_factor(std::size_t(std::max(to, 1)), L, &common) != 0;
  }
};
#endif

}  // namespace

bool supernodal_available() { return MLSDEFORM_HAVE_CHOLMOD != 0; }

SubtreeLdlt::SubtreeLdlt() = default;
SubtreeLdlt::~SubtreeLdlt() = default;
SubtreeLdlt::SubtreeLdlt(SubtreeLdlt&&) noexcept = default;
SubtreeLdlt& SubtreeLdlt::operator=(SubtreeLdlt&&) noexcept = default;

bool SubtreeLdlt::compute(const Eigen::SparseMatrix<double>& A, std::size_t bins, Method method,
                          const Eigen::Matrix<double, Eigen::Dynamic, 3>* points, std::size_t column_limit,
                          int split_columns) {
  storage.reset();
  Lp = Li = nullptr, Lx = nullptr;
  blocks = nullptr;
  D.clear(), perm.clear(), order.clear(), part_start.clear(), top_start.clear(), tail_cols.clear();
  if (method == Method::supernodal_mit && A.rows() > 0) {
    SupernodalFactor f;
    if (!supernodal_cholesky(A, points, int(bins), f, split_columns)) return false;
    perm = f.perm;
    if (f.values.size() > column_limit) {  // its own substitution, by blocks
      auto s = std::make_unique<BlockStorage>(SupernodalSolve(std::move(f), bins));
      blocks = &s->solve;
      storage = std::move(s);
      return true;
    }
    auto s = std::make_unique<ColumnStorage>();
    const auto arena = make_arena(int(bins));  // the conversion's arrays touched by as many threads as the factor's
    s->c = to_columns(f, true, int(bins), arena.get());
    f = SupernodalFactor();  // the blocks freed before the schedule's arrays are made
    D = std::move(s->c.D);
    Lp = s->c.col_start.data(), Li = s->c.rows.data(), Lx = s->c.values.data();
    storage = std::move(s);
  } else if (method == Method::supernodal && A.rows() > 0) {
#if MLSDEFORM_HAVE_CHOLMOD
    auto s = std::make_unique<CholmodStorage>();
    if (!s->factorise(A, points ? coordinate_nested_dissection(A, *points) : std::vector<int>(), perm, D)) return false;
    Lp = s->start.data(), Li = static_cast<const int*>(s->L->i), Lx = static_cast<const double*>(s->L->x);
    storage = std::move(s);
#else
    static_cast<void>(points);
    throw std::invalid_argument("the supernodal factorisation is not in this build (MLSDEFORM_CHOLMOD=OFF)");
#endif
  } else {
    auto s = std::make_unique<EigenStorage>();
    s->ldlt.compute(A);
    if (s->ldlt.info() != Eigen::Success) return false;
    const Eigen::VectorXd d = s->ldlt.vectorD();
    D.assign(d.data(), d.data() + d.size());
    perm.resize(std::size_t(A.rows()));
    for (Eigen::Index i = 0; i < A.rows(); ++i) perm[std::size_t(i)] = s->ldlt.permutationP().indices()(i);
    const auto& L = s->ldlt.matrixL().nestedExpression();
    Lp = L.outerIndexPtr(), Li = L.innerIndexPtr(), Lx = L.valuePtr();
    storage = std::move(s);
  }
  schedule(bins);
  return true;
}

SubtreeLdlt::Factor SubtreeLdlt::factor() const {
  if (blocks) {
    ColumnLdlt c = to_columns(blocks->factor());
    return {std::move(c.col_start), std::move(c.rows), std::move(c.values), std::move(c.D)};
  }
  const std::size_t n = D.size(), nnz = n ? std::size_t(Lp[n]) : 0;
  return {std::vector<int>(Lp, Lp + (n ? n + 1 : 0)), std::vector<int>(Li, Li + nnz), std::vector<double>(Lx, Lx + nnz),
          D};
}

std::size_t SubtreeLdlt::entries() const {
  if (blocks) {
    const SupernodalFactor& f = blocks->factor();
    std::size_t e = 0;
    for (std::size_t t = 0; t + 1 < f.first.size(); ++t) {
      const auto c = std::size_t(f.first[t + 1] - f.first[t]), r = std::size_t(f.row_start[t + 1] - f.row_start[t]);
      e += c * r - c * (c + 1) / 2;
    }
    return e;
  }
  return D.empty() ? 0 : std::size_t(Lp[D.size()]);
}

/// L z = y, in place in y, column by column: z_c is final once the columns before it are done, and goes
/// to y_r -= L_rc z_c for the rows r of entries [p0(c), p1(c)) of column c, for the columns c of cols.
template <class Cols, class First, class Last>
void SubtreeLdlt::forward(std::vector<double>& y, const Cols& cols, First p0, Last p1) const {
  for (const auto col : cols) {
    const auto k = 3 * std::size_t(col);
    const double z0 = y[k], z1 = y[k + 1], z2 = y[k + 2];
    for (int p = p0(col); p < p1(col); ++p) {
      const double l = Lx[p];  // once: the stores to y might otherwise alias it
      double* t = y.data() + 3 * std::size_t(Li[p]);
      t[0] -= l * z0, t[1] -= l * z1, t[2] -= l * z2;
    }
  }
}

/// x_c = z_c / D_c - sum_r L_rc x_r for the columns order[k0 .. k1), last first, in place in y. The sum runs as
/// two partial sums, over the column's even and its odd entries, then added: two chains of additions instead
/// of one. Each column's sum is whole in one call, so the bits are the same for any schedule.
void SubtreeLdlt::backward(std::vector<double>& y, std::size_t k0, std::size_t k1) const {
  for (std::size_t k = k1; k-- > k0;) {
    const auto col = std::size_t(order[k]);
    double e0 = 0, e1 = 0, e2 = 0, o0 = 0, o1 = 0, o2 = 0;
    int p = Lp[col];
    for (; p + 1 < Lp[col + 1]; p += 2) {
      const double* t = y.data() + 3 * std::size_t(Li[p]);
      const double* u = y.data() + 3 * std::size_t(Li[p + 1]);
      e0 += Lx[p] * t[0], e1 += Lx[p] * t[1], e2 += Lx[p] * t[2];
      o0 += Lx[p + 1] * u[0], o1 += Lx[p + 1] * u[1], o2 += Lx[p + 1] * u[2];
    }
    if (p < Lp[col + 1]) {
      const double* t = y.data() + 3 * std::size_t(Li[p]);
      e0 += Lx[p] * t[0], e1 += Lx[p] * t[1], e2 += Lx[p] * t[2];
    }
    y[3 * col] = y[3 * col] / D[col] - (e0 + o0);
    y[3 * col + 1] = y[3 * col + 1] / D[col] - (e1 + o1);
    y[3 * col + 2] = y[3 * col + 2] / D[col] - (e2 + o2);
  }
}

/// Builds the schedule for `bins` threads, and top_start and tail_cols: the roots of the elimination
/// tree (parent(j) = the first row below the diagonal in column j) are spread over the bins, heaviest
/// first onto the lightest bin (work = entries + 2 per row); then the heaviest subtree is split, its root
/// moving to the top and its children into the spread, for as long as that shortens the longest path
/// (top + heaviest bin). Any schedule gives the same bits; this one only balances the threads.
void SubtreeLdlt::schedule(std::size_t bins) {
  const std::size_t m = D.size();
  std::vector<int> parent(m, -1);
  std::vector<std::size_t> work(m), subtree(m);
  for (std::size_t j = 0; j < m; ++j) {
    for (int p = Lp[j]; p < Lp[j + 1]; ++p)
      if (parent[j] < 0 || Li[p] < parent[j]) parent[j] = Li[p];
    subtree[j] = work[j] = std::size_t(Lp[j + 1] - Lp[j]) + 2;
  }
  for (std::size_t j = 0; j < m; ++j)  // a parent comes after its children
    if (parent[j] >= 0) subtree[std::size_t(parent[j])] += subtree[j];
  std::vector<std::vector<int>> children(m);
  std::vector<int> frontier;  // the subtrees' roots not yet split
  for (std::size_t j = 0; j < m; ++j) (parent[j] >= 0 ? children[std::size_t(parent[j])] : frontier).push_back(int(j));
  const auto heavier = [&](int a, int b) {
    const std::size_t wa = subtree[std::size_t(a)], wb = subtree[std::size_t(b)];
    return wa != wb ? wa > wb : a < b;
  };
  std::vector<int> top, best_frontier, bin_of, best_bin;
  std::vector<std::size_t> load(bins);
  std::size_t top_work = 0, best = ~std::size_t(0), best_top = 0;
  // A surface's top separators hold some sqrt(m) rows (137 of the bundled body's 6,882; about 2,000 of
  // spot_loop3's 730,607 free vertices in coordinate_nested_dissection's order), each split taking one: the
  // splits go on while the frontier stays small. The budget (frontier entries visited) only bounds the
  // set-up's time on odd meshes, whose frontier grows wide.
  for (std::size_t visited = 0; visited < 16 * m + (1u << 20) && !frontier.empty() && top_work < best;
       visited += frontier.size()) {
    std::sort(frontier.begin(), frontier.end(), heavier);
    std::fill(load.begin(), load.end(), std::size_t(0));
    bin_of.assign(frontier.size(), 0);
    for (std::size_t f = 0; f < frontier.size(); ++f) {
      const auto b = std::size_t(std::min_element(load.begin(), load.end()) - load.begin());
      load[b] += subtree[std::size_t(frontier[f])];
      bin_of[f] = int(b);
    }
    const std::size_t span = top_work + *std::max_element(load.begin(), load.end());
    if (span < best) best = span, best_top = top.size(), best_frontier = frontier, best_bin = bin_of;
    if (bins == 1) break;
    const int f = frontier.front();
    frontier.erase(frontier.begin());
    top.push_back(f);
    top_work += work[std::size_t(f)];
    frontier.insert(frontier.end(), children[std::size_t(f)].begin(), children[std::size_t(f)].end());
  }
  std::vector<int> part(m, -1);
  for (std::size_t t = 0; t < best_top; ++t) part[std::size_t(top[t])] = int(bins);
  for (std::size_t f = 0; f < best_frontier.size(); ++f) part[std::size_t(best_frontier[f])] = best_bin[f];
  for (std::size_t j = m; j-- > 0;)  // the rest of each subtree goes with its root
    if (part[j] < 0) part[j] = part[std::size_t(parent[j])];
  parts = bins;
  part_start.assign(bins + 2, 0);
  for (std::size_t j = 0; j < m; ++j) ++part_start[std::size_t(part[j]) + 1];
  for (std::size_t k = 0; k <= bins; ++k) part_start[k + 1] += part_start[k];
  order.resize(m);
  std::vector<std::size_t> fill(part_start.begin(), part_start.end() - 1);
  for (std::size_t j = 0; j < m; ++j) order[fill[std::size_t(part[j])]++] = int(j);
  top_start.resize(m);
  tail_cols.clear();
  for (std::size_t col = 0; col < m; ++col) {
    int p = Lp[col];
    while (p < Lp[col + 1] && part[std::size_t(Li[p])] != int(bins)) ++p;
    top_start[col] = p;
    if (p < Lp[col + 1]) tail_cols.push_back(int(col));
  }
}

void SubtreeLdlt::solve(std::vector<double>& y, int threads, tbb::task_arena* arena) const {
  if (blocks) {
    blocks->solve(y, threads, arena);
    return;
  }
  // L z = y (unit lower), then D^-1 and L^T x = z. Row r of L has entries only in columns that descend from
  // r in the elimination tree, column c only in rows that are its ancestors: the parts' subtrees share no
  // row. Forward: each part's columns scatter into their rows below the top, in parallel; then every column
  // with entries in the top rows scatters into them, ascending. Backward gathers, the top first. Every y_r
  // receives its terms in one order whatever the schedule (ascending columns; then ascending rows): the
  // same bits for any thread count.
  const auto first = [&](int col) { return Lp[col]; };
  const auto below_top = [&](int col) { return top_start[std::size_t(col)]; };
  const auto last = [&](int col) { return Lp[col + 1]; };
  parallel_ranges(parts, threads, arena, [&](std::size_t k0, std::size_t k1) {
    for (std::size_t k = k0; k < k1; ++k)
      forward(y, std::span<const int>(order.data() + part_start[k], order.data() + part_start[k + 1]), first,
              below_top);
  });
  forward(y, tail_cols, below_top, last);
  backward(y, part_start[parts], part_start[parts + 1]);
  parallel_ranges(parts, threads, arena, [&](std::size_t k0, std::size_t k1) {
    for (std::size_t k = k0; k < k1; ++k) backward(y, part_start[k], part_start[k + 1]);
  });
}

std::size_t SubtreeLdlt::memory_bytes() const {
  const auto bytes = [](const auto& v) { return v.size() * sizeof(v[0]); };
  return (storage ? storage->bytes() : 0) + bytes(top_start) + bytes(tail_cols) + bytes(order) + bytes(part_start) +
         bytes(D) + bytes(perm);
}

}  // namespace mlsdeform::detail
