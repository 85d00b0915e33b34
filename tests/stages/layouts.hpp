// The stage tests' entries (tests/test_stages.cpp, tests/test_stages_ring.cpp): each paper stage of
// docs/design.md on n lanes, through one table per instruction set (tests/stages/table.hpp picks one), so
// that the tests hold each SIMD stage against its scalar twin. Built
// beside the library, not in it: the scalar table (scalar_entries.cpp) with the baseline flags, one table
// per ISA (entries_<isa>.cpp, lane_entries.hpp) with the kernels' flags; no Catch2 here.
//
// Each stage's inputs and outputs are a struct templated on the element type E: filled per lane with
// E = T by the test, and the same struct with E = a batch (one lane each) is what an entry hands the
// stage (for_lanes transposes). J, the pseudo-handles of the deformer's sums, is fixed at kJ.
#pragma once

#include "kernels/contract.hpp"

#include <cstddef>
#include <cstring>

namespace mlsdeform::testing::stages {

inline constexpr std::size_t kJ = 7;

template <class E>
struct Matrix {
  E h[9];  ///< h[3 r + c] = H(r, c), normalised (max |h| in [1, 2))
};
template <class E>
struct InvariantsOut {
  E E_, z[3], norm2, det, c2;  ///< eq. (6): trace, -V, ||H||^2, det H, sum_{i<j} |H_i x H_j|^2
};
template <class E>
struct RootOut {
  E y, converged;  ///< the largest root of (13); 1 where Newton's method converged, else 0
};
template <class E>
struct AxisIn {
  E h[9], y;  ///< normalised H and the root y of (13)
};
template <class E>
struct Quaternion {
  E q[4];  ///< (w, x), unnormalised (rotation_quaternion: unit, w >= 0)
};
template <class E>
struct AxisOut {
  E q[4], dk;  ///< eq. (14)'s quaternion, and the largest |diagonal| of the adjugate (the careful trigger)
};
template <class E>
struct Rotation {
  E r[9];  ///< r[3 i + j] = R(i, j)
};
template <class E>
struct Weights {
  E w[kJ];  ///< omega_j
};
template <class E>
struct CorrelationIn {
  E a[kJ][3];  ///< A_j
};
template <class E>
struct Point {
  E x[3];
};
template <class E>
struct SimilarityIn {
  E r[9], h[9], D, otherwise;
};
template <class E>
struct Scalar {
  E x;
};
template <class E>
struct ApplyIn {
  E qs[3], mu, r[9], vh[3];
};
/// The per-pseudo-handle constants, the same in every lane: q_j (weighted_centroid), d_j = q_j - c
/// (correlation_matrix).
template <class T>
struct Shared {
  T q[kJ][3];
};

/// One table of entries: n lanes of in, into n lanes of out.
template <class T>
struct StageEntries {
  const char* isa;    ///< "scalar", "sse4_2", "avx2", "avx512", "neon"
  std::size_t width;  ///< lanes per batch (1 for the scalar table)
  void (*invariants)(const Matrix<T>* in, InvariantsOut<T>* out, std::size_t n);
  void (*maximum_root)(const InvariantsOut<T>* in, RootOut<T>* out, std::size_t n);
  void (*rotation_axis)(const AxisIn<T>* in, AxisOut<T>* out, std::size_t n);
  void (*top_eigenvector)(const Matrix<T>* in, Quaternion<T>* out, std::size_t n);
  void (*sin_cos)(const Quaternion<T>* in, Rotation<T>* out, std::size_t n);
  void (*weighted_centroid)(const Weights<T>* in, const Shared<T>& q, Point<T>* out, std::size_t n);
  void (*correlation_matrix)(const CorrelationIn<T>* in, const Shared<T>& d, Rotation<T>* out, std::size_t n);
  void (*similarity_scale)(const SimilarityIn<T>* in, Scalar<T>* out, std::size_t n);
  void (*apply)(const ApplyIn<T>* in, Point<T>* out, std::size_t n);
  void (*rotation_quaternion)(const Rotation<T>* in, Quaternion<T>* out, std::size_t n);
  /// The ARAP local step's one-ring sums: no lane-wise struct (a lane gathers its neighbours' rows), the
  /// kernel table's entry itself over a frame of both layouts (kernels/contract.hpp, RingFrame).
  void (*ring_correlation)(const kernels::RingFrame<T>& frame, std::size_t block_begin, std::size_t block_end);
  /// The ARAP global step's rotated one-ring sums, likewise the kernel table's entry.
  void (*ring_rhs)(const kernels::RingFrame<T>& frame, std::size_t block_begin, std::size_t block_end);
};

/// The tables: the scalar reference's (scalar_entries.cpp) and each ISA's (entries_<isa>.cpp).
template <class T>
const StageEntries<T>& scalar_entries();
template <class T>
const StageEntries<T>& sse4_2_entries();
template <class T>
const StageEntries<T>& avx2_entries();
template <class T>
const StageEntries<T>& avx512_entries();
template <class T>
const StageEntries<T>& neon_entries();

/// Calls f(in, out) with In<V>, Out<V> holding lanes [i0, i0 + W) of in, out, W = L::W at a time (a partial
/// last batch zero-padded). The structs hold only E's, so In<T> is sizeof(In<T>) / sizeof(T) values of T
/// and In<V> as many of V; both are copied as bytes.
template <class L, template <class> class In, template <class> class Out, class F>
void for_lanes(const In<typename L::T>* in, Out<typename L::T>* out, std::size_t n, F&& f) {
  using T = typename L::T;
  using V = typename L::V;
  constexpr std::size_t W = L::W, ni = sizeof(In<T>) / sizeof(T), no = sizeof(Out<T>) / sizeof(T);
  static_assert(sizeof(In<V>) == ni * sizeof(V) && sizeof(Out<V>) == no * sizeof(V));
  for (std::size_t i0 = 0; i0 < n; i0 += W) {
    const std::size_t rem = n - i0 < W ? n - i0 : W;
    alignas(64) T soa_in[ni][W] = {}, soa_out[no][W];  // a row is one vector: aligned as load needs
    T flat[ni > no ? ni : no];
    for (std::size_t l = 0; l < rem; ++l) {
      std::memcpy(flat, &in[i0 + l], sizeof(In<T>));
      for (std::size_t k = 0; k < ni; ++k) soa_in[k][l] = flat[k];
    }
    V vin[ni], vout[no];
    for (std::size_t k = 0; k < ni; ++k) vin[k] = L::load(soa_in[k]);
    In<V> x;
    Out<V> y;
    std::memcpy(static_cast<void*>(&x), vin, sizeof x);
    f(static_cast<const In<V>&>(x), y);
    std::memcpy(static_cast<void*>(vout), &y, sizeof y);
    for (std::size_t k = 0; k < no; ++k) L::store(vout[k], soa_out[k]);
    for (std::size_t l = 0; l < rem; ++l) {
      for (std::size_t k = 0; k < no; ++k) flat[k] = soa_out[k][l];
      std::memcpy(&out[i0 + l], flat, sizeof(Out<T>));
    }
  }
}

}  // namespace mlsdeform::testing::stages
