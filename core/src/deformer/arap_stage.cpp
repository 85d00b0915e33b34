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
    : refiner(std::move(r)), constrained(std::move(c)), mls(n, 3), targets(Eigen::Index(constrained.size()), 3) {}

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
  return std::make_unique<ArapStage>(std::move(refiner), std::move(constrained), rest.rows());
}

template <class T>
void ArapStage<T>::run(Points<T>& x, int iterations, int exponent, const CancelCheck& cancel) {
  for (std::size_t k = 0; k < constrained.size(); ++k) targets.row(Eigen::Index(k)) = x.row(constrained[k]);
  refiner.refine_scaled(x, targets, exponent, iterations, x, cancel);
}

template struct ArapStage<float>;
template struct ArapStage<double>;

}  // namespace mlsdeform::detail
