// Anderson acceleration of ARAP's local/global fixed point, with the energy safeguard of Peng, Deng, Zhang and
// Liu, "Anderson Acceleration for Geometry Optimization and Physics Simulation" (SIGGRAPH 2018), Sec. 3-4.
//
// One local step followed by one global step is a map x -> G(x) of the positions whose fixed points are
// ARAP's stationary points, and which never raises the energy E(x) = min_R E(x, R) (each step minimises E over
// its own variables). Anderson's method of window m extrapolates from the last m + 1 pairs (x_j, G(x_j)):
// with F(x) = G(x) - x and the differences dF_j, dG_j of consecutive pairs,
//   theta = argmin |F(x_k) - sum_j theta_j dF_j|^2,   x_{k+1} = G(x_k) - sum_j theta_j dG_j   (Peng et al. (6)).
// That iterate is accepted only if its energy, found by the next local step, is not above E(x_k); otherwise
// the plain step G(x_k) replaces it and the history starts again (Peng et al. Alg. 2). So the energies of
// the iterates never increase, as the plain iteration's do not, and the fixed point is the same.
//
// The normal equations of the least-squares problem are at most m x m; the m dot products a step adds are
// reduced over fixed chunks of the positions in a fixed order, so the result is bitwise the same for any
// thread count. Everything is allocated at construction: a step allocates nothing.
#pragma once

#include "core/src/parallel.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <limits>
#include <span>
#include <vector>

namespace mlsdeform::detail {

class Anderson {
 public:
  /// The largest window: the normal equations live on the stack.
  static constexpr int kMaxWindow = 8;

  /// `size` doubles of positions (x, including the held ones: their differences are zero and change no
  /// sum), a window of 1 .. kMaxWindow pairs. `arena` must outlive this object.
  Anderson(std::size_t size, int window, int threads, tbb::task_arena* arena);

  /// `iterations` safeguarded accelerated steps on x in place. local() runs a local step at x and returns
  /// E(x) (with that step's rotations); global() replaces x by the global step's solution. Each iteration
  /// is one global step; the iterate it ends with is checked by one more local step at the end, and replaced
  /// by the plain step when its energy is higher (so that the result's energy is not above that of the
  /// iterate before it: the results after k and k + 1 iterations have non-increasing energies too).
  template <class Local, class Global>
  void run(std::span<double> x, int iterations, const Local& local, const Global& global, const CancelCheck& cancel) {
    if (iterations <= 0) return;
    count_ = 0, next_ = 0, fresh_ = true, rejections_ = 0;
    double previous = std::numeric_limits<double>::infinity();
    for (int it = 0; it < iterations; ++it) {
      throw_if_cancelled(cancel);
      double E = local();
      if (it > 0 && !(E <= previous)) {  // the extrapolated iterate is rejected: the plain step instead
        ++rejections_;
        plain(x);
        E = local();
      }
      previous = E;
      before_global(x);
      global();
      after_global(x);
    }
    if (!(local() <= previous)) ++rejections_, plain(x);
  }

  std::size_t memory_bytes() const;
  /// Extrapolated iterates rejected by the safeguard in the last run() (for benchmarks and tests).
  int rejections() const { return rejections_; }

 private:
  /// x = G(x_k), the last plain step; the history is dropped.
  void plain(std::span<double> x);
  /// Keeps x_k before the global step overwrites it.
  void before_global(std::span<double> x);
  /// x holds G(x_k): adds the pair's differences to the history (unless the history was just dropped or
  /// this is the first pair) and extrapolates x.
  void after_global(std::span<double> x);

  std::size_t size_, chunks_;
  int window_, threads_;
  tbb::task_arena* arena_;
  int count_ = 0;      ///< pairs of differences held (<= window_), in slots 0 .. count_ - 1
  int next_ = 0;       ///< the slot the next difference goes to once the window is full
  bool fresh_ = true;  ///< no previous pair to difference against (first step, or after a rejection)
  int rejections_ = 0;
  std::vector<double> x_prev_, g_last_, f_last_;  ///< x_k, G(x_{k-1}), F(x_{k-1})
  std::vector<double> dF_, dG_;                   ///< window_ columns of size_ each
  std::vector<double> partial_;                   ///< per chunk: dF_new . dF_j and F . dF_j, 2 window_ values
  using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxWindow, kMaxWindow>;
  Small gram_;  ///< dF_i . dF_j over the slots held
};

}  // namespace mlsdeform::detail
