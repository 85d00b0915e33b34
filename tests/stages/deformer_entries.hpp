// The deformer stages' entries, for any lane policy L (kernels/deformer/deform_kernel.hpp): one body of each
// stage (kernels/deformer/stages.hpp) instantiated at width 1 by the scalar table and at a batch's width
// by each ISA's, so that the stage test sees the two instantiations side by side.
#pragma once

#include "tests/stages/layouts.hpp"

#include "kernels/deformer/stages.hpp"

namespace mlsdeform::testing::stages {

template <class L>
struct DeformerEntries {
  using T = typename L::T;
  using V = typename L::V;

  static void weighted_centroid(const Weights<T>* in, const Shared<T>& q, Point<T>* out, std::size_t n) {
    for_lanes<L, Weights, Point>(in, out, n, [&](const Weights<V>& x, Point<V>& y) {
      for (V& e : y.x) e = V(T(0));
      for (std::size_t j = 0; j < kJ; ++j)
        kernels::weighted_centroid(y.x, x.w[j], {V(q.q[j][0]), V(q.q[j][1]), V(q.q[j][2])});
    });
  }
  static void correlation_matrix(const CorrelationIn<T>* in, const Shared<T>& d, Rotation<T>* out, std::size_t n) {
    for_lanes<L, CorrelationIn, Rotation>(in, out, n, [&](const CorrelationIn<V>& x, Rotation<V>& y) {
      for (V& e : y.r) e = V(T(0));
      for (std::size_t j = 0; j < kJ; ++j)
        kernels::correlation_matrix(y.r, {V(d.q[j][0]), V(d.q[j][1]), V(d.q[j][2])}, x.a[j]);
    });
  }
  static void similarity_scale(const SimilarityIn<T>* in, Scalar<T>* out, std::size_t n) {
    for_lanes<L, SimilarityIn, Scalar>(in, out, n, [](const SimilarityIn<V>& x, Scalar<V>& y) {
      y.x = kernels::similarity_scale(x.r, x.h, x.D, x.otherwise);
    });
  }
  static void apply(const ApplyIn<T>* in, Point<T>* out, std::size_t n) {
    for_lanes<L, ApplyIn, Point>(in, out, n,
                                 [](const ApplyIn<V>& x, Point<V>& y) { kernels::apply(x.qs, x.mu, x.r, x.vh, y.x); });
  }

  static void rotation_quaternion(const Rotation<T>* in, Quaternion<T>* out, std::size_t n) {
    for_lanes<L, Rotation, Quaternion>(
        in, out, n, [](const Rotation<V>& x, Quaternion<V>& y) { kernels::rotation_quaternion(x.r, y.q); });
  }

  /// The table with the rotation stages' entries R (a struct of the same static functions) and the ARAP
  /// steps' one-ring sums.
  template <class R>
  static StageEntries<T> table(const char* isa,
                               void (*ring_correlation)(const kernels::RingFrame<T>&, std::size_t, std::size_t),
                               void (*ring_rhs)(const kernels::RingFrame<T>&, std::size_t, std::size_t)) {
    return {isa,
            L::W,
            &R::invariants,
            &R::maximum_root,
            &R::rotation_axis,
            &R::top_eigenvector,
            &R::sin_cos,
            &weighted_centroid,
            &correlation_matrix,
            &similarity_scale,
            &apply,
            &rotation_quaternion,
            ring_correlation,
            ring_rhs};
  }
};

}  // namespace mlsdeform::testing::stages
