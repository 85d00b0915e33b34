// SupernodalSolve (supernodal_solve.hpp).
#include "core/src/arap/supernodal_solve.hpp"

#include "core/src/parallel.hpp"

#include <algorithm>
#include <utility>

namespace mlsdeform::detail {

SupernodalSolve::SupernodalSolve(SupernodalFactor factor, std::size_t bins) : f(std::move(factor)) {
  const std::size_t ns = f.first.size() - 1;
  const auto columns = [&](std::size_t t) { return f.first[t + 1] - f.first[t]; };
  const auto height = [&](std::size_t t) { return f.row_start[t + 1] - f.row_start[t]; };
  std::vector<double> work(ns);
  for (std::size_t t = 0; t < ns; ++t) work[t] = double(columns(t)) * double(height(t));
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
  for (std::size_t k = 0; k <= bins; ++k) scratch[k].assign(3 * need[k], 0.0);
}

/// Forward substitution with supernode t: where `diagonal`, its own rows z = G_11^-1 y (in place); then the
/// rows at positions p0 .. p1 below: y_r -= sum_c G_rc z_c, the sum over the columns c ascending, into `acc`.
void SupernodalSolve::forward(double* y, std::size_t t, int p0, int p1, bool diagonal, double* acc) const {
  const int f0 = f.first[t], nc = f.first[t + 1] - f0, nr = f.row_start[t + 1] - f.row_start[t];
  const double* G = f.values.data() + f.value_start[t];
  const int* rows = f.rows.data() + f.row_start[t];
  double* z = y + 3 * std::size_t(f0);
  if (diagonal)
    for (int c = 0; c < nc; ++c) {
      const double* g = G + std::size_t(c) * std::size_t(nr);
      double* zc = z + 3 * c;
      zc[0] /= g[c], zc[1] /= g[c], zc[2] /= g[c];
      for (int r = c + 1; r < nc; ++r) {
        double* zr = z + 3 * r;
        zr[0] -= g[r] * zc[0], zr[1] -= g[r] * zc[1], zr[2] -= g[r] * zc[2];
      }
    }
  if (p1 <= p0) return;
  const std::size_t m = std::size_t(p1 - p0);
  // The three right-hand sides' accumulators one after the other (acc, acc + m, acc + 2 m): each is then a
  // plain loop over the rows, which the compiler runs two rows per instruction.
  double *a0 = acc, *a1 = acc + m, *a2 = acc + 2 * m;
  std::fill(acc, acc + 3 * m, 0.0);
  // Four columns per sweep over the rows (each row still adds its terms column by column, ascending: the
  // same bits as one column per sweep, with a quarter of the accumulators' loads and stores).
  const auto column = [&](int c) { return G + std::size_t(c) * std::size_t(nr) + p0; };
  const auto sweep4 = [m](double* a, const double* g0, const double* g1, const double* g2, const double* g3, double w0,
                          double w1, double w2, double w3) {
    for (std::size_t i = 0; i < m; ++i) a[i] = (((a[i] + g0[i] * w0) + g1[i] * w1) + g2[i] * w2) + g3[i] * w3;
  };
  int c = 0;
  for (; c + 4 <= nc; c += 4) {
    const double *g0 = column(c), *g1 = column(c + 1), *g2 = column(c + 2), *g3 = column(c + 3);
    const double* zc = z + 3 * c;
    sweep4(a0, g0, g1, g2, g3, zc[0], zc[3], zc[6], zc[9]);
    sweep4(a1, g0, g1, g2, g3, zc[1], zc[4], zc[7], zc[10]);
    sweep4(a2, g0, g1, g2, g3, zc[2], zc[5], zc[8], zc[11]);
  }
  for (; c < nc; ++c) {
    const double* g = column(c);
    const double z0 = z[3 * c], z1 = z[3 * c + 1], z2 = z[3 * c + 2];
    for (std::size_t i = 0; i < m; ++i) a0[i] += g[i] * z0;
    for (std::size_t i = 0; i < m; ++i) a1[i] += g[i] * z1;
    for (std::size_t i = 0; i < m; ++i) a2[i] += g[i] * z2;
  }
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
  for (std::size_t i = 0; i < std::size_t(nr - nc); ++i) {
    const double* x = y + 3 * std::size_t(rows[i]);
    xb[3 * i] = x[0], xb[3 * i + 1] = x[1], xb[3 * i + 2] = x[2];
  }
}

void SupernodalSolve::below(double* y, std::size_t t, int c0, int c1, const double* xb) const {
  const int f0 = f.first[t], nc = f.first[t + 1] - f0, nr = f.row_start[t + 1] - f.row_start[t];
  const double* G = f.values.data() + f.value_start[t];
  double* z = y + 3 * std::size_t(f0);
  const std::size_t m = std::size_t(nr - nc);
  // Two columns per sweep (each column's sum still runs over the rows ascending: the same bits as one).
  const auto column = [&](int c) { return G + std::size_t(c) * std::size_t(nr) + nc; };
  int c = c0;
  for (; c + 2 <= c1; c += 2) {
    const double *g0 = column(c), *g1 = column(c + 1);
    double s0 = 0, s1 = 0, s2 = 0, t0 = 0, t1 = 0, t2 = 0;
    for (std::size_t i = 0; i < m; ++i) {
      const double x0 = xb[3 * i], x1 = xb[3 * i + 1], x2 = xb[3 * i + 2];
      s0 += g0[i] * x0, s1 += g0[i] * x1, s2 += g0[i] * x2;
      t0 += g1[i] * x0, t1 += g1[i] * x1, t2 += g1[i] * x2;
    }
    z[3 * c] -= s0, z[3 * c + 1] -= s1, z[3 * c + 2] -= s2;
    z[3 * c + 3] -= t0, z[3 * c + 4] -= t1, z[3 * c + 5] -= t2;
  }
  for (; c < c1; ++c) {
    const double* g = column(c);
    double s0 = 0, s1 = 0, s2 = 0;
    for (std::size_t i = 0; i < m; ++i) s0 += g[i] * xb[3 * i], s1 += g[i] * xb[3 * i + 1], s2 += g[i] * xb[3 * i + 2];
    z[3 * c] -= s0, z[3 * c + 1] -= s1, z[3 * c + 2] -= s2;
  }
}

void SupernodalSolve::diagonal_back(double* y, std::size_t t) const {
  const int f0 = f.first[t], nc = f.first[t + 1] - f0, nr = f.row_start[t + 1] - f.row_start[t];
  const double* G = f.values.data() + f.value_start[t];
  double* z = y + 3 * std::size_t(f0);
  for (int j = nc; j-- > 0;) {
    const double* g = G + std::size_t(j) * std::size_t(nr);
    double v0 = z[3 * j], v1 = z[3 * j + 1], v2 = z[3 * j + 2];
    for (int r = j + 1; r < nc; ++r) v0 -= g[r] * z[3 * r], v1 -= g[r] * z[3 * r + 1], v2 -= g[r] * z[3 * r + 2];
    z[3 * j] = v0 / g[j], z[3 * j + 1] = v1 / g[j], z[3 * j + 2] = v2 / g[j];
  }
}

void SupernodalSolve::solve(std::vector<double>& yv, int threads, tbb::task_arena* arena) const {
  double* y = yv.data();
  const std::size_t parts = range_start.size() - 1;
  const auto nc = [&](std::size_t t) { return f.first[t + 1] - f.first[t]; };
  const auto nr = [&](std::size_t t) { return f.row_start[t + 1] - f.row_start[t]; };
  parallel_ranges(parts, threads, arena, [&](std::size_t k0, std::size_t k1) {
    for (std::size_t k = k0; k < k1; ++k)
      for (std::size_t q = range_start[k]; q < range_start[k + 1]; ++q)
        for (int t = ranges[q].first; t <= ranges[q].second; ++t)
          forward(y, std::size_t(t), nc(std::size_t(t)), top_start[std::size_t(t)], true, scratch[k].data());
  });
  // The top's large blocks (the dissection's top separators: a third of spot_loop3's entries) are shared by
  // the threads: rows of an update, or columns of a backward sum, in chunks (each row's or column's sum is
  // the same whichever chunk holds it). Only blocks of at least 1/64 of the entries: at most 64 more
  // joins of the threads per pass, each of which waits for a thread that a loaded machine may preempt.
  constexpr int kChunk = 256;
  const auto large = [&](std::size_t t) { return threads != 1 && double(nc(t)) * double(nr(t)) >= shared_from; };
  double* acc = scratch.back().data();
  for (const int t : tail) {
    const auto u = std::size_t(t);
    const int p0 = top_start[u], p1 = nr(u);
    const bool own = p0 == nc(u) && std::binary_search(top.begin(), top.end(), t);
    if (!large(u)) {
      forward(y, u, p0, p1, own, acc);
      continue;
    }
    forward(y, u, p0, p0, own, acc);
    parallel_ranges(std::size_t(p1 - p0 + kChunk - 1) / kChunk, threads, arena, [&](std::size_t k0, std::size_t k1) {
      const int q0 = p0 + int(k0) * kChunk, q1 = std::min(p1, p0 + int(k1) * kChunk);
      forward(y, u, q0, q1, false, acc + 3 * std::size_t(q0 - p0));
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
    diagonal_back(y, u);
  }
  parallel_ranges(parts, threads, arena, [&](std::size_t k0, std::size_t k1) {
    for (std::size_t k = k0; k < k1; ++k)
      for (std::size_t q = range_start[k]; q < range_start[k + 1]; ++q)
        for (int t = ranges[q].second; t >= ranges[q].first; --t) {
          const auto u = std::size_t(t);
          gather(y, u, scratch[k].data());
          below(y, u, 0, nc(u), scratch[k].data());
          diagonal_back(y, u);
        }
  });
}

std::size_t SupernodalSolve::memory_bytes() const {
  const auto bytes = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  std::size_t s = bytes(f.first) + bytes(f.row_start) + bytes(f.rows) + bytes(f.super_parent) + bytes(f.perm) +
                  bytes(f.value_start) + bytes(f.values) + bytes(top_start) + bytes(ranges) + bytes(range_start) +
                  bytes(top) + bytes(tail);
  for (const auto& v : scratch) s += bytes(v);
  return s;
}

}  // namespace mlsdeform::detail
