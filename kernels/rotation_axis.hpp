// Stage "rotation_axis" of Algorithm 1 (eq. 14, generalised) in SIMD lanes, mirroring
// core/src/axis_angle.hpp stage by stage. Fast path (fast_axis): the strongest column of the adjugate of
// K - y I and one power step. Careful path (rotation_axis): the adjugate, the two strongest columns (the paper's
// frame k = 0 unless |q0| is below half the largest |q_k|: Shuster's sequential rotations), Rayleigh-Ritz
// on their span, the near-double-root evaluation at y + sqrt(eps) ||K|| for the lanes that need it (run
// only when some lane does), and the lanes left (a triple root) marked for the scalar code.
#pragma once

#include "simd.hpp"

namespace mlsdeform::kernels {

template <class T, class A>
struct RotationAxis : Simd<T, A> {
  using typename Simd<T, A>::V;
  using typename Simd<T, A>::M;
  using Simd<T, A>::eps;

  /// The symmetric 4x4 Davenport matrix K, full storage k[4 i + j].
  struct Mat4 {
    V k[16];
    V operator()(int i, int j) const { return k[4 * i + j]; }
  };
  struct Vec4 {
    V v[4];
  };

  MLSDEFORM_KERNEL_INLINE static Mat4 davenport(const V (&h)[9], V E, V z0, V z1, V z2) {
    Mat4 K;
    const V n01 = h[1] + h[3], n02 = h[2] + h[6], n12 = h[5] + h[7];
    const V d[4] = {E, V(T(2)) * h[0] - E, V(T(2)) * h[4] - E, V(T(2)) * h[8] - E};
    const V off[4][4] = {{d[0], z0, z1, z2}, {z0, d[1], n01, n02}, {z1, n01, d[2], n12}, {z2, n02, n12, d[3]}};
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) K.k[4 * i + j] = off[i][j];
    return K;
  }

  MLSDEFORM_KERNEL_INLINE static Mat4 shifted(const Mat4& K, V y) {
    Mat4 S = K;
    for (int i = 0; i < 4; ++i) S.k[5 * i] = K.k[5 * i] - y;
    return S;
  }

  /// adj(A) by complementary 2x2 minors; the same expressions as the scalar adjugate4.
  MLSDEFORM_KERNEL_INLINE static Mat4 adjugate(const Mat4& S) {
    const V s0 = S(0, 0) * S(1, 1) - S(1, 0) * S(0, 1), s1 = S(0, 0) * S(1, 2) - S(1, 0) * S(0, 2);
    const V s2 = S(0, 0) * S(1, 3) - S(1, 0) * S(0, 3), s3 = S(0, 1) * S(1, 2) - S(1, 1) * S(0, 2);
    const V s4 = S(0, 1) * S(1, 3) - S(1, 1) * S(0, 3), s5 = S(0, 2) * S(1, 3) - S(1, 2) * S(0, 3);
    const V c5 = S(2, 2) * S(3, 3) - S(3, 2) * S(2, 3), c4 = S(2, 1) * S(3, 3) - S(3, 1) * S(2, 3);
    const V c3 = S(2, 1) * S(3, 2) - S(3, 1) * S(2, 2), c2 = S(2, 0) * S(3, 3) - S(3, 0) * S(2, 3);
    const V c1 = S(2, 0) * S(3, 2) - S(3, 0) * S(2, 2), c0 = S(2, 0) * S(3, 1) - S(3, 0) * S(2, 1);
    Mat4 adj;
    adj.k[0] = S(1, 1) * c5 - S(1, 2) * c4 + S(1, 3) * c3;
    adj.k[1] = -S(0, 1) * c5 + S(0, 2) * c4 - S(0, 3) * c3;
    adj.k[2] = S(3, 1) * s5 - S(3, 2) * s4 + S(3, 3) * s3;
    adj.k[3] = -S(2, 1) * s5 + S(2, 2) * s4 - S(2, 3) * s3;
    adj.k[4] = -S(1, 0) * c5 + S(1, 2) * c2 - S(1, 3) * c1;
    adj.k[5] = S(0, 0) * c5 - S(0, 2) * c2 + S(0, 3) * c1;
    adj.k[6] = -S(3, 0) * s5 + S(3, 2) * s2 - S(3, 3) * s1;
    adj.k[7] = S(2, 0) * s5 - S(2, 2) * s2 + S(2, 3) * s1;
    adj.k[8] = S(1, 0) * c4 - S(1, 1) * c2 + S(1, 3) * c0;
    adj.k[9] = -S(0, 0) * c4 + S(0, 1) * c2 - S(0, 3) * c0;
    adj.k[10] = S(3, 0) * s4 - S(3, 1) * s2 + S(3, 3) * s0;
    adj.k[11] = -S(2, 0) * s4 + S(2, 1) * s2 - S(2, 3) * s0;
    adj.k[12] = -S(1, 0) * c3 + S(1, 1) * c1 - S(1, 2) * c0;
    adj.k[13] = S(0, 0) * c3 - S(0, 1) * c1 + S(0, 2) * c0;
    adj.k[14] = -S(3, 0) * s3 + S(3, 1) * s1 - S(3, 2) * s0;
    adj.k[15] = S(2, 0) * s3 - S(2, 1) * s1 + S(2, 2) * s0;
    return adj;
  }

  /// The fast path of eq. (14): the column of adj(K - y I) with the largest diagonal entry, then one step of
  /// the power method on that adjugate (mirrors the scalar fast_axis; see there for the error analysis).
  /// adj is symmetric: its 10 distinct entries from the 12 complementary 2x2 minors of rows (0, 1) and (2, 3) (11 of
  /// the 12: the symmetric entries need no c0),
  /// sums of products fused. `dk` returns the largest |diagonal entry| (the careful path's trigger).
  MLSDEFORM_KERNEL_INLINE static Vec4 fast_axis(const Mat4& K, V y, V& dk) {
    const V S00 = K.k[0] - y, S11 = K.k[5] - y, S22 = K.k[10] - y, S33 = K.k[15] - y;
    const V S01 = K.k[1], S02 = K.k[2], S03 = K.k[3], S12 = K.k[6], S13 = K.k[7], S23 = K.k[11];
    const V s0 = mul_sub(S00, S11, S01 * S01), s1 = mul_sub(S00, S12, S01 * S02), s2 = mul_sub(S00, S13, S01 * S03);
    const V s3 = mul_sub(S01, S12, S11 * S02), s4 = mul_sub(S01, S13, S11 * S03), s5 = mul_sub(S02, S13, S12 * S03);
    const V c5 = mul_sub(S22, S33, S23 * S23), c4 = mul_sub(S12, S33, S13 * S23), c3 = mul_sub(S12, S23, S13 * S22);
    const V c2 = mul_sub(S02, S33, S03 * S23), c1 = mul_sub(S02, S23, S03 * S22);
    const V a00 = mul_add(S11, c5, mul_sub(S13, c3, S12 * c4));
    const V a01 = mul_add(S02, c4, -mul_add(S01, c5, S03 * c3));
    const V a02 = mul_add(S13, s5, mul_sub(S33, s3, S23 * s4));
    const V a03 = mul_add(S22, s4, -mul_add(S12, s5, S23 * s3));
    const V a11 = mul_add(S00, c5, mul_sub(S03, c1, S02 * c2));
    const V a12 = mul_add(S23, s2, -mul_add(S03, s5, S33 * s1));
    const V a13 = mul_add(S02, s5, mul_sub(S23, s1, S22 * s2));
    const V a22 = mul_add(S03, s4, mul_sub(S33, s0, S13 * s2));
    const V a23 = mul_add(S12, s2, -mul_add(S02, s4, S23 * s0));
    const V a33 = mul_add(S02, s3, mul_sub(S22, s0, S12 * s1));
    const V adj[4][4] = {{a00, a01, a02, a03}, {a01, a11, a12, a13}, {a02, a12, a22, a23}, {a03, a13, a23, a33}};
    // Column k = argmax |a_kk| (first index on ties), by selects.
    const V d0 = abs(a00), d1 = abs(a11), d2 = abs(a22), d3 = abs(a33);
    dk = max(max(d0, d1), max(d2, d3));
    const M k0 = d0 == dk, k1 = ~k0 & (d1 == dk), k2 = ~(k0 | k1) & (d2 == dk);
    Vec4 col;
    for (int i = 0; i < 4; ++i) col.v[i] = select(k0, adj[i][0], select(k1, adj[i][1], select(k2, adj[i][2], adj[i][3])));
    Vec4 q;
    for (int i = 0; i < 4; ++i)
      q.v[i] = mul_add(adj[i][0], col.v[0], mul_add(adj[i][1], col.v[1], mul_add(adj[i][2], col.v[2], adj[i][3] * col.v[3])));
    return q;
  }

  /// One-hot lane masks for the column k (scalar strongest_column: maxCoeff's first index, then k = 0 if
  /// |adj00| >= |adj_kk| / 4); dk the largest |diagonal cofactor|.
  struct Columns {
    M k[4];
    V dk;
  };
  MLSDEFORM_KERNEL_INLINE static Columns strongest_column(const Mat4& adj) {
    Columns c;
    const V d[4] = {abs(adj.k[0]), abs(adj.k[5]), abs(adj.k[10]), abs(adj.k[15])};
    c.dk = max(max(d[0], d[1]), max(d[2], d[3]));
    c.k[0] = d[0] >= V(T(0.25)) * c.dk;
    M taken = c.k[0];
    for (int j = 1; j < 4; ++j) {
      c.k[j] = ~taken & (d[j] == c.dk);
      taken = taken | c.k[j];
    }
    c.k[3] = c.k[3] | ~taken;  // NaN lanes (H = 0): any choice, they are replaced by the identity
    return c;
  }

  MLSDEFORM_KERNEL_INLINE static Vec4 column(const Mat4& adj, const M (&pick)[4]) {
    Vec4 col;
    for (int i = 0; i < 4; ++i)
      col.v[i] = select(pick[0], adj(i, 0), select(pick[1], adj(i, 1), select(pick[2], adj(i, 2), adj(i, 3))));
    return col;
  }

  MLSDEFORM_KERNEL_INLINE static V dot(const Vec4& a, const Vec4& b) {
    return a.v[0] * b.v[0] + a.v[1] * b.v[1] + a.v[2] * b.v[2] + a.v[3] * b.v[3];
  }
  MLSDEFORM_KERNEL_INLINE static Vec4 mul(const Mat4& K, const Vec4& x) {
    Vec4 r;
    for (int i = 0; i < 4; ++i) r.v[i] = K(i, 0) * x.v[0] + K(i, 1) * x.v[1] + K(i, 2) * x.v[2] + K(i, 3) * x.v[3];
    return r;
  }

  /// Rayleigh-Ritz on span{column k, the column most independent of it}: mirrors the scalar ritz_top,
  /// including `gap` (infinity where the columns span a line).
  MLSDEFORM_KERNEL_INLINE static Vec4 ritz_top(const Mat4& adj, const Columns& c, const Mat4& K, V a, V& gap) {
    const Vec4 ck = column(adj, c.k);
    Vec4 b1, b2;
    const V inv1 = V(T(1)) / sqrt(dot(ck, ck));
    for (int i = 0; i < 4; ++i) b1.v[i] = ck.v[i] * inv1;
    // l: the largest remainder |c_j|^2 - (b1 . c_j)^2 over j != k (first index on ties; scalar: rem > best).
    M l[4];
    V best(T(-1));
    M taken = c.k[0] ^ c.k[0];
    for (int j = 0; j < 4; ++j) {
      Vec4 cj;
      for (int i = 0; i < 4; ++i) cj.v[i] = adj(i, j);
      const V p = dot(b1, cj), rem = dot(cj, cj) - p * p;
      l[j] = ~c.k[j] & (rem > best);
      best = select(l[j], rem, best);
      taken = taken | l[j];
    }
    // Keep only the last index that improved (the first maximum); NaN lanes: the scalar's default.
    for (int j = 0; j < 3; ++j)
      for (int m = j + 1; m < 4; ++m) l[j] = l[j] & ~l[m];
    const M none = ~taken;
    l[1] = l[1] | (none & c.k[0]);
    l[0] = l[0] | (none & ~c.k[0]);
    const Vec4 cl = column(adj, l);
    V p = dot(b1, cl);
    for (int i = 0; i < 4; ++i) b2.v[i] = cl.v[i] - b1.v[i] * p;
    // scalar: if (!(|b2|^2 > 64^2 eps^2 |cl|^2)) return b1;
    const M line_only = !(dot(b2, b2) > V(T(64 * 64) * eps * eps) * dot(cl, cl));
    p = dot(b1, b2);  // twice is enough
    for (int i = 0; i < 4; ++i) b2.v[i] = b2.v[i] - b1.v[i] * p;
    const V inv2 = V(T(1)) / sqrt(dot(b2, b2));
    for (int i = 0; i < 4; ++i) b2.v[i] = b2.v[i] * inv2;
    const Vec4 Kb1 = mul(K, b1), Kb2 = mul(K, b2);
    const V B11 = dot(b1, Kb1), B12 = dot(b1, Kb2), B22 = dot(b2, Kb2);
    const V d = V(T(0.5)) * (B11 - B22);
    const V r = sqrt(d * d + B12 * B12);
    constexpr T inf = std::numeric_limits<T>::infinity();
    gap = select(line_only, V(inf), V(T(2)) * r);
    // scalar: if (!(r > 8 eps a)) { the plane's vector closest to e0 (or e_m) }
    const M is_double = !(r > V(T(8) * eps) * a);
    V proj[4];
    for (int i = 0; i < 4; ++i) proj[i] = b1.v[i] * b1.v[i] + b2.v[i] * b2.v[i];
    const V pm = max(max(proj[0], proj[1]), max(proj[2], proj[3]));
    M pick[4];
    pick[0] = proj[0] >= V(T(0.25)) * pm;
    taken = pick[0];
    for (int j = 1; j < 4; ++j) {
      pick[j] = ~taken & (proj[j] == pm);
      taken = taken | pick[j];
    }
    V b1m = b1.v[3], b2m = b2.v[3];
    for (int j = 2; j >= 0; --j) {
      b1m = select(pick[j], b1.v[j], b1m);
      b2m = select(pick[j], b2.v[j], b2m);
    }
    const M d_pos = d >= V(T(0));
    const V f1 = select(d_pos, d + r, B12), f2 = select(d_pos, B12, r - d);
    Vec4 q;
    for (int i = 0; i < 4; ++i) {
      const V ritz = f1 * b1.v[i] + f2 * b2.v[i];
      const V dbl = b1.v[i] * b1m + b2.v[i] * b2m;
      q.v[i] = select(line_only, b1.v[i], select(is_double, dbl, ritz));
    }
    return q;
  }

  /// Eq. (14) generalised, mirroring the scalar rotation_axis. `fallback` returns the lanes whose adjugate
  /// was rounding noise even when shifted (a triple root), which the scalar code redoes; `near_double` those
  /// that took the shifted evaluation. `clustered`: the lanes whose top three eigenvalues of K cluster.
  MLSDEFORM_KERNEL_INLINE static Vec4 rotation_axis(const Mat4& K, V y, M clustered, M& near_double, M& fallback) {
    V a = abs(K.k[0]);
    for (int i = 1; i < 16; ++i) a = max(a, abs(K.k[i]));
    const V a3 = a * a * a;
    const V sqrt_eps(Simd<T, A>::sqrt_eps);
    Mat4 adj = adjugate(shifted(K, y));
    Columns c = strongest_column(adj);
    V gap;
    Vec4 q = ritz_top(adj, c, K, a, gap);
    // scalar: if (dk > sqrt(eps) a^3) regular, else the shifted evaluation
    const M regular = c.dk > sqrt_eps * a3;
    near_double = !regular;
    fallback = M(false);
    if (any(near_double)) {
      adj = adjugate(shifted(K, y + sqrt_eps * a));
      c = strongest_column(adj);
      V gap1;
      const Vec4 q1 = ritz_top(adj, c, K, a, gap1);
      for (int i = 0; i < 4; ++i) q.v[i] = select(regular, q.v[i], q1.v[i]);
      gap = select(regular, gap, gap1);
      fallback = near_double & !(c.dk > V(T(64) * eps) * a3);
    }
    // scalar: clustered lanes go to top_eigenvector (here: to the scalar fallback), and
    // refine = noise || (!(gap > a / 64) && gap > sqrt(eps) a); the noise lanes (fallback) are redone by the
    // scalar code, which runs its own passes.
    fallback = fallback | clustered;
    M refine = ~fallback & ~(gap > a / V(T(64))) & (gap > sqrt_eps * a);
    if (any(refine)) {
      V rho = dot(q, mul(K, q)) / dot(q, q);
      for (int pass = 0; pass < 2 && any(refine); ++pass) {
        adj = adjugate(shifted(K, rho));
        c = strongest_column(adj);
        V unused;
        const Vec4 next = ritz_top(adj, c, K, a, unused);
        const V rho_next = dot(next, mul(K, next)) / dot(next, next);
        refine = refine & (rho_next >= rho - V(T(8) * eps) * a);
        for (int i = 0; i < 4; ++i) q.v[i] = select(refine, next.v[i], q.v[i]);
        rho = select(refine, rho_next, rho);
      }
    }
    // scalar: the polish, one power step on K + y I (kept where it is non-zero).
    const Vec4 Kq = mul(K, q);
    Vec4 polished;
    for (int i = 0; i < 4; ++i) polished.v[i] = Kq.v[i] + y * q.v[i];
    const M keep = dot(polished, polished) > V(T(0));
    for (int i = 0; i < 4; ++i) q.v[i] = select(keep, polished.v[i], q.v[i]);
    return q;
  }
};

}  // namespace mlsdeform::kernels
