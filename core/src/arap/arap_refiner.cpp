// Surface ARAP (Sorkine & Alexa 2007) as a refinement of the MLS result: the session (arap.hpp documents the
// energy and the weights). Local step: one S_i per vertex, summed over its one-ring by the active ISA's
// ring_correlation (SIMD lanes over padded blocks of the one-rings, or the scalar reference over the CSR), and
// its rotation by the active ISA's batched fit, chunk by chunk. Global step: the reduced cotangent Laplacian of the
// free vertices, factorised once and solved for the three right-hand sides per iteration (subtree_ldlt.hpp),
// with nothing allocated.
//
// Units. The session works on the rest pose scaled by 2^-e, e = ilogb of its largest coordinate, and each
// refine() on the positions scaled by 2^-f, f = max(e, ilogb of their largest coordinate): every number of
// the problem (cotangent weights, the one-ring vectors w_ij (p_i - p_j), S_i, the right-hand sides, the
// solution) is then of order one, so nothing overflows or underflows at any scale, and scaling the whole
// input by a power of two 2^k shifts e and f by k and changes no bit of the scaled problem: the result is
// the unscaled one times 2^k, rounded once to T. (The rest terms of b, in units of 2^e, enter the system in
// units of 2^f through the factor 2^(e - f) <= 1, which is itself scale-free.)
#include "core/src/arap/anderson.hpp"
#include "core/src/arap/one_rings.hpp"
#include "core/src/arap/ring_correlation.hpp"
#include "core/src/arap/ring_energy.hpp"
#include "core/src/arap/subtree_ldlt.hpp"
#include "core/src/dispatch.hpp"
#include "core/src/huge_pages.hpp"
#include "core/src/parallel.hpp"
#include "core/src/pow2.hpp"
#include "core/src/threading.hpp"

#include <mlsdeform/arap.hpp>
#include <mlsdeform/fit_rotations.hpp>

#include "kernels/kernel_table.hpp"

#include <Eigen/SparseCore>

#include <algorithm>
#include <cmath>
#include <limits>
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
static_assert(kGrain % kernels::kLanes == 0, "a task of the local step is whole blocks of the one-ring sums");

}  // namespace

template <class T>
struct ArapRefiner<T>::Impl {
  Eigen::Index n = 0;
  ArapOptions options;
  std::unique_ptr<tbb::task_arena> arena;
  int rest_e = 0;  ///< the rest pose's exponent e (Units above)
  PointsD P;       ///< rest positions times 2^-e
  /// One-rings, CSR: the neighbours of i are nbr[start[i] .. start[i + 1]) with weights w, ascending.
  std::vector<Eigen::Index> start, nbr;
  std::vector<double> w;
  std::size_t clamped = 0;
  std::vector<Eigen::Index> constrained;
  /// Row of vertex i in the reduced system, or -1 for a vertex held fixed (constrained, or in a component
  /// with no constrained vertex: it keeps its start position).
  std::vector<Eigen::Index> row;
  std::vector<Eigen::Index> free_vertices;
  /// The held neighbours of free vertex f (their terms w_ij x_j go to the right-hand side), in the CSR
  /// order: held_nbr[held_start[f] .. held_start[f + 1]), their weights in held_w.
  std::vector<std::size_t> held_start;
  std::vector<Eigen::Index> held_nbr;
  std::vector<double> held_w;
  detail::SubtreeLdlt solver;  ///< L_ff, factorised
  std::vector<double> we;      ///< w_ij (p_i - p_j) per directed edge (3 values), in the CSR order; units 2^e
  std::vector<double> c;       ///< c_i = sum_j w_ij (p_i - p_j) per vertex (3 values); units 2^e
  detail::PaddedRings padded;  ///< the one-rings and `we` in blocks, for the SIMD sums (ring_correlation.hpp)

  // Scratch, sized once.
  RowPoints X;           ///< current positions times 2^-f (refine), the caller's units after it
  bool refined = false;  ///< X holds a refine()'s result
  double rest_to_x = 1;  ///< 2^(e - f): the rest terms of b in the units of X
  std::vector<T> H, R;   ///< 3 x 3 x n, SoA, for fit_rotations
  /// R_i^T row-major (R_i's columns side by side, as ring_rhs reads them), 9 values per vertex and one of
  /// padding, in T: the global step reads a neighbour's R_j at random, and float halves those bytes (each value is
  /// widened to double exactly where it is used, as a double copy was).
  std::vector<T> Rd;
  std::vector<double> bsum;  ///< the global step's rotated sums b_i per vertex (3 values), units 2^e
  std::vector<double> y;     ///< the three right-hand sides, permuted and interleaved (3 values per row)
  std::unique_ptr<detail::Anderson> anderson;  ///< ArapAcceleration::anderson only, with `energy`
  detail::RingEnergy energy;

  /// For every vertex S_i = sum_j w_ij (x_i - x_j)(p_i - p_j)^T, normalised to a power of two, by the active
  /// kernel table's ring_correlation (ring_correlation.hpp), and its rotation R_i, by the table's batched
  /// axis/angle fit, chunk by chunk (one parallel pass: S, fit, R row-major). With `with_energy`, returns
  /// E(x, R) in the units of X squared (ring_energy.hpp).
  double local_step(bool with_energy = false) {
    const std::size_t nn = std::size_t(n);
    const kernels::KernelTable& table = detail::active_kernels();
    kernels::FitRotationsFn<T> fit;
    kernels::RingCorrelationFn<T> sums;
    if constexpr (std::is_same_v<T, float>)
      fit = table.fit_axis_angle_f, sums = table.ring_correlation_f;
    else
      fit = table.fit_axis_angle_d, sums = table.ring_correlation_d;
    const kernels::RingFrame<T> frame = detail::ring_frame<T>(nn, X.data(), start, nbr, w, we, padded, H.data(),
                                                              with_energy ? energy.ring.data() : nullptr);
    detail::parallel_ranges((nn + kGrain - 1) / kGrain, options.threads, arena.get(),
                            [&](std::size_t c0, std::size_t c1) {
                              const std::size_t i0 = c0 * kGrain, i1 = std::min(nn, c1 * kGrain);
                              sums(frame, i0 / kernels::kLanes, (i1 + kernels::kLanes - 1) / kernels::kLanes);
                              fit(H.data(), R.data(), nn, i0, i1, nullptr);  // S_i is finite: X is
                              for (std::size_t i = i0; i < i1; ++i)
                                for (std::size_t k = 0; k < 9; ++k) Rd[9 * i + k] = R[(3 * (k % 3) + k / 3) * nn + i];
                              if (with_energy) energy.finish(c0, c1, kGrain, nn, Rd.data(), rest_to_x);
                            });
    return with_energy ? energy.total() : 0.0;
  }

  /// b_i = sum_j (w_ij / 2)(R_i + R_j)(p_i - p_j) = (R_i c_i + sum_j R_j w_ij (p_i - p_j)) / 2, by the active
  /// kernel table's ring_rhs (ring_correlation.hpp), in the units of X (times rest_to_x), plus w_ij x_j for each
  /// held neighbour; then L_ff x = b by the factor (forward, diagonal, backward substitution on the three
  /// interleaved right-hand sides at once).
  void global_step() {
    const std::size_t nn = std::size_t(n), nf = free_vertices.size();
    const kernels::KernelTable& table = detail::active_kernels();
    kernels::RingCorrelationFn<T> sums;
    if constexpr (std::is_same_v<T, float>)
      sums = table.ring_rhs_f;
    else
      sums = table.ring_rhs_d;
    const kernels::RingFrame<T> frame = detail::ring_frame<T>(nn, X.data(), start, nbr, w, we, padded, nullptr, nullptr,
                                                              Rd.data(), c.data(), bsum.data());
    detail::parallel_ranges(
        (nn + kGrain - 1) / kGrain, options.threads, arena.get(), [&](std::size_t c0, std::size_t c1) {
          const std::size_t i0 = c0 * kGrain, i1 = std::min(nn, c1 * kGrain);
          sums(frame, i0 / kernels::kLanes, (i1 + kernels::kLanes - 1) / kernels::kLanes);
          for (std::size_t i = i0; i < i1; ++i) {
            const Eigen::Index f = row[i];
            if (f < 0) continue;
            double b[3];
            for (int k = 0; k < 3; ++k) b[k] = bsum[3 * i + std::size_t(k)] * rest_to_x;
            for (std::size_t e = held_start[std::size_t(f)]; e < held_start[std::size_t(f) + 1]; ++e)
              for (int k = 0; k < 3; ++k) b[k] += held_w[e] * X(held_nbr[e], k);
            for (int k = 0; k < 3; ++k) y[3 * std::size_t(solver.row_of(f)) + std::size_t(k)] = b[k];
          }
        });
    solver.solve(y, options.threads, arena.get());
    detail::parallel_ranges((nf + kGrain - 1) / kGrain, options.threads, arena.get(),
                            [&](std::size_t c0, std::size_t c1) {
                              for (std::size_t f = c0 * kGrain; f < std::min(nf, c1 * kGrain); ++f) {
                                const double* x = y.data() + 3 * std::size_t(solver.row_of(Eigen::Index(f)));
                                const Eigen::Index v = free_vertices[f];
                                X(v, 0) = x[0], X(v, 1) = x[1], X(v, 2) = x[2];
                              }
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
  if (options.factorisation == ArapFactorisation::supernodal && !detail::supernodal_available())
    throw std::invalid_argument(
        "ArapRefiner: ArapFactorisation::supernodal is not in this build (configure with -DMLSDEFORM_CHOLMOD=ON)");
  if (options.threads < 0)
    throw std::invalid_argument("ArapRefiner: threads must be >= 0 (got " + std::to_string(options.threads) + ")");
  if (!rest.allFinite()) throw std::invalid_argument("ArapRefiner: non-finite rest vertex coordinate");
  m.arena = detail::make_arena(options.threads);
  m.P = rest.template cast<double>();
  m.rest_e = detail::exponent_of(m.P.cwiseAbs().maxCoeff());
  for (Eigen::Index i = 0; i < m.P.size(); ++i) m.P.data()[i] = std::ldexp(m.P.data()[i], -m.rest_e);
  const std::size_t nn = std::size_t(m.n);

  // The set-up's large arrays are first touched on the session's threads (huge_pages.hpp, touch_pages).
  const int threads = options.threads;
  tbb::task_arena* const arena = m.arena.get();
  detail::OneRings rings = detail::cotangent_one_rings(m.P, triangles, threads, arena);
  m.start = std::move(rings.start), m.nbr = std::move(rings.nbr), m.w = std::move(rings.w);
  m.clamped = rings.clamped;
  detail::assign_huge(m.we, 3 * m.nbr.size(), 0.0, threads, arena);
  detail::assign_huge(m.c, 3 * nn, 0.0, threads, arena);
  for (std::size_t i = 0; i < nn; ++i)
    for (Eigen::Index e = m.start[i]; e < m.start[i + 1]; ++e)
      for (int k = 0; k < 3; ++k) {
        const double v = m.w[std::size_t(e)] * (m.P(Eigen::Index(i), k) - m.P(m.nbr[std::size_t(e)], k));
        m.we[3 * std::size_t(e) + std::size_t(k)] = v;
        m.c[3 * i + std::size_t(k)] += v;
      }
  m.padded = detail::pad_one_rings(m.start, m.nbr, m.w, m.we, threads, arena);

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
  detail::Disjoint components(m.n);
  for (std::size_t i = 0; i < nn; ++i)
    for (Eigen::Index e = m.start[i]; e < m.start[i + 1]; ++e) components.unite(Eigen::Index(i), m.nbr[std::size_t(e)]);
  std::vector<char> anchored(nn, 0);
  for (const Eigen::Index c : m.constrained) anchored[std::size_t(components.find(c))] = 1;
  m.row.assign(nn, -1);
  for (std::size_t i = 0; i < nn; ++i)
    if (!is_constrained[i] && anchored[std::size_t(components.find(Eigen::Index(i)))]) {
      m.row[i] = Eigen::Index(m.free_vertices.size());
      m.free_vertices.push_back(Eigen::Index(i));
    }

  const Eigen::Index nf = Eigen::Index(m.free_vertices.size());
  m.held_start.assign(1, 0);
  for (const Eigen::Index i : m.free_vertices) {
    for (Eigen::Index e = m.start[std::size_t(i)]; e < m.start[std::size_t(i) + 1]; ++e)
      if (m.row[std::size_t(m.nbr[std::size_t(e)])] < 0)
        m.held_nbr.push_back(m.nbr[std::size_t(e)]), m.held_w.push_back(m.w[std::size_t(e)]);
    m.held_start.push_back(m.held_nbr.size());
  }
  const Eigen::SparseMatrix<double> L =
      detail::reduced_laplacian({m.start, m.nbr, m.w}, m.row, m.free_vertices, threads, arena);
  // One part of the substitution per thread the local step may use (detail::make_arena's rule).
  const int cores = tbb::info::default_concurrency();
  const std::size_t bins =
      options.threads == 1 ? 1 : std::size_t(options.threads == 0 ? cores : std::min(options.threads, cores));
  using Method = detail::SubtreeLdlt::Method;
  const ArapFactorisation chosen = options.factorisation != ArapFactorisation::automatic ? options.factorisation
                                   : detail::supernodal_available()                      ? ArapFactorisation::supernodal
                                                                    : ArapFactorisation::supernodal_mit;
  const Method method = chosen == ArapFactorisation::supernodal       ? Method::supernodal
                        : chosen == ArapFactorisation::supernodal_mit ? Method::supernodal_mit
                                                                      : Method::simplicial;
  const bool supernodal = method != Method::simplicial;
  PointsD free_points;  // the supernodal factorisation orders the rows by their points
  if (supernodal) {
    free_points.resize(nf, 3);
    for (Eigen::Index f = 0; f < nf; ++f) free_points.row(f) = m.P.row(m.free_vertices[std::size_t(f)]);
  }
  if (!m.solver.compute(L, bins, method, supernodal ? &free_points : nullptr))
    throw std::invalid_argument("ArapRefiner: the cotangent Laplacian could not be factorised");

  m.X.resize(m.n, 3);
  detail::assign_huge(m.H, 9 * nn, T(0), threads, arena);
  detail::assign_huge(m.R, 9 * nn, T(0), threads, arena);
  detail::assign_huge(m.Rd, 9 * nn + 1, T(0), threads, arena);  // + 1: ring_rhs's padding (RingFrame)
  detail::assign_huge(m.bsum, 3 * nn, 0.0, threads, arena);
  detail::assign_huge(m.y, 3 * std::size_t(nf), 0.0, threads, arena);
  if (options.acceleration == ArapAcceleration::anderson) {
    m.anderson = std::make_unique<detail::Anderson>(3 * nn, options.anderson_window, options.threads, m.arena.get());
    m.energy.init(m.start, m.nbr, m.w, m.P, kGrain, threads, arena);
  }
}

template <class T>
ArapRefiner<T>::~ArapRefiner() = default;
template <class T>
ArapRefiner<T>::ArapRefiner(ArapRefiner&&) noexcept = default;
template <class T>
ArapRefiner<T>& ArapRefiner<T>::operator=(ArapRefiner&&) noexcept = default;

template <class T>
void ArapRefiner<T>::refine(const Points<T>& start, const Points<T>& targets, int iterations, Points<T>& out,
                            const CancelCheck& cancel) {
  refine_scaled(start, targets, 0, iterations, out, cancel);
}

template <class T>
void ArapRefiner<T>::refine_scaled(const Points<T>& start, const Points<T>& targets, int exponent, int iterations,
                                   Points<T>& out, const CancelCheck& cancel) {
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
  m.refined = false;
  m.X = start.template cast<double>();  // row-major copy
  for (std::size_t k = 0; k < m.constrained.size(); ++k)
    m.X.row(m.constrained[k]) = targets.row(Eigen::Index(k)).template cast<double>();
  const int f = std::max(m.rest_e, detail::exponent_of(m.X.cwiseAbs().maxCoeff()) + exponent);
  for (Eigen::Index i = 0; i < m.X.size(); ++i) m.X.data()[i] = std::ldexp(m.X.data()[i], exponent - f);
  m.rest_to_x = std::ldexp(1.0, m.rest_e - f);
  if (m.anderson)  // cancel is checked before every iteration there too, before `out` is written
    m.anderson->run(
        std::span<double>(m.X.data(), std::size_t(m.X.size())), iterations, [&] { return m.local_step(true); },
        [&] { m.global_step(); }, cancel);
  else
    for (int it = 0; it < iterations; ++it) {
      detail::throw_if_cancelled(cancel);  // before `out` is written: the strong guarantee
      m.local_step();
      m.global_step();
    }
  // Back to the caller's units, refusing (before `out` changes) what T cannot hold: the iterations can move a
  // vertex beyond its start (a rotated one-ring reaches past the targets' bounding box).
  for (Eigen::Index i = 0; i < m.X.size(); ++i) {
    const double x = std::ldexp(m.X.data()[i], f);
    if (!(std::abs(x) <= double(std::numeric_limits<T>::max())))
      throw std::invalid_argument("ArapRefiner::refine: vertex " + std::to_string(i / 3) +
                                  "'s refined position overflows " + (sizeof(T) == 4 ? "float" : "double") +
                                  " (a coordinate of magnitude 2^" + std::to_string(std::ilogb(m.X.data()[i]) + f) +
                                  ")");
    m.X.data()[i] = x;
  }
  if (out.rows() != m.n) out.resize(m.n, 3);
  out = m.X.template cast<T>();
  m.refined = true;
}

template <class T>
void ArapRefiner<T>::rotations(std::span<T> out) {
  if (!impl_ || !impl_->refined) throw std::logic_error("ArapRefiner::rotations: no refine() result to fit");
  Impl& m = *impl_;
  const std::size_t nn = std::size_t(m.n);
  if (out.size() != 9 * nn)
    throw std::invalid_argument("ArapRefiner::rotations: " + std::to_string(out.size()) + " values for " +
                                std::to_string(nn) + " vertices (9 each)");
  m.local_step();  // R_i is invariant under the scale of X: its S_i is normalised to a power of two
  for (std::size_t i = 0; i < nn; ++i)
    for (std::size_t k = 0; k < 9; ++k) out[9 * i + k] = m.R[k * nn + i];
}

template <class T>
double ArapRefiner<T>::energy(const Points<T>& x) const {
  if (!impl_) throw std::logic_error("ArapRefiner: this session was moved from");
  const Impl& m = *impl_;
  if (x.rows() != m.n) throw std::invalid_argument("ArapRefiner::energy: wrong number of rows");
  PointsD X = x.template cast<double>();
  for (Eigen::Index i = 0; i < X.size(); ++i) X.data()[i] = std::ldexp(X.data()[i], -m.rest_e);  // the units of P
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
  return std::ldexp(E, 2 * m.rest_e);
}

template <class T>
int ArapRefiner<T>::rejected_iterates() const {
  return impl_ && impl_->anderson ? impl_->anderson->rejections() : 0;
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
  return m.solver.memory_bytes() + bytes(m.start) + bytes(m.nbr) + bytes(m.w) + bytes(m.we) + bytes(m.c) +
         m.padded.memory_bytes() + bytes(m.row) + bytes(m.free_vertices) + bytes(m.held_start) + bytes(m.held_nbr) +
         bytes(m.held_w) + bytes(m.H) + bytes(m.R) + bytes(m.Rd) + bytes(m.bsum) + bytes(m.y) + bytes(m.energy.ring) +
         bytes(m.energy.q) + bytes(m.energy.chunks) + (m.anderson ? m.anderson->memory_bytes() : 0) +
         std::size_t(m.P.size() + m.X.size()) * sizeof(double);
}

bool supernodal_factorisation_available() { return detail::supernodal_available(); }

template class ArapRefiner<float>;
template class ArapRefiner<double>;

}  // namespace mlsdeform
