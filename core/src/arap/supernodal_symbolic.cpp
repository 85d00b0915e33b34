// The supernodal factorisation's analysis (supernodal_ldlt.hpp): elimination tree, postorder, column
// counts, supernodes, their row structures and the update lists.
#include "core/src/arap/supernodal_ldlt.hpp"

#include <algorithm>
#include <cstdint>

namespace mlsdeform::detail {

namespace {

using Sparse = Eigen::SparseMatrix<double>;

/// Entries of a supernode's lower trapezoid: `c` columns, `r` rows (the diagonal block's lower triangle and
/// the rows below it).
double trapezoid(double c, double r) { return c * (c + 1) / 2 + c * (r - c); }

}  // namespace

SupernodalSymbolic analyse_order(const Sparse& A, const std::vector<int>& order) {
  const auto n = std::size_t(A.rows());
  SupernodalSymbolic s;
  std::vector<int> pos(n), parent(n, -1), ancestor(n, -1);
  for (std::size_t k = 0; k < n; ++k) pos[std::size_t(order[k])] = int(k);
  // Liu's algorithm: column k's entries above the diagonal join their subtrees' roots (path-compressed
  // through `ancestor`) under k.
  for (std::size_t k = 0; k < n; ++k)
    for (Sparse::InnerIterator it(A, order[k]); it; ++it) {
      int r = pos[std::size_t(it.row())];
      if (r >= int(k)) continue;
      while (ancestor[std::size_t(r)] != -1 && ancestor[std::size_t(r)] != int(k)) {
        const int t = ancestor[std::size_t(r)];
        ancestor[std::size_t(r)] = int(k);
        r = t;
      }
      if (ancestor[std::size_t(r)] == -1) ancestor[std::size_t(r)] = int(k), parent[std::size_t(r)] = int(k);
    }
  // A postorder, children ascending: every subtree becomes a range of consecutive columns, so a chain of
  // columns with one structure becomes a supernode. Same fill, same tree.
  std::vector<int> head(n, -1), next(n, -1), post, stack;
  post.reserve(n);
  for (std::size_t j = n; j-- > 0;)
    if (parent[j] >= 0) next[j] = head[std::size_t(parent[j])], head[std::size_t(parent[j])] = int(j);
  for (std::size_t root = 0; root < n; ++root) {
    if (parent[root] >= 0) continue;
    stack.push_back(int(root));
    while (!stack.empty()) {
      const auto p = std::size_t(stack.back());
      const int c = head[p];
      if (c < 0) {
        post.push_back(int(p));
        stack.pop_back();
      } else {
        head[p] = next[std::size_t(c)];
        stack.push_back(c);
      }
    }
  }
  std::vector<int> renumber(n);
  for (std::size_t k = 0; k < n; ++k) renumber[std::size_t(post[k])] = int(k);
  s.order.resize(n), s.pos.resize(n), s.parent.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const auto old = std::size_t(post[k]);
    s.order[k] = order[old];
    s.pos[std::size_t(order[old])] = int(k);
    s.parent[k] = parent[old] < 0 ? -1 : renumber[std::size_t(parent[old])];
  }
  // Column counts: row i of L has entries in the columns of its row subtree, the union of the tree paths
  // from each k (A_ik != 0, k < i) up to i; each such column gains one entry.
  s.count.assign(n, 0);
  std::vector<int>& mark = ancestor;
  std::fill(mark.begin(), mark.end(), -1);
  for (std::size_t i = 0; i < n; ++i) {
    mark[i] = int(i);
    for (Sparse::InnerIterator it(A, s.order[i]); it; ++it)
      for (int k = s.pos[std::size_t(it.row())]; k < int(i) && mark[std::size_t(k)] != int(i);
           k = s.parent[std::size_t(k)])
        mark[std::size_t(k)] = int(i), ++s.count[std::size_t(k)];
  }
  for (const int c : s.count) s.entries += std::size_t(c);
  return s;
}

void find_supernodes(const Sparse& A, SupernodalSymbolic& s) {
  const std::size_t n = s.order.size();
  // Fundamental supernodes: column j joins j - 1's when j - 1 is its only child and their structures
  // agree (count[j - 1] = count[j] + 1).
  std::vector<int> children(n, 0), fund;
  for (std::size_t j = 0; j < n; ++j)
    if (s.parent[j] >= 0) ++children[std::size_t(s.parent[j])];
  for (std::size_t j = 0; j < n; ++j)
    if (j == 0 || s.parent[j - 1] != int(j) || s.count[j - 1] != s.count[j] + 1 || children[j] != 1)
      fund.push_back(int(j));
  const std::size_t nf = fund.size();
  fund.push_back(int(n));
  std::vector<int> fund_of(n);
  for (std::size_t f = 0; f < nf; ++f)
    for (int j = fund[f]; j < fund[f + 1]; ++j) fund_of[std::size_t(j)] = int(f);
  // Relaxed amalgamation (CHOLMOD's default rule): a supernode merges into its parent when that parent
  // follows it directly (it is the parent's last child) and the merged block's explicit zeros stay few:
  // any at most 4 columns wide, under 80% zeros up to 16 columns, 10% up to 48, 5% beyond. Fewer, larger
  // blocks for the dense kernels, at the price of those zeros. Groups grow downwards from their top
  // fundamental supernode `top`: columns, rows and zeros of each group are kept at its top.
  std::vector<int> top(nf);
  std::vector<double> cols(nf), rows(nf), zeros(nf, 0);
  for (std::size_t f = nf; f-- > 0;) {
    const int last = fund[f + 1] - 1;
    top[f] = int(f);
    cols[f] = fund[f + 1] - fund[f];
    rows[f] = cols[f] + s.count[std::size_t(last)];
    const int p = s.parent[std::size_t(last)];
    if (p < 0 || fund_of[std::size_t(p)] != int(f) + 1) continue;
    const auto t = std::size_t(top[f + 1]);
    const double c = cols[f] + cols[t], r = cols[f] + rows[t];
    const double z = trapezoid(c, r) - (trapezoid(cols[f], rows[f]) + trapezoid(cols[t], rows[t]) - zeros[t]);
    const double fraction = z / trapezoid(c, r);
    if (c <= 4 || (c <= 16 && fraction < 0.8) || (c <= 48 && fraction < 0.1) || fraction < 0.05)
      top[f] = int(t), cols[t] = c, rows[t] = r, zeros[t] = z;
  }
  s.first.clear();
  for (std::size_t f = 0; f < nf; ++f)
    if (f == 0 || top[f] != top[f - 1]) s.first.push_back(fund[f]);
  const std::size_t ns = s.first.size();
  s.first.push_back(int(n));
  s.super_of.resize(n);
  for (std::size_t t = 0; t < ns; ++t)
    for (int j = s.first[t]; j < s.first[t + 1]; ++j) s.super_of[std::size_t(j)] = int(t);
  s.super_parent.resize(ns);
  std::vector<int> child_start(ns + 1, 0), child(ns);
  for (std::size_t t = 0; t < ns; ++t) {
    const int p = s.parent[std::size_t(s.first[t + 1] - 1)];
    s.super_parent[t] = p < 0 ? -1 : s.super_of[std::size_t(p)];
    if (p >= 0) ++child_start[std::size_t(s.super_parent[t]) + 1];
  }
  for (std::size_t t = 0; t < ns; ++t) child_start[t + 1] += child_start[t];
  {
    std::vector<int> fill(child_start.begin(), child_start.end() - 1);
    for (std::size_t t = 0; t < ns; ++t)
      if (s.super_parent[t] >= 0) child[std::size_t(fill[std::size_t(s.super_parent[t])]++)] = int(t);
  }
  // Row structures: a supernode's rows below its columns are those of A's entries in its columns and of its
  // children's structures (the symbolic factorisation's recurrence).
  std::vector<int> mark(n, -1), below;
  s.rows.clear();
  s.row_start.assign(1, 0);
  s.value_start.assign(1, 0);
  for (std::size_t t = 0; t < ns; ++t) {
    const int f0 = s.first[t], f1 = s.first[t + 1];
    below.clear();
    const auto add = [&](int r) {
      if (r >= f1 && mark[std::size_t(r)] != int(t)) mark[std::size_t(r)] = int(t), below.push_back(r);
    };
    for (int j = f0; j < f1; ++j)
      for (Sparse::InnerIterator it(A, s.order[std::size_t(j)]); it; ++it) add(s.pos[std::size_t(it.row())]);
    for (int k = child_start[t]; k < child_start[t + 1]; ++k) {
      const auto c = std::size_t(child[std::size_t(k)]);
      const int own = s.first[c + 1] - s.first[c];
      for (int q = s.row_start[c] + own; q < s.row_start[c + 1]; ++q) add(s.rows[std::size_t(q)]);
    }
    std::sort(below.begin(), below.end());
    for (int j = f0; j < f1; ++j) s.rows.push_back(j);
    s.rows.insert(s.rows.end(), below.begin(), below.end());
    s.row_start.push_back(int(s.rows.size()));
    s.value_start.push_back(s.value_start.back() +
                            std::size_t(f1 - f0) * std::size_t(s.row_start[t + 1] - s.row_start[t]));
  }
  // Updates: descendant d's rows below its columns, in runs by the supernode that owns them (rows ascend,
  // supernodes are ranges of columns), each run an update of that supernode; d ascending in every list.
  s.update_start.assign(ns + 1, 0);
  const auto runs = [&](auto&& visit) {
    for (std::size_t d = 0; d < ns; ++d) {
      const int own = s.first[d + 1] - s.first[d], end = s.row_start[d + 1] - s.row_start[d];
      const int* r = s.rows.data() + s.row_start[d];
      for (int p0 = own, p1; p0 < end; p0 = p1) {
        const int owner = s.super_of[std::size_t(r[p0])];
        for (p1 = p0 + 1; p1 < end && s.super_of[std::size_t(r[p1])] == owner; ++p1) {
        }
        visit(owner, SupernodalSymbolic::Update{int(d), p0, p1});
      }
    }
  };
  runs([&](int owner, const SupernodalSymbolic::Update&) { ++s.update_start[std::size_t(owner) + 1]; });
  for (std::size_t t = 0; t < ns; ++t) s.update_start[t + 1] += s.update_start[t];
  s.updates.resize(s.update_start[ns]);
  std::vector<std::size_t> fill(s.update_start.begin(), s.update_start.end() - 1);
  runs([&](int owner, const SupernodalSymbolic::Update& u) { s.updates[fill[std::size_t(owner)]++] = u; });
}

}  // namespace mlsdeform::detail
