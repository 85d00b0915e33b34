#include "core/src/deformer/arap_stage.hpp"

#include "core/src/pow2.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace mlsdeform::detail {

void check_triangles(const Triangles& triangles, Eigen::Index n) {
  for (Eigen::Index f = 0; f < triangles.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (triangles(f, k) < 0 || triangles(f, k) >= n)
        throw std::invalid_argument("Deformer: triangle " + std::to_string(f) + " has vertex index " +
                                    std::to_string(triangles(f, k)) + ", outside [0, " + std::to_string(n) + ")");
}

template <class T>
ArapStage<T>::ArapStage(ArapRefiner<T>&& r, std::vector<Eigen::Index> c, Eigen::Index n)
    : refiner(std::move(r)),
      constrained(std::move(c)),
      mls(n, 3),
      targets(Eigen::Index(constrained.size()), 3),
      rotations(9 * std::size_t(n)) {}

template <class T>
std::unique_ptr<ArapStage<T>> ArapStage<T>::make(const Points<T>& rest, const Triangles& triangles,
                                                 const Handles<T>& handles, const Options& options) {
  check_triangles(triangles, rest.rows());
  if (triangles.rows() == 0)
    throw std::invalid_argument("Deformer: arap_iterations > 0 needs the mesh's triangles (none given)");
  std::vector<char> taken(std::size_t(rest.rows()), 0);
  std::vector<Eigen::Index> constrained;
  // Squared distances in a frame scaled by a power of two to the largest coordinate: they cannot overflow,
  // and the choice is the same at every scale.
  double m = 0;
  for (const Points<T>* h : {&rest, &handles.points, &handles.segment_a, &handles.segment_b})
    if (h->size()) m = std::max(m, double(h->cwiseAbs().maxCoeff()));
  const int e = exponent_of(m);
  auto nearest = [&](const auto& p) {
    Eigen::Index best = 0;
    double d_best = std::numeric_limits<double>::infinity();
    for (Eigen::Index i = 0; i < rest.rows(); ++i) {
      double d = 0;
      for (int c = 0; c < 3; ++c) {
        const double x = std::ldexp(double(rest(i, c)), -e) - std::ldexp(double(p(c)), -e);
        d += x * x;
      }
      if (d < d_best) d_best = d, best = i;
    }
    if (!taken[std::size_t(best)]) taken[std::size_t(best)] = 1, constrained.push_back(best);
  };
  for (Eigen::Index i = 0; i < handles.points.rows(); ++i) nearest(handles.points.row(i));
  for (Eigen::Index i = 0; i < handles.segment_a.rows(); ++i) {
    nearest(handles.segment_a.row(i));
    nearest(handles.segment_b.row(i));
  }
  ArapOptions ao;
  ao.threads = options.threads;
  ao.acceleration = options.arap_acceleration;
  ArapRefiner<T> refiner(rest, triangles, constrained, ao);
  auto stage = std::make_unique<ArapStage>(std::move(refiner), std::move(constrained), rest.rows());
  if (options.arap_warm_start) {
    stage->warm_start = true;
    stage->last.resize(rest.rows(), 3);
    stage->last_targets.resize(stage->targets.rows(), 3);
    // The diagonal in a frame scaled by 2^-e (no overflow), back in the caller's units.
    double diagonal2 = 0;
    for (int c = 0; c < 3; ++c)
      diagonal2 +=
          std::pow(std::ldexp(double(rest.col(c).maxCoeff()), -e) - std::ldexp(double(rest.col(c).minCoeff()), -e), 2);
    stage->jump = options.arap_warm_start_limit * std::ldexp(std::sqrt(diagonal2), e);
  }
  return stage;
}

template <class T>
void ArapStage<T>::run(Points<T>& x, int iterations, int exponent, const CancelCheck& cancel) {
  for (std::size_t k = 0; k < constrained.size(); ++k) targets.row(Eigen::Index(k)) = x.row(constrained[k]);
  if (!warm_start) return refiner.refine_scaled(x, targets, exponent, iterations, x, cancel);
  // The largest move of a constrained vertex since the last frame, in the caller's units (both in the local
  // frame, where the differences cannot overflow).
  double moved = has_last ? 0.0 : std::numeric_limits<double>::infinity();
  for (Eigen::Index k = 0; has_last && k < targets.rows(); ++k)
    moved = std::max(moved, (targets.row(k) - last_targets.row(k)).template cast<double>().norm());
  last_was_warm = std::ldexp(moved, exponent) <= jump;
  has_last = false;  // until this frame's result is in `last`
  if (last_was_warm) {
    for (Eigen::Index i = 0; i < last.size(); ++i) last.data()[i] = std::ldexp(last.data()[i], -exponent);
    refiner.refine_scaled(last, targets, exponent, iterations, x, cancel);
  } else {
    refiner.refine_scaled(x, targets, exponent, iterations, x, cancel);
  }
  last = x, last_targets = targets, has_last = true;
}

template struct ArapStage<float>;
template struct ArapStage<double>;

}  // namespace mlsdeform::detail
