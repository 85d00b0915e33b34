// The StageFn entry of an ISA's kernel table (kernel_table.hpp): one paper stage on n lanes, batch by batch
// (a partial last batch through zero-padded copies), so that the stage test can hold each SIMD stage
// against its scalar twin (core/src/scalar_kernels.cpp) on every ISA.
#pragma once

#include "kernels/contract.hpp"
#include "kernels/deformer/stages.hpp"
#include "kernels/rotation/axis_angle.hpp"

namespace mlsdeform::kernels {

template <class T, class A>
void run_stage(Stage stage, const T* in, const T* shared, std::size_t J, T* out, std::size_t n) {
  using V = xsimd::batch<T, A>;
  using M = xsimd::batch_bool<T, A>;
  constexpr std::size_t W = V::size;
  for (std::size_t i0 = 0; i0 < n; i0 += W) {
    const std::size_t rem = n - i0 < W ? n - i0 : W;
    auto load = [&](std::size_t k) {
      alignas(64) T buf[W] = {};
      for (std::size_t l = 0; l < rem; ++l) buf[l] = in[k * n + i0 + l];
      return V::load_aligned(buf);
    };
    auto store = [&](std::size_t k, V v) {
      alignas(64) T buf[W];
      v.store_aligned(buf);
      for (std::size_t l = 0; l < rem; ++l) out[k * n + i0 + l] = buf[l];
    };
    auto load_n = [&](std::size_t first, V* x, std::size_t count) {
      for (std::size_t k = 0; k < count; ++k) x[k] = load(first + k);
    };
    auto store_n = [&](std::size_t first, const V* x, std::size_t count) {
      for (std::size_t k = 0; k < count; ++k) store(first + k, x[k]);
    };
    V h[9], r[9];
    switch (stage) {
      case Stage::invariants: {
        load_n(0, h, 9);
        const Invariants<V> inv = invariants(h);
        const V o[7] = {inv.E, inv.z0, inv.z1, inv.z2, inv.norm2, inv.det, inv.c2};
        store_n(0, o, 7);
        break;
      }
      case Stage::maximum_root: {
        Invariants<V> inv;
        inv.E = load(0), inv.z0 = load(1), inv.z1 = load(2), inv.z2 = load(3);
        inv.norm2 = load(4), inv.det = load(5), inv.c2 = load(6);
        M converged;
        store(0, maximum_root(inv, converged));
        store(1, select(converged, V(T(1)), V(T(0))));
        break;
      }
      case Stage::rotation_axis: {
        load_n(0, h, 9);
        const Invariants<V> inv = invariants(h);
        V dk;
        const Vec4<V> q = rotation_axis(davenport(h, inv.E, inv.z0, inv.z1, inv.z2), load(9), dk);
        store_n(0, q.v, 4);
        store(4, dk);
        break;
      }
      case Stage::top_eigenvector: {
        load_n(0, h, 9);
        const Invariants<V> inv = invariants(h);
        V q[4];
        top_eigenvector(davenport(h, inv.E, inv.z0, inv.z1, inv.z2).k, sqrt(V(T(4)) * inv.norm2), q);
        store_n(0, q, 4);
        break;
      }
      case Stage::sin_cos: {
        sin_cos(load(0), load(1), load(2), load(3), r);
        store_n(0, r, 9);
        break;
      }
      case Stage::weighted_centroid: {
        V qs[3] = {V(T(0)), V(T(0)), V(T(0))};
        for (std::size_t j = 0; j < J; ++j)
          weighted_centroid(qs, load(j), {V(shared[3 * j]), V(shared[3 * j + 1]), V(shared[3 * j + 2])});
        store_n(0, qs, 3);
        break;
      }
      case Stage::correlation_matrix: {
        for (V& e : h) e = V(T(0));
        for (std::size_t j = 0; j < J; ++j)
          correlation_matrix(h, {V(shared[3 * j]), V(shared[3 * j + 1]), V(shared[3 * j + 2])},
                             {load(3 * j), load(3 * j + 1), load(3 * j + 2)});
        store_n(0, h, 9);
        break;
      }
      case Stage::similarity_scale: {
        load_n(0, r, 9);
        load_n(9, h, 9);
        store(0, similarity_scale(r, h, load(18), load(19)));
        break;
      }
      case Stage::apply: {
        V qs[3], vh[3], o[3];
        load_n(0, qs, 3);
        load_n(4, r, 9);
        load_n(13, vh, 3);
        apply(qs, load(3), r, vh, o);
        store_n(0, o, 3);
        break;
      }
    }
  }
}

}  // namespace mlsdeform::kernels
