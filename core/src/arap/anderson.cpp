// Anderson acceleration's history and extrapolation (anderson.hpp has the method).
#include "core/src/arap/anderson.hpp"

#include "core/src/huge_pages.hpp"

#include <Eigen/QR>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

namespace mlsdeform::detail {

namespace {

/// Positions per chunk of the reductions: the chunks, not the threads, fix the order of every sum.
constexpr std::size_t kChunk = 2048;

/// The pointers chunk_sums works on (after_global's names).
struct Columns {
  const double* x;  ///< G(x_k)
  const double* x_prev;
  double* g_last;
  double* f_last;
  double* dF;
  double* dG;
  std::size_t n, slot;
  double* partial;  ///< the chunk's 2 w sums
  std::size_t w;
};

/// One chunk [e0, e1) of after_global's pass, for Held slots held: F, the new differences (with `add`), and the
/// 2 Held dot products. All of them in one sweep: each dot still adds its terms in ascending e from zero (the
/// bits of one sweep per dot), but its chain of additions runs beside the others' instead of after them, and
/// the columns are read once.
template <int Held>
void chunk_sums(const Columns& c, bool add, std::size_t e0, std::size_t e1) {
  double new_dot[Held > 0 ? Held : 1] = {}, rhs[Held > 0 ? Held : 1] = {};
  double* dfs = c.dF + c.slot * c.n;
  double* dgs = c.dG + c.slot * c.n;
  for (std::size_t e = e0; e < e1; ++e) {
    const double g = c.x[e], f = g - c.x_prev[e];
    if (add) dfs[e] = f - c.f_last[e], dgs[e] = g - c.g_last[e];
    c.f_last[e] = f, c.g_last[e] = g;
    for (int j = 0; j < Held; ++j) {
      const double dfj = c.dF[std::size_t(j) * c.n + e];
      if (add) new_dot[j] += dfs[e] * dfj;
      rhs[j] += f * dfj;
    }
  }
  for (std::size_t j = 0; j < 2 * c.w; ++j) c.partial[j] = 0;
  for (int j = 0; j < Held; ++j) c.partial[j] = new_dot[j], c.partial[c.w + std::size_t(j)] = rhs[j];
}

/// x_e -= sum_j theta_j dG_j[e] for e in [e0, e1), Held columns, j ascending; whether every x_e is finite.
template <int Held>
bool extrapolate(double* x, const double* dG, std::size_t n, const double* theta, std::size_t e0, std::size_t e1) {
  bool finite = true;
  for (std::size_t e = e0; e < e1; ++e) {
    double v = x[e];
    for (int j = 0; j < Held; ++j) v -= theta[j] * dG[std::size_t(j) * n + e];
    x[e] = v;
    finite &= std::abs(v) <= std::numeric_limits<double>::max();  // false for NaN too
  }
  return finite;
}

/// f(std::integral_constant<int, held>) for held in [0, Anderson::kMaxWindow].
template <class F>
void with_held(int held, const F& f) {
  [&]<int... H>(std::integer_sequence<int, H...>) {
    static_cast<void>(((held == H ? (f(std::integral_constant<int, H>{}), true) : false) || ...));
  }
  (std::make_integer_sequence<int, Anderson::kMaxWindow + 1>{});
}

}  // namespace

Anderson::Anderson(std::size_t size, int window, int threads, tbb::task_arena* arena)
    : size_(size), chunks_((size + kChunk - 1) / kChunk), window_(window), threads_(threads), arena_(arena) {
  if (window < 1 || window > kMaxWindow)
    throw std::invalid_argument("ArapRefiner: anderson_window must be in [1, " + std::to_string(kMaxWindow) +
                                "] (got " + std::to_string(window) + ")");
  assign_huge(x_prev_, size, 0.0, threads, arena);
  assign_huge(g_last_, size, 0.0, threads, arena);
  assign_huge(f_last_, size, 0.0, threads, arena);
  assign_huge(dF_, size * std::size_t(window), 0.0, threads, arena);
  assign_huge(dG_, size * std::size_t(window), 0.0, threads, arena);
  partial_.assign(chunks_ * 2 * std::size_t(window), 0.0);
  gram_.resize(window, window);
  gram_.setZero();
}

std::size_t Anderson::memory_bytes() const {
  return sizeof(double) *
         (x_prev_.size() + g_last_.size() + f_last_.size() + dF_.size() + dG_.size() + partial_.size());
}

void Anderson::plain(std::span<double> x) {
  std::copy(g_last_.begin(), g_last_.end(), x.begin());
  count_ = 0, next_ = 0, fresh_ = true;
}

void Anderson::before_global(std::span<double> x) { std::copy(x.begin(), x.end(), x_prev_.begin()); }

void Anderson::after_global(std::span<double> x) {
  const std::size_t n = size_;
  const bool add = !fresh_;
  const int slot = count_ < window_ ? count_ : next_;
  const int held = add ? std::min(count_ + 1, window_) : count_;
  const auto w = std::size_t(window_);
  // One pass: F = G(x_k) - x_k, the new differences into `slot`, and per chunk the sums
  // dF_new . dF_j (Gram's new row) and F . dF_j (the right-hand side) over the slots held.
  parallel_ranges(chunks_, threads_, arena_, [&](std::size_t c0, std::size_t c1) {
    for (std::size_t c = c0; c < c1; ++c) {
      const std::size_t e0 = c * kChunk, e1 = std::min(n, e0 + kChunk);
      const Columns cols = {x.data(),
                            x_prev_.data(),
                            g_last_.data(),
                            f_last_.data(),
                            dF_.data(),
                            dG_.data(),
                            n,
                            std::size_t(slot),
                            partial_.data() + c * 2 * w,
                            w};
      with_held(held, [&](auto h) { chunk_sums<decltype(h)::value>(cols, add, e0, e1); });
    }
  });
  fresh_ = false;
  if (add) {
    count_ = held;
    if (count_ == window_) next_ = (slot + 1) % window_;
  }
  if (count_ == 0) return;  // x = G(x_k): the plain step
  Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxWindow, 1> rhs(count_);
  rhs.setZero();
  Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxWindow, 1> new_row(count_);
  new_row.setZero();
  for (std::size_t c = 0; c < chunks_; ++c)  // in chunk order: the same sums for any thread count
    for (int j = 0; j < count_; ++j) {
      new_row(j) += partial_[c * 2 * w + std::size_t(j)];
      rhs(j) += partial_[c * 2 * w + w + std::size_t(j)];
    }
  if (add) gram_.row(slot).head(count_) = new_row.transpose(), gram_.col(slot).head(count_) = new_row;
  // Solve with the columns scaled to unit length (Peng et al. normalise dF the same way): the Gram matrix of
  // nearly parallel differences is ill-conditioned, so directions below 1e-10 of the largest (relative
  // condition 1e5 in the differences themselves) are dropped by the rank-revealing decomposition.
  Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxWindow, 1> scale(count_);
  for (int j = 0; j < count_; ++j) {
    const double d = gram_(j, j);
    if (!(d > 0) || !std::isfinite(d)) return;  // a zero difference: no secant information, the plain step
    scale(j) = 1 / std::sqrt(d);
  }
  Small A = scale.asDiagonal() * gram_.topLeftCorner(count_, count_) * scale.asDiagonal();
  Eigen::CompleteOrthogonalDecomposition<Small> cod;
  cod.setThreshold(1e-10);
  cod.compute(A);
  Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxWindow, 1> theta = cod.solve(scale.cwiseProduct(rhs));
  theta = scale.cwiseProduct(theta);
  if (!theta.allFinite()) return;
  // x_{k+1} = G(x_k) - sum_j theta_j dG_j, element by element (any cut, the same bits); a non-finite result
  // (theta out of all proportion) falls back to the plain step.
  std::atomic<bool> finite = true;
  parallel_ranges(chunks_, threads_, arena_, [&](std::size_t c0, std::size_t c1) {
    const std::size_t e0 = c0 * kChunk, e1 = std::min(n, c1 * kChunk);
    bool ok = true;
    with_held(count_,
              [&](auto h) { ok = extrapolate<decltype(h)::value>(x.data(), dG_.data(), n, theta.data(), e0, e1); });
    if (!ok) finite.store(false, std::memory_order_relaxed);
  });
  if (!finite) plain(x);
}

}  // namespace mlsdeform::detail
