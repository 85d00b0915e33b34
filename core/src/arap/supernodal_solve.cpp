// SupernodalSolve (supernodal_solve.hpp).
#include "core/src/arap/supernodal_solve.hpp"

#include "core/src/arap/supernodal_solve_loops.hpp"
#include "core/src/parallel.hpp"

#include <algorithm>
#include <utility>

namespace mlsdeform::detail {

using solve_loops::dot1, solve_loops::dot2, solve_loops::subtract4, solve_loops::update1, solve_loops::update4;

SupernodalSolve::SupernodalSolve(SupernodalFactor factor, std::size_t bins) : f(std::move(factor)) {
  const std::size_t ns = f.first.size() - 1;
  const auto columns = [&](std::size_t t) { return f.first[t + 1] - f.first[t]; };
  const auto height = [&](std::size_t t) { return f.row_start[t + 1] - f.row_start[t]; };
  std::vector<double> work(ns);
  for (std::size_t t = 0; t < ns; ++t) work[t] = double(columns(t)) * double(height(t));
  // The diagonal's reciprocals: the substitutions multiply (on spot_loop3 the divisions, and the stores that
  // waited on them, were a fifth of the forward pass's profile samples).
  inverse.resize(f.perm.size());
  for (std::size_t t = 0; t < ns; ++t)
    for (int c = 0; c < columns(t); ++c)
      inverse[std::size_t(f.first[t] + c)] =
          1 / f.values[f.value_start[t] + std::size_t(c) * std::size_t(height(t)) + std::size_t(c)];
  for (const double w : work) shared_from += w / 64;
  std::vector<std::pair<int, int>> subtrees;
  cut_tree(f.super_parent, work, bins, subtrees, top);
  // The subtrees (heaviest first) each onto the lightest part.
  bins = std::max<std::size_t>(bins, 1);
  std::vector<double> load(bins, 0.0);
  std::vector<std::vector<std::pair<int, int>>> part(bins);
  for (const auto& r : subtrees) {
    double w = 0;
    for (int t = r.first; t <= r.second; ++t) w += work[std::size_t(t)];
    const auto k = std::size_t(std::min_element(load.begin(), load.end()) - load.begin());
    load[k] += w;
    part[k].push_back(r);
  }
  range_start.assign(1, 0);
  for (auto& p : part) {
    std::sort(p.begin(), p.end());
    ranges.insert(ranges.end(), p.begin(), p.end());
    range_start.push_back(ranges.size());
  }
  std::vector<char> in_top(ns, 0);
  for (const int t : top) in_top[std::size_t(t)] = 1;
  std::vector<int> super_of(f.perm.size());
  for (std::size_t t = 0; t < ns; ++t)
    for (int j = f.first[t]; j < f.first[t + 1]; ++j) super_of[std::size_t(j)] = int(t);
  // A supernode's rows below its columns are on its path to the root, ascending: those in the top (whose
  // supernodes' ancestors are in the top too) are the last ones.
  top_start.resize(ns);
  scratch.assign(bins + 1, {});
  std::vector<std::size_t> need(bins + 1, 0);
  for (std::size_t k = 0; k < bins; ++k)
    for (std::size_t q = range_start[k]; q < range_start[k + 1]; ++q)
      for (int t = ranges[q].first; t <= ranges[q].second; ++t)
        need[k] = std::max(need[k], std::size_t(height(std::size_t(t)) - columns(std::size_t(t))));
  for (std::size_t t = 0; t < ns; ++t) {
    const int* rows = f.rows.data() + f.row_start[t];
    int p = columns(t);
    if (!in_top[t])
      while (p < height(t) && !in_top[std::size_t(super_of[std::size_t(rows[p])])]) ++p;
    top_start[t] = p;
    if (in_top[t] || p < height(t)) {
      tail.push_back(int(t));
      need[bins] = std::max(need[bins], std::size_t(height(t) - columns(t)));
    }
  }
  for (const int t : tail)
    if (!in_top[std::size_t(t)]) {
      sums_at.push_back(below_sums);
      below_top.push_back(t);
      below_sums += 3 * std::size_t(height(std::size_t(t)) - top_start[std::size_t(t)]);
    }
  if (bins > 1) tail_sums.assign(below_sums, 0.0);
  // Each part's scratch: the rows below a supernode (3 values each), then its own columns, planar.
  int widest = 0;
  for (std::size_t t = 0; t < ns; ++t) widest = std::max(widest, columns(t));
  planar_at.resize(bins + 1);
  for (std::size_t k = 0; k <= bins; ++k) {
    planar_at[k] = 3 * need[k];
    scratch[k].assign(3 * (need[k] + std::size_t(widest)), 0.0);
  }
}

/// Forward substitution with supernode t: where `diagonal`, its own rows z = G_11^-1 y (in place, by way of
/// `planar`: 3 nc values); then the rows at positions p0 .. p1 below: y_r -= sum_c G_rc z_c, the sum over the
/// columns c ascending, into `acc`.
void SupernodalSolve::forward(double* y, std::size_t t, int p0, int p1, bool diagonal, double* acc,
                              double* planar) const {
  const int f0 = f.first[t], nc = f.first[t + 1] - f0, nr = f.row_start[t + 1] - f.row_start[t];
  const double* G = f.values.data() + f.value_start[t];
  double* z = y + 3 * std::size_t(f0);
  // One column: the general path's operations without its planar copies, zeroed buffer and calls (back_one
  // likewise). spot_loop3's substitution 2-3% faster on one and two threads; the same bits.
  if (diagonal && nc == 1) {
    const double d = inverse[std::size_t(f0)];
    z[0] *= d, z[1] *= d, z[2] *= d;
    const int* rows = f.rows.data() + f.row_start[t];
    for (int p = p0; p < p1; ++p) {  // y_r -= (0 + G_r z), as sums() and scatter() compute it
      double* yr = y + 3 * std::size_t(rows[p]);
      yr[0] -= 0.0 + G[p] * z[0], yr[1] -= 0.0 + G[p] * z[1], yr[2] -= 0.0 + G[p] * z[2];
    }
    return;
  }
  if (diagonal) {
    // Column by column: q_c *= 1 / G_cc, then q_r -= G_rc q_c for the rows r > c of the block, each row's
    // subtractions in ascending c. Four columns at a time below their own 4 x 4 triangle, on the planar copy
    // (the rows two or more per instruction): the same operations in the same order as one column at a time.
    const std::size_t n = std::size_t(nc);
    const double* d = inverse.data() + f0;
    double *q0 = planar, *q1 = planar + n, *q2 = planar + 2 * n;
    for (std::size_t r = 0; r < n; ++r) q0[r] = z[3 * r], q1[r] = z[3 * r + 1], q2[r] = z[3 * r + 2];
    const auto column = [&](std::size_t c) { return G + c * std::size_t(nr); };
    std::size_t c = 0;
    for (; c + 4 <= n; c += 4) {
      for (std::size_t j = c; j < c + 4; ++j) {
        const double* g = column(j);
        q0[j] *= d[j], q1[j] *= d[j], q2[j] *= d[j];
        for (std::size_t r = j + 1; r < c + 4; ++r) q0[r] -= g[r] * q0[j], q1[r] -= g[r] * q1[j], q2[r] -= g[r] * q2[j];
      }
      const std::size_t b = c + 4;
      subtract4(n - b, column(c) + b, column(c + 1) + b, column(c + 2) + b, column(c + 3) + b, q0 + c, q1 + c, q2 + c,
                q0 + b, q1 + b, q2 + b);
    }
    for (; c < n; ++c) {
      const double* g = column(c);
      q0[c] *= d[c], q1[c] *= d[c], q2[c] *= d[c];
      for (std::size_t r = c + 1; r < n; ++r) q0[r] -= g[r] * q0[c], q1[r] -= g[r] * q1[c], q2[r] -= g[r] * q2[c];
    }
    for (std::size_t r = 0; r < n; ++r) z[3 * r] = q0[r], z[3 * r + 1] = q1[r], z[3 * r + 2] = q2[r];
  }
  if (p1 <= p0) return;
  sums(y, t, p0, p1, acc);
  scatter(y, t, p0, p1, acc);
}

void SupernodalSolve::sums(const double* y, std::size_t t, int p0, int p1, double* acc) const {
  const int f0 = f.first[t], nc = f.first[t + 1] - f0, nr = f.row_start[t + 1] - f.row_start[t];
  const double* G = f.values.data() + f.value_start[t];
  const double* z = y + 3 * std::size_t(f0);
  const std::size_t m = std::size_t(p1 - p0);
  // The three right-hand sides' accumulators one after the other (acc, acc + m, acc + 2 m): each is then a
  // plain loop over the rows, which the compiler runs two rows per instruction.
  double *a0 = acc, *a1 = acc + m, *a2 = acc + 2 * m;
  std::fill(acc, acc + 3 * m, 0.0);
  // Four columns per sweep over the rows, all three right-hand sides in the same sweep: each entry of the
  // block is read once. Each row still adds its terms column by column, ascending (the same bits as one
  // column per sweep).
  const auto column = [&](int c) { return G + std::size_t(c) * std::size_t(nr) + p0; };
  int c = 0;
  for (; c + 4 <= nc; c += 4) update4(m, column(c), column(c + 1), column(c + 2), column(c + 3), z + 3 * c, a0, a1, a2);
  for (; c < nc; ++c) update1(m, column(c), z + 3 * c, a0, a1, a2);
}

void SupernodalSolve::scatter(double* y, std::size_t t, int p0, int p1, const double* acc) const {
  const int* rows = f.rows.data() + f.row_start[t];
  const std::size_t m = std::size_t(p1 - p0);
  const double *a0 = acc, *a1 = acc + m, *a2 = acc + 2 * m;
  for (std::size_t i = 0; i < m; ++i) {
    double* yr = y + 3 * std::size_t(rows[std::size_t(p0) + i]);
    yr[0] -= a0[i], yr[1] -= a1[i], yr[2] -= a2[i];
  }
}

/// Backward substitution with supernode t, in three steps: x_below (its rows below, its ancestors', final
/// already) gathered into `xb`; z_c -= G_21(:, c)^T x_below for its columns c0 .. c1; then x_own = G_11^-T z_own.
void SupernodalSolve::gather(const double* y, std::size_t t, double* xb) const {
  const int nc = f.first[t + 1] - f.first[t], nr = f.row_start[t + 1] - f.row_start[t];
  const int* rows = f.rows.data() + f.row_start[t] + nc;
  const std::size_t m = std::size_t(nr - nc);
  for (std::size_t i = 0; i < m; ++i) {
    const double* x = y + 3 * std::size_t(rows[i]);
    xb[i] = x[0], xb[m + i] = x[1], xb[2 * m + i] = x[2];
  }
}

void SupernodalSolve::below(double* y, std::size_t t, int c0, int c1, const double* xb) const {
  const int f0 = f.first[t], nc = f.first[t + 1] - f0, nr = f.row_start[t + 1] - f.row_start[t];
  const double* G = f.values.data() + f.value_start[t];
  double* z = y + 3 * std::size_t(f0);
  const std::size_t m = std::size_t(nr - nc);
  const double *x0 = xb, *x1 = xb + m, *x2 = xb + 2 * m;
  const auto column = [&](int c) { return G + std::size_t(c) * std::size_t(nr) + nc; };
  int c = c0;
  for (; c + 2 <= c1; c += 2) dot2(m, column(c), column(c + 1), x0, x1, x2, z + 3 * c);
  for (; c < c1; ++c) dot1(m, column(c), x0, x1, x2, z + 3 * c);
}

void SupernodalSolve::diagonal_back(double* y, std::size_t t, double* planar) const {
  const int f0 = f.first[t], nc = f.first[t + 1] - f0, nr = f.row_start[t + 1] - f.row_start[t];
  const double* G = f.values.data() + f.value_start[t];
  double* z = y + 3 * std::size_t(f0);
  const std::size_t n = std::size_t(nc);
  const double* d = inverse.data() + f0;
  double *q0 = planar, *q1 = planar + n, *q2 = planar + 2 * n;
  for (std::size_t r = 0; r < n; ++r) q0[r] = z[3 * r], q1[r] = z[3 * r + 1], q2[r] = z[3 * r + 2];
  // x_j = (z_j - sum_{r > j} G_rj x_r) (1 / G_jj), the sum as dot1's (even and odd rows apart, then added), on the
  // planar copy.
  for (std::size_t j = n; j-- > 0;) {
    const double* g = G + j * std::size_t(nr);
    double v[3] = {q0[j], q1[j], q2[j]};
    dot1(n - j - 1, g + j + 1, q0 + j + 1, q1 + j + 1, q2 + j + 1, v);
    q0[j] = v[0] * d[j], q1[j] = v[1] * d[j], q2[j] = v[2] * d[j];
  }
  for (std::size_t r = 0; r < n; ++r) z[3 * r] = q0[r], z[3 * r + 1] = q1[r], z[3 * r + 2] = q2[r];
}

/// gather, below and diagonal_back for a supernode of one column, without the planar copies: each sum over the
/// rows below as dot1's (its even and its odd rows apart, then added, then the last odd row), then
/// x = (z - sum) (1 / G_cc), diagonal_back's step with nothing above (it subtracts a sum of no terms, +0).
void SupernodalSolve::back_one(double* y, std::size_t t) const {
  const int f0 = f.first[t], nr = f.row_start[t + 1] - f.row_start[t];
  const double* g = f.values.data() + f.value_start[t] + 1;
  const int* rows = f.rows.data() + f.row_start[t] + 1;
  const std::size_t m = std::size_t(nr - 1);
  double e[3] = {0, 0, 0}, o[3] = {0, 0, 0};
  std::size_t i = 0;
  for (; i + 2 <= m; i += 2) {
    const double *a = y + 3 * std::size_t(rows[i]), *b = y + 3 * std::size_t(rows[i + 1]);
    for (int k = 0; k < 3; ++k) e[k] += g[i] * a[k], o[k] += g[i + 1] * b[k];
  }
  double* z = y + 3 * std::size_t(f0);
  const double d = inverse[std::size_t(f0)];
  for (int k = 0; k < 3; ++k) {
    double s = e[k] + o[k];
    if (i < m) s += g[i] * y[3 * std::size_t(rows[i]) + std::size_t(k)];
    z[k] = ((z[k] - s) - 0.0) * d;
  }
}

void SupernodalSolve::prefetch_block(std::size_t t) const {
  const double* p = f.values.data() + f.value_start[t];
  const double* e = p + std::min<std::size_t>(f.value_start[t + 1] - f.value_start[t], kPrefetchBytes / sizeof(double));
  for (; p < e; p += 64 / sizeof(double)) __builtin_prefetch(p);
}

void SupernodalSolve::solve(std::vector<double>& yv, int threads, tbb::task_arena* arena) const {
  double* y = yv.data();
  const std::size_t parts = range_start.size() - 1;
  const auto nc = [&](std::size_t t) { return f.first[t + 1] - f.first[t]; };
  const auto nr = [&](std::size_t t) { return f.row_start[t + 1] - f.row_start[t]; };
  parallel_ranges(parts, threads, arena, [&](std::size_t k0, std::size_t k1) {
    for (std::size_t k = k0; k < k1; ++k)
      for (std::size_t q = range_start[k]; q < range_start[k + 1]; ++q)
        for (int t = ranges[q].first; t <= ranges[q].second; ++t) {
          if (t < ranges[q].second) prefetch_block(std::size_t(t) + 1);
          forward(y, std::size_t(t), nc(std::size_t(t)), top_start[std::size_t(t)], true, scratch[k].data(),
                  scratch[k].data() + planar_at[k]);
        }
  });
  // The top's large blocks (the dissection's top separators: a third of spot_loop3's entries) are shared by
  // the threads: rows of an update, or columns of a backward sum, in chunks (each row's or column's sum is
  // the same whichever chunk holds it). Only blocks of at least 1/64 of the entries: at most 64 more
  // joins of the threads per pass, each of which waits for a thread that a loaded machine may preempt.
  constexpr int kChunk = 256;
  const auto large = [&](std::size_t t) { return threads != 1 && double(nc(t)) * double(nr(t)) >= shared_from; };
  double* acc = scratch.back().data();
  double* planar = acc + planar_at.back();
  // The subtrees' supernodes in the tail only read their own solved rows: their sums for the top's rows are
  // computed first, in parallel, into tail_sums, and subtracted below in the tail's order (so each row's
  // updates still arrive in ascending supernode order, each the same sum: the same bits).
  const bool ahead = threads != 1 && !tail_sums.empty();
  if (ahead)
    parallel_ranges(below_top.size(), threads, arena, [&](std::size_t k0, std::size_t k1) {
      for (std::size_t k = k0; k < k1; ++k) {
        const auto u = std::size_t(below_top[k]);
        sums(y, u, top_start[u], nr(u), tail_sums.data() + sums_at[k]);
      }
    });
  std::size_t next = 0;  // below_top's next
  for (const int t : tail) {
    const auto u = std::size_t(t);
    const int p0 = top_start[u], p1 = nr(u);
    if (ahead && next < below_top.size() && below_top[next] == t) {
      scatter(y, u, p0, p1, tail_sums.data() + sums_at[next++]);
      continue;
    }
    const bool own = p0 == nc(u) && std::binary_search(top.begin(), top.end(), t);
    if (!large(u)) {
      forward(y, u, p0, p1, own, acc, planar);
      continue;
    }
    forward(y, u, p0, p0, own, acc, planar);
    parallel_ranges(std::size_t(p1 - p0 + kChunk - 1) / kChunk, threads, arena, [&](std::size_t k0, std::size_t k1) {
      const int q0 = p0 + int(k0) * kChunk, q1 = std::min(p1, p0 + int(k1) * kChunk);
      forward(y, u, q0, q1, false, acc + 3 * std::size_t(q0 - p0), nullptr);
    });
  }
  for (std::size_t k = top.size(); k-- > 0;) {
    const auto u = std::size_t(top[k]);
    gather(y, u, acc);
    if (large(u))
      parallel_ranges(std::size_t(nc(u) + kChunk / 16 - 1) / (kChunk / 16), threads, arena,
                      [&](std::size_t k0, std::size_t k1) {
                        below(y, u, int(k0) * (kChunk / 16), std::min(nc(u), int(k1) * (kChunk / 16)), acc);
                      });
    else
      below(y, u, 0, nc(u), acc);
    diagonal_back(y, u, planar);
  }
  parallel_ranges(parts, threads, arena, [&](std::size_t k0, std::size_t k1) {
    for (std::size_t k = k0; k < k1; ++k)
      for (std::size_t q = range_start[k]; q < range_start[k + 1]; ++q)
        for (int t = ranges[q].second; t >= ranges[q].first; --t) {
          const auto u = std::size_t(t);
          if (t > ranges[q].first) prefetch_block(u - 1);
          if (nc(u) == 1) {
            back_one(y, u);
            continue;
          }
          gather(y, u, scratch[k].data());
          below(y, u, 0, nc(u), scratch[k].data());
          diagonal_back(y, u, scratch[k].data() + planar_at[k]);
        }
  });
}

std::size_t SupernodalSolve::memory_bytes() const {
  const auto bytes = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  std::size_t s = bytes(f.first) + bytes(f.row_start) + bytes(f.rows) + bytes(f.super_parent) + bytes(f.perm) +
                  bytes(f.value_start) + bytes(f.values) + bytes(top_start) + bytes(ranges) + bytes(range_start) +
                  bytes(top) + bytes(tail) + bytes(inverse) + bytes(below_top) + bytes(sums_at) + bytes(tail_sums);
  for (const auto& v : scratch) s += bytes(v);
  return s;
}

}  // namespace mlsdeform::detail
