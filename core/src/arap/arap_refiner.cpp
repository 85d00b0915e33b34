// Surface ARAP (Sorkine & Alexa 2007) as a refinement of the MLS result: the session (arap.hpp documents the
// energy and the weights). Local step: one S_i per vertex, gathered over its one-ring (CSR), then all n
// rotation fits in one fit_rotations call (SIMD lanes). Global step: the reduced cotangent Laplacian of the
// free vertices, factorised once (Eigen's SimplicialLDLT, AMD ordering, in double), three right-hand sides
// solved in place with the factor's own permutation (so that nothing is allocated per frame).
#include "../parallel.hpp"

#include <mlsdeform/arap.hpp>
#include <mlsdeform/batch.hpp>

#include <Eigen/Geometry>  // cross
#include <Eigen/SparseCholesky>

#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace mlsdeform {

namespace {

using Vec3d = Eigen::Vector3d;
using PointsD = Eigen::Matrix<double, Eigen::Dynamic, 3>;

/// Vertices per task of the local step and the right-hand side (each vertex's work is its own: any cut gives
/// the same bits).
constexpr std::size_t kGrain = 1024;

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
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  std::vector<int> perm;  ///< the factor's permutation P (as indices): P b puts b(i) at perm[i]
  Eigen::VectorXd D;      ///< the factor's diagonal (vectorD() returns a copy: taken once)

  // Scratch, sized once.
  PointsD X;             ///< current positions
  std::vector<T> H, R;   ///< 3 x 3 x n, SoA, for fit_rotations
  Eigen::VectorXd y[3];  ///< the right-hand sides, permuted, solved in place

  void local_step() {
    const std::size_t nn = std::size_t(n);
    detail::parallel_ranges((nn + kGrain - 1) / kGrain, options.threads, arena.get(),
                            [&](std::size_t c0, std::size_t c1) {
                              for (std::size_t i = c0 * kGrain; i < std::min(nn, c1 * kGrain); ++i) {
                                double s[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
                                for (Eigen::Index e = start[i]; e < start[i + 1]; ++e) {
                                  const auto j = nbr[std::size_t(e)];
                                  const double we = w[std::size_t(e)];
                                  for (int r = 0; r < 3; ++r) {
                                    const double dx = we * (X(Eigen::Index(i), r) - X(j, r));
                                    for (int c = 0; c < 3; ++c) s[3 * r + c] += dx * (P(Eigen::Index(i), c) - P(j, c));
                                  }
                                }
                                for (int k = 0; k < 9; ++k) H[std::size_t(k) * nn + i] = T(s[k]);
                              }
                            });
    fit_rotations(H.data(), R.data(), nn, RotationMethod::axis_angle, options.threads);
  }

  /// R_i as a double matrix.
  Eigen::Matrix3d rotation(Eigen::Index i) const {
    Eigen::Matrix3d Ri;
    for (int k = 0; k < 9; ++k) Ri(k / 3, k % 3) = double(R[std::size_t(k) * std::size_t(n) + std::size_t(i)]);
    return Ri;
  }

  void global_step() {
    const std::size_t nf = free_vertices.size();
    detail::parallel_ranges((nf + kGrain - 1) / kGrain, options.threads, arena.get(),
                            [&](std::size_t c0, std::size_t c1) {
                              for (std::size_t f = c0 * kGrain; f < std::min(nf, c1 * kGrain); ++f) {
                                const Eigen::Index i = free_vertices[f];
                                const Eigen::Matrix3d Ri = rotation(i);
                                Vec3d bi = Vec3d::Zero();
                                for (Eigen::Index e = start[std::size_t(i)]; e < start[std::size_t(i) + 1]; ++e) {
                                  const Eigen::Index j = nbr[std::size_t(e)];
                                  const double we = w[std::size_t(e)];
                                  bi += (0.5 * we) * ((Ri + rotation(j)) * (P.row(i) - P.row(j)).transpose());
                                  if (row[std::size_t(j)] < 0) bi += we * X.row(j).transpose();  // held: to the right
                                }
                                // Permuted on the way in: y = P b.
                                for (int c = 0; c < 3; ++c) y[c](perm[f]) = bi[c];
                              }
                            });
    auto solve = [&](int c) {
      ldlt.matrixL().solveInPlace(y[c]);
      y[c].array() /= D.array();
      ldlt.matrixU().solveInPlace(y[c]);
    };
    if (options.threads == 1) {
      for (int c = 0; c < 3; ++c) solve(c);
    } else {
      auto all = [&] { tbb::parallel_invoke([&] { solve(0); }, [&] { solve(1); }, [&] { solve(2); }); };
      if (arena)
        arena->execute(all);
      else
        all();
    }
    for (std::size_t f = 0; f < nf; ++f)
      for (int c = 0; c < 3; ++c) X(free_vertices[f], c) = y[c](perm[f]);
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
  m.D = m.ldlt.vectorD();
  m.perm.resize(std::size_t(nf));
  for (Eigen::Index f = 0; f < nf; ++f) m.perm[std::size_t(f)] = m.ldlt.permutationP().indices()(f);

  m.X.resize(m.n, 3);
  m.H.assign(9 * nn, T(0));
  m.R.assign(9 * nn, T(0));
  for (auto& v : m.y) v.resize(nf);
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
  m.X = start.template cast<double>();
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
  const std::size_t factor =
      std::size_t(m.ldlt.matrixL().nestedExpression().nonZeros()) * (sizeof(double) + sizeof(int)) +
      std::size_t(m.ldlt.vectorD().size()) * (sizeof(double) + 3 * sizeof(int));
  return factor + m.P.size() * sizeof(double) + m.X.size() * sizeof(double) +
         (m.start.size() + m.nbr.size() + m.row.size() + m.free_vertices.size()) * sizeof(Eigen::Index) +
         m.w.size() * sizeof(double) + (m.H.size() + m.R.size()) * sizeof(T) +
         3 * std::size_t(m.y[0].size()) * sizeof(double) + m.perm.size() * sizeof(int) +
         std::size_t(m.D.size()) * sizeof(double);
}

template class ArapRefiner<float>;
template class ArapRefiner<double>;

}  // namespace mlsdeform
