// The deformer's per-vertex stages, scalar reference (one vertex), read beside the paper; SIMD twins in
// kernels/deformer/stages.hpp, operation for operation (so each stage's result is bitwise the same):
//   weighted_centroid   q* = sum_j omega_j q_j                         (eq. 2), one term per call
//   correlation_matrix  H  = sum_j (q_j - c) A_j^T                     (eq. 6, Sec. 6.2), one term per call
//   similarity_scale    mu = trace(R^T H) / D                          (Sec. 6.1)
//   apply               v' = q* + mu R vhat                            (Algorithm 1 steps 8-10)
#pragma once

namespace mlsdeform::detail {

/// Eq. (2), the term of one pseudo-handle: qs += omega q_j.
template <class T>
void weighted_centroid(T (&qs)[3], T omega, const T (&q)[3]) {
  for (int r = 0; r < 3; ++r) qs[r] = qs[r] + omega * q[r];
}

/// Eq. (6), the term of one pseudo-handle: h += d a^T with d = q_j - c, a = A_j; h[3 r + c] = H(r, c).
template <class T>
void correlation_matrix(T (&h)[9], const T (&d)[3], const T (&a)[3]) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) h[3 * r + c] = h[3 * r + c] + d[r] * a[c];
}

/// Sec. 6.1: mu_s = trace(R^T H) / D where D > 0 (D = sum_i w_i |phat_i|^2 in the session's units; 0 only
/// where vhat = 0), `otherwise` elsewhere.
template <class T>
T similarity_scale(const T (&r)[9], const T (&h)[9], T D, T otherwise) {
  T tr = r[0] * h[0];
  for (int i = 1; i < 9; ++i) tr = tr + r[i] * h[i];
  return D > T(0) ? tr / D : otherwise;
}

/// Algorithm 1 steps 8-10: out = q* + mu R vhat.
template <class T>
void apply(const T (&qs)[3], T mu, const T (&r)[9], const T (&vh)[3], T (&out)[3]) {
  for (int i = 0; i < 3; ++i) {
    const T rv = r[3 * i] * vh[0] + r[3 * i + 1] * vh[1] + r[3 * i + 2] * vh[2];
    out[i] = qs[i] + mu * rv;
  }
}

}  // namespace mlsdeform::detail
