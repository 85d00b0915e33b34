// Surface ARAP (Sorkine & Alexa 2007) as a refinement of the MLS result: the session (arap.hpp documents the
// energy and the weights). Local step: one S_i per vertex, gathered over its one-ring (CSR), and its rotation
// by the active ISA's batched fit (SIMD lanes), chunk by chunk. Global step: the reduced cotangent Laplacian of the
// free vertices, factorised once (Eigen's SimplicialLDLT, AMD ordering, in double); per iteration the three
// right-hand sides are solved together (interleaved) by forward and backward substitution, disjoint subtrees
// of the factor's elimination tree on the threads at once, with nothing allocated.
#include "../dispatch.hpp"
#include "../parallel.hpp"

#include <mlsdeform/arap.hpp>
#include <mlsdeform/batch.hpp>

#include <kernel_table.hpp>

#include <tbb/info.h>
#include <Eigen/Geometry>  // cross
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace mlsdeform {

namespace {

using Vec3d = Eigen::Vector3d;
using PointsD = Eigen::Matrix<double, Eigen::Dynamic, 3>;
using RowPoints = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// Vertices per task of the local step and the right-hand side (each vertex's work is its own: any cut gives
/// the same bits); small enough that a mesh of a few thousand vertices still splits evenly over the threads.
constexpr std::size_t kGrain = 256;

/// cot of the angle at c in the triangle (a, b, c), or 0 for a degenerate triangle (the sine below
/// 2^-40 of |u| |v|: the cotangent would be rounding noise, and huge).
double cotangent(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d u = a - c, v = b - c;
  const double cross = u.cross(v).norm(), scale = u.norm() * v.norm();
  if (!(cross > std::ldexp(scale, -40))) return 0;
  return u.dot(v) / cross;
}

struct Disjoint {
  std::vector<Eigen::Index> parent;
  explicit Disjoint(Eigen::Index n) : parent(static_cast<std::size_t>(n)) {
    std::iota(parent.begin(), parent.end(), Eigen::Index(0));
  }
  Eigen::Index find(Eigen::Index i) {
    while (parent[std::size_t(i)] != i) i = parent[std::size_t(i)] = parent[std::size_t(parent[std::size_t(i)])];
    return i;
  }
  void unite(Eigen::Index a, Eigen::Index b) { parent[std::size_t(find(a))] = find(b); }
};

}  // namespace

template <class T>
struct ArapRefiner<T>::Impl {
  Eigen::Index n = 0;
  ArapOptions options;
  std::unique_ptr<tbb::task_arena> arena;
  PointsD P;  ///< rest positions
  /// One-rings, CSR: the neighbours of i are nbr[start[i] .. start[i + 1]) with weights w, ascending.
  std::vector<Eigen::Index> start, nbr;
  std::vector<double> w;
  std::size_t clamped = 0;
  std::vector<Eigen::Index> constrained;
  /// Row of vertex i in the reduced system, or -1 for a vertex held fixed (constrained, or in a component
  /// with no constrained vertex: it keeps its start position).
  std::vector<Eigen::Index> row;
  std::vector<Eigen::Index> free_vertices;
  std::vector<int> perm;  ///< the factor's permutation P (as indices): P b puts b(i) at perm[i]
  /// The factor L D L^T of P L_ff P^T (Eigen stores L's strictly lower part by columns: the unit diagonal is
  /// implicit), and D, copied once (vectorD() returns a copy).
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  std::vector<double> D;
  /// Column c's entries in rows of the top part are L.innerIndex[top_start[c] .. Lp[c + 1]) (its rows
  /// ascend along its ancestors, the top's last); tail_cols: the columns with any, ascending.
  std::vector<int> top_start, tail_cols;
  /// The substitution's schedule (schedule() builds it): factor rows part by part, ascending in each part;
  /// part k is order[part_start[k] .. part_start[k + 1]). Parts 0 .. parts - 1 are disjoint sets of subtrees
  /// of the elimination tree, part `parts` (the top) holds all their ancestors.
  std::vector<int> order;
  std::vector<std::size_t> part_start;
  std::size_t parts = 0;
  std::vector<Eigen::Index> vertex_of;  ///< the free vertex of factor row r (the inverse of perm)
  std::vector<double> we;               ///< w_ij (p_i - p_j) per directed edge (3 values), in the CSR order
  std::vector<double> c;                ///< c_i = sum_j w_ij (p_i - p_j) per vertex (3 values)

  // Scratch, sized once.
  RowPoints X;             ///< current positions
  std::vector<T> H, R;     ///< 3 x 3 x n, SoA, for fit_rotations
  std::vector<double> Rd;  ///< R_i in double, row-major, 9 values per vertex
  std::vector<double> y;   ///< the three right-hand sides, permuted and interleaved (3 values per row)

  /// For every vertex S_i = sum_j w_ij (x_i - x_j)(p_i - p_j)^T and its rotation R_i, by the active kernel
  /// table's batched axis/angle fit on each chunk of vertices (one parallel pass: S, fit, R in double).
  void local_step() {
    const std::size_t nn = std::size_t(n);
    kernels::FitRotationsFn<T> fit;
    if constexpr (std::is_same_v<T, float>)
      fit = detail::active_kernels().fit_axis_angle_f;
    else
      fit = detail::active_kernels().fit_axis_angle_d;
    detail::parallel_ranges((nn + kGrain - 1) / kGrain, options.threads, arena.get(),
                            [&](std::size_t c0, std::size_t c1) {
                              const std::size_t i0 = c0 * kGrain, i1 = std::min(nn, c1 * kGrain);
                              for (std::size_t i = i0; i < i1; ++i) {
                                // Nine named sums: an array here is packed into pairs and shuffled by the
                                // compiler, slower than the plain scalar code.
                                double s0 = 0, s1 = 0, s2 = 0, s3 = 0, s4 = 0, s5 = 0, s6 = 0, s7 = 0, s8 = 0;
                                const double* xi = X.data() + 3 * i;
                                for (Eigen::Index e = start[i]; e < start[i + 1]; ++e) {
                                  const double* xj = X.data() + 3 * nbr[std::size_t(e)];
                                  const double* a = we.data() + 3 * e;
                                  const double d0 = xi[0] - xj[0], d1 = xi[1] - xj[1], d2 = xi[2] - xj[2];
                                  s0 += d0 * a[0], s1 += d0 * a[1], s2 += d0 * a[2];
                                  s3 += d1 * a[0], s4 += d1 * a[1], s5 += d1 * a[2];
                                  s6 += d2 * a[0], s7 += d2 * a[1], s8 += d2 * a[2];
                                }
                                const double s[9] = {s0, s1, s2, s3, s4, s5, s6, s7, s8};
                                for (int k = 0; k < 9; ++k) H[std::size_t(k) * nn + i] = T(s[k]);
                              }
                              fit(H.data(), R.data(), nn, i0, i1, nullptr);  // S_i is finite: X is
                              for (std::size_t i = i0; i < i1; ++i)
                                for (std::size_t k = 0; k < 9; ++k) Rd[9 * i + k] = double(R[k * nn + i]);
                            });
  }

  /// L z = y, in place in y, column by column: z_c is final once the columns before it are done, and goes
  /// to y_r -= L_rc z_c for the rows r of entries [p0(c), p1(c)) of column c, for the columns c of cols.
  template <class Cols, class First, class Last>
  void forward(const Cols& cols, First p0, Last p1) {
    const auto& L = ldlt.matrixL().nestedExpression();
    const int* Li = L.innerIndexPtr();
    const double* Lx = L.valuePtr();
    for (const auto col : cols) {
      const auto k = 3 * std::size_t(col);
      const double z0 = y[k], z1 = y[k + 1], z2 = y[k + 2];
      for (int p = p0(col); p < p1(col); ++p) {
        double* t = y.data() + 3 * std::size_t(Li[p]);
        t[0] -= Lx[p] * z0, t[1] -= Lx[p] * z1, t[2] -= Lx[p] * z2;
      }
    }
  }

  /// x_c = z_c / D_c - sum_r L_rc x_r for the columns order[k0 .. k1), last first, in place in y; each x_c
  /// also goes to its vertex's row of X.
  void backward(std::size_t k0, std::size_t k1) {
    const auto& L = ldlt.matrixL().nestedExpression();
    const int *Lp = L.outerIndexPtr(), *Li = L.innerIndexPtr();
    const double* Lx = L.valuePtr();
    for (std::size_t k = k1; k-- > k0;) {
      const auto col = std::size_t(order[k]);
      double x0 = y[3 * col] / D[col], x1 = y[3 * col + 1] / D[col], x2 = y[3 * col + 2] / D[col];
      for (int p = Lp[col]; p < Lp[col + 1]; ++p) {
        const double* t = y.data() + 3 * std::size_t(Li[p]);
        x0 -= Lx[p] * t[0], x1 -= Lx[p] * t[1], x2 -= Lx[p] * t[2];
      }
      y[3 * col] = x0, y[3 * col + 1] = x1, y[3 * col + 2] = x2;
      const Eigen::Index v = vertex_of[col];
      X(v, 0) = x0, X(v, 1) = x1, X(v, 2) = x2;
    }
  }

  /// Builds the schedule for `bins` threads, and top_start and tail_cols: the roots of the elimination
  /// tree (parent(j) = the first row below the diagonal in column j) are spread over the bins, heaviest
  /// first onto the lightest bin (work = entries + 2 per row); then the heaviest subtree is split, its root
  /// moving to the top and its children into the spread, for as long as that shortens the longest path
  /// (top + heaviest bin). Any schedule gives the same bits; this one only balances the threads.
  void schedule(std::size_t bins) {
    const auto& L = ldlt.matrixL().nestedExpression();
    const int *Lp = L.outerIndexPtr(), *Li = L.innerIndexPtr();
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
    for (std::size_t j = 0; j < m; ++j)
      (parent[j] >= 0 ? children[std::size_t(parent[j])] : frontier).push_back(int(j));
    const auto heavier = [&](int a, int b) {
      const std::size_t wa = subtree[std::size_t(a)], wb = subtree[std::size_t(b)];
      return wa != wb ? wa > wb : a < b;
    };
    std::vector<int> top, best_frontier, bin_of, best_bin;
    std::vector<std::size_t> load(bins);
    std::size_t top_work = 0, best = ~std::size_t(0), best_top = 0;
    // A surface's top separators hold some sqrt(m) rows (137 of the bundled body's 6,882): the cap only
    // bounds the set-up's time on odd meshes.
    for (int split = 0; split < 1024 && !frontier.empty() && top_work < best; ++split) {
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

  /// b_i = sum_j (w_ij / 2)(R_i + R_j)(p_i - p_j) = (R_i c_i + sum_j R_j w_ij (p_i - p_j)) / 2, plus w_ij x_j
  /// for each held neighbour; then L_ff x = b by the factor (forward, diagonal, backward substitution on the
  /// three interleaved right-hand sides at once).
  void global_step() {
    const std::size_t nf = free_vertices.size();
    auto rotate_add = [](const double* Rm, const double* v, double(&b)[3]) {
      for (int r = 0; r < 3; ++r) b[r] += 0.5 * (Rm[3 * r] * v[0] + Rm[3 * r + 1] * v[1] + Rm[3 * r + 2] * v[2]);
    };
    detail::parallel_ranges((nf + kGrain - 1) / kGrain, options.threads, arena.get(),
                            [&](std::size_t c0, std::size_t c1) {
                              for (std::size_t f = c0 * kGrain; f < std::min(nf, c1 * kGrain); ++f) {
                                const auto i = std::size_t(free_vertices[f]);
                                double b[3] = {0, 0, 0};
                                rotate_add(Rd.data() + 9 * i, c.data() + 3 * i, b);
                                for (Eigen::Index e = start[i]; e < start[i + 1]; ++e) {
                                  const auto j = std::size_t(nbr[std::size_t(e)]);
                                  rotate_add(Rd.data() + 9 * j, we.data() + 3 * e, b);
                                  if (row[j] < 0)  // held: to the right-hand side
                                    for (int k = 0; k < 3; ++k) b[k] += w[std::size_t(e)] * X(Eigen::Index(j), k);
                                }
                                for (int k = 0; k < 3; ++k) y[3 * std::size_t(perm[f]) + std::size_t(k)] = b[k];
                              }
                            });
    // L z = y (unit lower), then D^-1 and L^T x = z. Row r of L has entries only in columns that descend from
    // r in the elimination tree, column c only in rows that are its ancestors: the parts' subtrees share no
    // row. Forward: each part's columns scatter into their rows below the top, in parallel; then every column
    // with entries in the top rows scatters into them, ascending. Backward gathers, the top first. Every y_r
    // receives its terms in one order whatever the schedule (ascending columns; then ascending rows): the
    // same bits for any thread count.
    const auto& L = ldlt.matrixL().nestedExpression();
    const int* Lp = L.outerIndexPtr();
    const auto first = [&](int col) { return Lp[col]; };
    const auto below_top = [&](int col) { return top_start[std::size_t(col)]; };
    const auto last = [&](int col) { return Lp[col + 1]; };
    detail::parallel_ranges(parts, options.threads, arena.get(), [&](std::size_t k0, std::size_t k1) {
      for (std::size_t k = k0; k < k1; ++k)
        forward(std::span<const int>(order.data() + part_start[k], order.data() + part_start[k + 1]), first, below_top);
    });
    forward(tail_cols, below_top, last);
    backward(part_start[parts], part_start[parts + 1]);
    detail::parallel_ranges(parts, options.threads, arena.get(), [&](std::size_t k0, std::size_t k1) {
      for (std::size_t k = k0; k < k1; ++k) backward(part_start[k], part_start[k + 1]);
    });
  }
};

template <class T>
ArapRefiner<T>::ArapRefiner(const Points<T>& rest, const Triangles& triangles,
                            std::span<const Eigen::Index> constrained, const ArapOptions& options)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.n = rest.rows();
  m.options = options;
  if (options.threads < 0)
    throw std::invalid_argument("ArapRefiner: threads must be >= 0 (got " + std::to_string(options.threads) + ")");
  if (!rest.allFinite()) throw std::invalid_argument("ArapRefiner: non-finite rest vertex coordinate");
  m.arena = detail::make_arena(options.threads);
  m.P = rest.template cast<double>();
  const std::size_t nn = std::size_t(m.n);

  // Cotangent weights per undirected edge, as (min, max) pairs, merged over the triangles sharing the edge.
  std::vector<std::pair<std::pair<Eigen::Index, Eigen::Index>, double>> edges;
  edges.reserve(std::size_t(triangles.rows()) * 3);
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    for (int k = 0; k < 3; ++k)
      if (triangles(f, k) < 0 || triangles(f, k) >= m.n)
        throw std::invalid_argument("ArapRefiner: triangle " + std::to_string(f) + " has vertex index " +
                                    std::to_string(triangles(f, k)) + ", outside [0, " + std::to_string(m.n) + ")");
    for (int k = 0; k < 3; ++k) {
      const Eigen::Index a = triangles(f, k), b = triangles(f, (k + 1) % 3), c = triangles(f, (k + 2) % 3);
      if (a == b) continue;  // a repeated corner: no edge
      edges.push_back({{std::min(a, b), std::max(a, b)},
                       a == c || b == c ? 0.0 : 0.5 * cotangent(m.P.row(a), m.P.row(b), m.P.row(c))});
    }
  }
  std::sort(edges.begin(), edges.end());
  std::vector<std::pair<std::pair<Eigen::Index, Eigen::Index>, double>> merged;
  for (const auto& e : edges) {
    if (!merged.empty() && merged.back().first == e.first)
      merged.back().second += e.second;
    else
      merged.push_back(e);
  }
  double sum = 0;
  for (auto& e : merged) {
    if (e.second < 0) ++m.clamped, e.second = 0;
    sum += e.second;
  }
  const double floor = merged.empty() || sum == 0 ? 1.0 : 1e-6 * sum / double(merged.size());
  for (auto& e : merged) e.second += floor;

  // CSR one-rings: both directions of every edge, sorted by (vertex, neighbour).
  std::vector<std::pair<std::pair<Eigen::Index, Eigen::Index>, double>> directed;
  directed.reserve(2 * merged.size());
  for (const auto& e : merged) {
    directed.push_back(e);
    directed.push_back({{e.first.second, e.first.first}, e.second});
  }
  std::sort(directed.begin(), directed.end());
  m.start.assign(nn + 1, 0);
  for (const auto& e : directed) ++m.start[std::size_t(e.first.first) + 1];
  for (std::size_t i = 0; i < nn; ++i) m.start[i + 1] += m.start[i];
  for (const auto& e : directed) m.nbr.push_back(e.first.second), m.w.push_back(e.second);
  m.we.assign(3 * m.nbr.size(), 0.0);
  m.c.assign(3 * nn, 0.0);
  for (std::size_t i = 0; i < nn; ++i)
    for (Eigen::Index e = m.start[i]; e < m.start[i + 1]; ++e)
      for (int k = 0; k < 3; ++k) {
        const double v = m.w[std::size_t(e)] * (m.P(Eigen::Index(i), k) - m.P(m.nbr[std::size_t(e)], k));
        m.we[3 * std::size_t(e) + std::size_t(k)] = v;
        m.c[3 * i + std::size_t(k)] += v;
      }

  // Constrained vertices; components without one are held at the start position.
  std::vector<char> is_constrained(nn, 0);
  for (const Eigen::Index c : constrained) {
    if (c < 0 || c >= m.n)
      throw std::invalid_argument("ArapRefiner: constrained vertex " + std::to_string(c) + " outside [0, " +
                                  std::to_string(m.n) + ")");
    if (is_constrained[std::size_t(c)])
      throw std::invalid_argument("ArapRefiner: vertex " + std::to_string(c) + " is constrained twice");
    is_constrained[std::size_t(c)] = 1;
    m.constrained.push_back(c);
  }
  Disjoint components(m.n);
  for (const auto& e : merged) components.unite(e.first.first, e.first.second);
  std::vector<char> anchored(nn, 0);
  for (const Eigen::Index c : m.constrained) anchored[std::size_t(components.find(c))] = 1;
  m.row.assign(nn, -1);
  for (std::size_t i = 0; i < nn; ++i)
    if (!is_constrained[i] && anchored[std::size_t(components.find(Eigen::Index(i)))]) {
      m.row[i] = Eigen::Index(m.free_vertices.size());
      m.free_vertices.push_back(Eigen::Index(i));
    }

  // The reduced Laplacian L_ff: L_ii = sum_j w_ij, L_ij = -w_ij between free vertices.
  const Eigen::Index nf = Eigen::Index(m.free_vertices.size());
  std::vector<Eigen::Triplet<double>> entries;
  for (const Eigen::Index i : m.free_vertices) {
    double diag = 0;
    for (Eigen::Index e = m.start[std::size_t(i)]; e < m.start[std::size_t(i) + 1]; ++e) {
      diag += m.w[std::size_t(e)];
      const Eigen::Index rj = m.row[std::size_t(m.nbr[std::size_t(e)])];
      if (rj >= 0) entries.emplace_back(m.row[std::size_t(i)], rj, -m.w[std::size_t(e)]);
    }
    entries.emplace_back(m.row[std::size_t(i)], m.row[std::size_t(i)], diag);
  }
  Eigen::SparseMatrix<double> L(nf, nf);
  L.setFromTriplets(entries.begin(), entries.end());
  m.ldlt.compute(L);
  if (m.ldlt.info() != Eigen::Success)
    throw std::invalid_argument("ArapRefiner: the cotangent Laplacian could not be factorised");
  const Eigen::VectorXd d = m.ldlt.vectorD();
  m.D.assign(d.data(), d.data() + d.size());
  m.perm.resize(std::size_t(nf));
  for (Eigen::Index f = 0; f < nf; ++f) m.perm[std::size_t(f)] = m.ldlt.permutationP().indices()(f);
  m.vertex_of.resize(std::size_t(nf));
  for (std::size_t f = 0; f < std::size_t(nf); ++f) m.vertex_of[std::size_t(m.perm[f])] = m.free_vertices[f];
  // One part per thread the local step may use (detail::make_arena's rule).
  const int cores = tbb::info::default_concurrency();
  m.schedule(options.threads == 1 ? 1 : std::size_t(options.threads == 0 ? cores : std::min(options.threads, cores)));

  m.X.resize(m.n, 3);
  m.H.assign(9 * nn, T(0));
  m.R.assign(9 * nn, T(0));
  m.Rd.assign(9 * nn, 0.0);
  m.y.assign(3 * std::size_t(nf), 0.0);
}

template <class T>
ArapRefiner<T>::~ArapRefiner() = default;
template <class T>
ArapRefiner<T>::ArapRefiner(ArapRefiner&&) noexcept = default;
template <class T>
ArapRefiner<T>& ArapRefiner<T>::operator=(ArapRefiner&&) noexcept = default;

template <class T>
void ArapRefiner<T>::refine(const Points<T>& start, const Points<T>& targets, int iterations, Points<T>& out) {
  if (!impl_) throw std::logic_error("ArapRefiner: this session was moved from");
  Impl& m = *impl_;
  if (start.rows() != m.n)
    throw std::invalid_argument("ArapRefiner::refine: start has " + std::to_string(start.rows()) +
                                " rows but the mesh has " + std::to_string(m.n) + " vertices");
  if (targets.rows() != Eigen::Index(m.constrained.size()))
    throw std::invalid_argument("ArapRefiner::refine: " + std::to_string(targets.rows()) + " targets for " +
                                std::to_string(m.constrained.size()) + " constrained vertices");
  if (iterations < 0)
    throw std::invalid_argument("ArapRefiner::refine: iterations must be >= 0 (got " + std::to_string(iterations) +
                                ")");
  if (!start.allFinite() || !targets.allFinite())
    throw std::invalid_argument("ArapRefiner::refine: non-finite coordinate in start or targets");
  m.X = start.template cast<double>();  // row-major copy
  for (std::size_t k = 0; k < m.constrained.size(); ++k)
    m.X.row(m.constrained[k]) = targets.row(Eigen::Index(k)).template cast<double>();
  for (int it = 0; it < iterations; ++it) {
    m.local_step();
    m.global_step();
  }
  if (out.rows() != m.n) out.resize(m.n, 3);
  out = m.X.template cast<T>();
}

template <class T>
double ArapRefiner<T>::energy(const Points<T>& x) const {
  if (!impl_) throw std::logic_error("ArapRefiner: this session was moved from");
  const Impl& m = *impl_;
  if (x.rows() != m.n) throw std::invalid_argument("ArapRefiner::energy: wrong number of rows");
  const PointsD X = x.template cast<double>();
  double E = 0;
  for (Eigen::Index i = 0; i < m.n; ++i) {
    const auto ring = [&](auto&& f) {
      for (Eigen::Index e = m.start[std::size_t(i)]; e < m.start[std::size_t(i) + 1]; ++e)
        f(m.w[std::size_t(e)], (X.row(i) - X.row(m.nbr[std::size_t(e)])).transpose().eval(),
          (m.P.row(i) - m.P.row(m.nbr[std::size_t(e)])).transpose().eval());
    };
    Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
    ring([&](double we, const Vec3d& d, const Vec3d& p) { S += we * d * p.transpose(); });
    const Eigen::Matrix3d Ri = fit_rotation<double>(S);  // the local step's rotation, in double
    ring([&](double we, const Vec3d& d, const Vec3d& p) { E += we * (d - Ri * p).squaredNorm(); });
  }
  return E;
}

template <class T>
Eigen::Index ArapRefiner<T>::vertex_count() const {
  return impl_ ? impl_->n : 0;
}

template <class T>
std::size_t ArapRefiner<T>::clamped_weights() const {
  return impl_ ? impl_->clamped : 0;
}

template <class T>
std::size_t ArapRefiner<T>::memory_bytes() const {
  if (!impl_) return 0;
  const Impl& m = *impl_;
  const auto bytes = [](const auto& v) { return v.size() * sizeof(v[0]); };
  const auto& L = m.ldlt.matrixL().nestedExpression();
  // The factor: L (by columns), its diagonal (twice: Eigen's and the copy) and its two
  // permutations (about one more D).
  return std::size_t(L.nonZeros()) * (sizeof(double) + sizeof(int)) + std::size_t(L.outerSize() + 1) * sizeof(int) +
         bytes(m.top_start) + bytes(m.tail_cols) + bytes(m.order) + bytes(m.part_start) + bytes(m.vertex_of) +
         3 * bytes(m.D) + bytes(m.perm) + bytes(m.start) + bytes(m.nbr) + bytes(m.w) + bytes(m.we) + bytes(m.c) +
         bytes(m.row) + bytes(m.free_vertices) + bytes(m.H) + bytes(m.R) + bytes(m.Rd) + bytes(m.y) +
         std::size_t(m.P.size() + m.X.size()) * sizeof(double);
}

template class ArapRefiner<float>;
template class ArapRefiner<double>;

}  // namespace mlsdeform
