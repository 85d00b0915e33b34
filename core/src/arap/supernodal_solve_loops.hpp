// The dense loops of SupernodalSolve's substitution (supernodal_solve.cpp), over one supernode's block: the
// forward updates (update4, update1, subtract4) and the backward sums (dot1, dot2), three right-hand sides at a
// time. Their operations and order are the substitution's contract (the same bits for any thread count and
// schedule): each row's forward sum adds its columns in ascending order, each backward sum runs as an even and an
// odd chain. Included by supernodal_solve.cpp alone.
#pragma once

#include <cstddef>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace mlsdeform::detail::solve_loops {

/// a_k[i] += g0[i] w[k] + g1[i] w[3 + k] + g2[i] w[6 + k] + g3[i] w[9 + k] for the three right-hand sides
/// k, added left to right; w: four rows of z, 3 values each. Restrict-qualified so that the compiler runs
/// the rows two (SSE2) or more at a time without run-time alias checks.
inline void update4(std::size_t m, const double* __restrict g0, const double* __restrict g1,
                    const double* __restrict g2, const double* __restrict g3, const double* __restrict w,
                    double* __restrict a0, double* __restrict a1, double* __restrict a2) {
  const double w00 = w[0], w01 = w[1], w02 = w[2], w10 = w[3], w11 = w[4], w12 = w[5];
  const double w20 = w[6], w21 = w[7], w22 = w[8], w30 = w[9], w31 = w[10], w32 = w[11];
  for (std::size_t i = 0; i < m; ++i) {
    const double h0 = g0[i], h1 = g1[i], h2 = g2[i], h3 = g3[i];
    a0[i] = (((a0[i] + h0 * w00) + h1 * w10) + h2 * w20) + h3 * w30;
    a1[i] = (((a1[i] + h0 * w01) + h1 * w11) + h2 * w21) + h3 * w31;
    a2[i] = (((a2[i] + h0 * w02) + h1 * w12) + h2 * w22) + h3 * w32;
  }
}

inline void update1(std::size_t m, const double* __restrict g, const double* __restrict w, double* __restrict a0,
                    double* __restrict a1, double* __restrict a2) {
  const double w0 = w[0], w1 = w[1], w2 = w[2];
  for (std::size_t i = 0; i < m; ++i) a0[i] += g[i] * w0, a1[i] += g[i] * w1, a2[i] += g[i] * w2;
}

/// The backward sums z_k -= sum_i g[i] x_k[i] of one column g (k: the three right-hand sides), each as two
/// partial sums, over the even and the odd rows (ascending), then (even + odd): two independent chains per
/// sum. The order depends on m alone, never on the threads. With SSE2 each sum's two chains are the two lanes
/// of one register, written out: left to the compiler, dot2's chains were unrolled past the 16 registers and
/// kept on the stack, each addition waiting on a store and a load. On spot_loop3 (Zen 5, one thread, blocks of
/// 2^11 to 2^20 entries) the backward pass took 2.3-2.5 TSC cycles per entry before, 1.9-2.2 after (the forward
/// pass: 1.3-1.9); its substitution 67.9-70.1 -> 63.3-65.1 ms on two threads. The same operations in the same
/// order as the portable loop (which the builds without SSE2, WebAssembly's, run): the same bits.
#if defined(__SSE2__)
/// Lane 0 + lane 1 of v: the even chain plus the odd.
inline double even_plus_odd(__m128d v) { return _mm_cvtsd_f64(_mm_add_sd(v, _mm_unpackhi_pd(v, v))); }
#endif

inline void dot1(std::size_t m, const double* __restrict g, const double* __restrict x0, const double* __restrict x1,
                 const double* __restrict x2, double* __restrict z) {
  std::size_t i = 0;
  double s0, s1, s2;
#if defined(__SSE2__)
  __m128d e0 = _mm_setzero_pd(), e1 = e0, e2 = e0;
  for (; i + 2 <= m; i += 2) {
    const __m128d w = _mm_loadu_pd(g + i);
    e0 = _mm_add_pd(e0, _mm_mul_pd(w, _mm_loadu_pd(x0 + i)));
    e1 = _mm_add_pd(e1, _mm_mul_pd(w, _mm_loadu_pd(x1 + i)));
    e2 = _mm_add_pd(e2, _mm_mul_pd(w, _mm_loadu_pd(x2 + i)));
  }
  s0 = even_plus_odd(e0), s1 = even_plus_odd(e1), s2 = even_plus_odd(e2);
#else
  double e0 = 0, e1 = 0, e2 = 0, o0 = 0, o1 = 0, o2 = 0;
  for (; i + 2 <= m; i += 2) {
    e0 += g[i] * x0[i], e1 += g[i] * x1[i], e2 += g[i] * x2[i];
    o0 += g[i + 1] * x0[i + 1], o1 += g[i + 1] * x1[i + 1], o2 += g[i + 1] * x2[i + 1];
  }
  s0 = e0 + o0, s1 = e1 + o1, s2 = e2 + o2;
#endif
  if (i < m) s0 += g[i] * x0[i], s1 += g[i] * x1[i], s2 += g[i] * x2[i];
  z[0] -= s0, z[1] -= s1, z[2] -= s2;
}

/// dot1 for two columns g and h (z: their two rows, 3 values each) in one sweep over x.
inline void dot2(std::size_t m, const double* __restrict g, const double* __restrict h, const double* __restrict x0,
                 const double* __restrict x1, const double* __restrict x2, double* __restrict z) {
  std::size_t i = 0;
  double s0, s1, s2, t0, t1, t2;
#if defined(__SSE2__)
  __m128d e0 = _mm_setzero_pd(), e1 = e0, e2 = e0, f0 = e0, f1 = e0, f2 = e0;
  for (; i + 2 <= m; i += 2) {
    const __m128d a0 = _mm_loadu_pd(x0 + i), a1 = _mm_loadu_pd(x1 + i), a2 = _mm_loadu_pd(x2 + i);
    const __m128d u = _mm_loadu_pd(g + i), v = _mm_loadu_pd(h + i);
    e0 = _mm_add_pd(e0, _mm_mul_pd(u, a0)), e1 = _mm_add_pd(e1, _mm_mul_pd(u, a1));
    e2 = _mm_add_pd(e2, _mm_mul_pd(u, a2));
    f0 = _mm_add_pd(f0, _mm_mul_pd(v, a0)), f1 = _mm_add_pd(f1, _mm_mul_pd(v, a1));
    f2 = _mm_add_pd(f2, _mm_mul_pd(v, a2));
  }
  s0 = even_plus_odd(e0), s1 = even_plus_odd(e1), s2 = even_plus_odd(e2);
  t0 = even_plus_odd(f0), t1 = even_plus_odd(f1), t2 = even_plus_odd(f2);
#else
  double e0 = 0, e1 = 0, e2 = 0, o0 = 0, o1 = 0, o2 = 0;
  double f0 = 0, f1 = 0, f2 = 0, p0 = 0, p1 = 0, p2 = 0;
  for (; i + 2 <= m; i += 2) {
    const double a0 = x0[i], a1 = x1[i], a2 = x2[i], b0 = x0[i + 1], b1 = x1[i + 1], b2 = x2[i + 1];
    e0 += g[i] * a0, e1 += g[i] * a1, e2 += g[i] * a2;
    o0 += g[i + 1] * b0, o1 += g[i + 1] * b1, o2 += g[i + 1] * b2;
    f0 += h[i] * a0, f1 += h[i] * a1, f2 += h[i] * a2;
    p0 += h[i + 1] * b0, p1 += h[i + 1] * b1, p2 += h[i + 1] * b2;
  }
  s0 = e0 + o0, s1 = e1 + o1, s2 = e2 + o2, t0 = f0 + p0, t1 = f1 + p1, t2 = f2 + p2;
#endif
  if (i < m) {
    s0 += g[i] * x0[i], s1 += g[i] * x1[i], s2 += g[i] * x2[i];
    t0 += h[i] * x0[i], t1 += h[i] * x1[i], t2 += h[i] * x2[i];
  }
  z[0] -= s0, z[1] -= s1, z[2] -= s2, z[3] -= t0, z[4] -= t1, z[5] -= t2;
}

/// q_k[i] -= g0[i] w_k[0], then g1[i] w_k[1], g2[i] w_k[2], g3[i] w_k[3], in that order (k: the three
/// right-hand sides, planar): four columns of the forward triangular solve applied to the rows below them.
inline void subtract4(std::size_t m, const double* __restrict g0, const double* __restrict g1,
                      const double* __restrict g2, const double* __restrict g3, const double* w0, const double* w1,
                      const double* w2, double* __restrict q0, double* __restrict q1, double* __restrict q2) {
  const double u00 = w0[0], u01 = w0[1], u02 = w0[2], u03 = w0[3];
  const double u10 = w1[0], u11 = w1[1], u12 = w1[2], u13 = w1[3];
  const double u20 = w2[0], u21 = w2[1], u22 = w2[2], u23 = w2[3];
  for (std::size_t i = 0; i < m; ++i) {
    const double h0 = g0[i], h1 = g1[i], h2 = g2[i], h3 = g3[i];
    q0[i] = (((q0[i] - h0 * u00) - h1 * u01) - h2 * u02) - h3 * u03;
    q1[i] = (((q1[i] - h0 * u10) - h1 * u11) - h2 * u12) - h3 * u13;
    q2[i] = (((q2[i] - h0 * u20) - h1 * u21) - h2 * u22) - h3 * u23;
  }
}

}  // namespace mlsdeform::detail::solve_loops
