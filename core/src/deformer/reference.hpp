// The MLS deformer's per-frame evaluation, scalar reference: the scalar entry of the kernel table
// (DeformBlocksFn), one vertex at a time over the same DeformFrame (kernels/contract.hpp) and session data
// (data.hpp) as the SIMD kernel kernels/deformer/deform_kernel.hpp, stage by stage (stages.hpp):
//   weighted_centroid   q* = sum_j omega_j q_j                                     (eq. 2)
//   correlation_matrix  H  = sum_j (q_j - c) A_j^T                                 (eq. 6; Sec. 6.2)
//   fit_rotation        R  = argmax trace(R^T H)                                   (eqs. 13-15, or a baseline)
//   similarity_scale    mu = trace(R^T H) / D (similarity, Sec. 6.1), else 1
//   apply               v' = q* + mu R vhat                                        (steps 8-10)
// Affine: v' = sum_j alpha_j q_j. All of it in the local frame (data.hpp, Units): targets times local_scale
// as they are read, results times world_scale as they are written.
//
// Accumulation runs over j in increasing order in T, so a vertex's result depends only on its own data and
// the targets: bitwise the same for any thread count or block schedule.
#pragma once

#include "core/src/deformer/stages.hpp"

#include "kernels/contract.hpp"

#include <mlsdeform/rotation.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace mlsdeform::detail {

/// Calls f(j, x, y, z) for the target q_j of every pseudo-handle j = 0, 1, ..., J-1 in order, in the local
/// frame: the point targets, then for each segment its two end targets (c, d).
template <class T, class F>
void for_each_target(const kernels::DeformFrame<T>& fr, F&& f) {
  const T ls = fr.local_scale;
  std::size_t j = 0;
  for (std::size_t i = 0; i < fr.k; ++i, ++j)
    f(j, fr.points[i] * ls, fr.points[fr.k + i] * ls, fr.points[2 * fr.k + i] * ls);
  for (std::size_t i = 0; i < fr.s; ++i) {
    f(j++, fr.seg_a[i] * ls, fr.seg_a[fr.s + i] * ls, fr.seg_a[2 * fr.s + i] * ls);
    f(j++, fr.seg_b[i] * ls, fr.seg_b[fr.s + i] * ls, fr.seg_b[2 * fr.s + i] * ls);
  }
}

/// Vertex v's position x_local, from the local frame to the caller's units.
template <class T>
void write_local_vertex(const kernels::DeformFrame<T>& fr, std::size_t v, const T (&x_local)[3]) {
  for (std::size_t c = 0; c < 3; ++c)
    fr.out[c * fr.out_coord_stride + v * fr.out_vertex_stride] = x_local[c] * fr.world_scale;
}

/// The stages after H (both weight sources): R = fit_rotation(H), mu (similarity_scale, else `scale`), apply.
template <class T>
void rotate_and_apply(const kernels::DeformFrame<T>& fr, const T (&h)[9], const T (&qs)[3], const T (&vh)[3], T D,
                      T scale, T (&out)[3]) {
  Matrix3<T> H;
  for (int i = 0; i < 9; ++i) H(i / 3, i % 3) = h[i];
  const Matrix3<T> Rm = fit_rotation<T>(H, fr.method);
  T r[9];
  for (int i = 0; i < 9; ++i) r[i] = Rm(i / 3, i % 3);
  const T mu = fr.transform == Transform::similarity ? similarity_scale(r, h, D, scale) : scale;
  apply(qs, mu, r, vh, out);
}

/// Rigid or similarity transform of the vertices of block b, precomputed weights.
template <class T>
void deform_block_table(const kernels::DeformFrame<T>& fr, std::size_t b) {
  using kernels::kLanes;
  const std::size_t first = b * kLanes, count = std::min(kLanes, fr.n - first), J = fr.k + 2 * fr.s;
  for (std::size_t lane = 0; lane < count; ++lane) {
    const std::size_t v = first + lane;
    // weighted_centroid and correlation_matrix, in one pass over the pseudo-handles.
    T qs[3] = {0, 0, 0}, h[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    for_each_target(fr, [&](std::size_t j, T x, T y, T z) {
      const T* co = fr.table + kernels::table_offset(b, j, J, fr.transform) + lane;
      weighted_centroid(qs, co[0], {x, y, z});
      correlation_matrix(h, {x - fr.centre[0], y - fr.centre[1], z - fr.centre[2]},
                         {co[kLanes], co[2 * kLanes], co[3 * kLanes]});
    });
    const T vh[3] = {fr.vhat[v], fr.vhat[fr.padded + v], fr.vhat[2 * fr.padded + v]};
    const T D = fr.transform == Transform::similarity ? fr.D[v] : T(0);
    T out[3];
    rotate_and_apply(fr, h, qs, vh, D, T(1), out);
    write_local_vertex(fr, v, out);
  }
}

/// On-the-fly weights (WeightStorage::on_the_fly; rigid and similarity, point handles): the vertices of
/// block b, recomputing w_j = (dref^2 / d_j^2)^(u/2) from the rest distances every frame (weights relative to
/// the nearest handle, as in the precomputation: all in (0, 1]). Coordinates are taken relative to the vertex
/// (p_j - v), so that near a handle, where p* ~ p_n and vhat is small, nothing cancels against the scene's
/// size; and, as in the precomputation, the common rounding of p* is projected out of the A_j
/// (H -= (q* - c) (sum_j A_j)^T). Two passes over the handles, for each vertex:
///   pass 1  S = sum w_j, p* - v = sum w_j (p_j - v) / S, q* = sum w_j q_j / S                      (eq. 2)
///   pass 2  phat_j = (p_j - v) - (p* - v), A_j = w_j phat_j / S, H = sum (q_j - c) A_j^T,
///           D = sum A_j . phat_j                                                         (eq. 6, Sec. 6.1)
/// then R, mu and v' = q* + mu R vhat as in deform_block_table (vhat = v - p*).
template <class T>
void deform_block_on_the_fly(const kernels::DeformFrame<T>& fr, std::size_t b) {
  using kernels::kLanes;
  const std::size_t first = b * kLanes, count = std::min(kLanes, fr.n - first), np = fr.padded, k = fr.k;
  const T* px = fr.p_local;
  const T *py = px + k, *pz = px + 2 * k;
  const T ls = fr.local_scale;
  auto q = [&](std::size_t c, std::size_t j) { return fr.points[c * k + j] * ls; };  // local frame
  for (std::size_t lane = 0; lane < count; ++lane) {
    const std::size_t i = first + lane;
    if (fr.snap[i] >= T(0)) {  // Sec. 3: f(p_i) = q_i exactly (to the local frame and back: data.hpp, Units)
      const auto j = static_cast<std::size_t>(fr.snap[i]);
      write_local_vertex(fr, i, {q(0, j), q(1, j), q(2, j)});
      continue;
    }
    const T vx = fr.v_local[i], vy = fr.v_local[np + i], vz = fr.v_local[2 * np + i], dref2 = fr.dref2[i];
    auto weight = [&](std::size_t j, T& dx, T& dy, T& dz) {
      dx = px[j] - vx, dy = py[j] - vy, dz = pz[j] - vz;
      const T r2 = dref2 / (dx * dx + dy * dy + dz * dz);
      return fr.half_u == T(1) ? r2 : T(std::pow(r2, fr.half_u));
    };
    T S = 0, ps[3] = {0, 0, 0}, qs[3] = {0, 0, 0};
    for (std::size_t j = 0; j < k; ++j) {
      T dx, dy, dz;
      const T w = weight(j, dx, dy, dz);
      S += w;
      ps[0] += w * dx, ps[1] += w * dy, ps[2] += w * dz;
      weighted_centroid(qs, w, {q(0, j), q(1, j), q(2, j)});
    }
    const T inv_S = T(1) / S;
    for (T& x : ps) x *= inv_S;  // p* - v
    for (T& x : qs) x *= inv_S;  // q*
    T h[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0}, sum_a[3] = {0, 0, 0}, D = 0;
    for (std::size_t j = 0; j < k; ++j) {
      T dx, dy, dz;
      const T w = weight(j, dx, dy, dz) * inv_S;
      const T ph[3] = {dx - ps[0], dy - ps[1], dz - ps[2]};
      const T a[3] = {w * ph[0], w * ph[1], w * ph[2]};
      correlation_matrix(h, {q(0, j) - fr.centre[0], q(1, j) - fr.centre[1], q(2, j) - fr.centre[2]}, a);
      for (int r = 0; r < 3; ++r) sum_a[r] += a[r];
      D += a[0] * ph[0] + a[1] * ph[1] + a[2] * ph[2];
    }
    for (int r = 0; r < 3; ++r)
      for (int s = 0; s < 3; ++s) h[3 * r + s] = h[3 * r + s] - (qs[r] - fr.centre[r]) * sum_a[s];
    const T vh[3] = {-ps[0], -ps[1], -ps[2]};
    T out[3];
    rotate_and_apply(fr, h, qs, vh, D, T(1), out);
    write_local_vertex(fr, i, out);
  }
}

/// Affine transform of the vertices of block b: v' = sum_j alpha_j q_j.
template <class T>
void deform_block_affine(const kernels::DeformFrame<T>& fr, std::size_t b) {
  using kernels::kLanes;
  const std::size_t first = b * kLanes, count = std::min(kLanes, fr.n - first), J = fr.k + 2 * fr.s;
  for (std::size_t lane = 0; lane < count; ++lane) {
    T out[3] = {0, 0, 0};
    for_each_target(fr, [&](std::size_t j, T qx, T qy, T qz) {
      weighted_centroid(out, fr.table[kernels::table_offset(b, j, J, fr.transform) + lane], {qx, qy, qz});
    });
    write_local_vertex(fr, first + lane, out);
  }
}

/// The scalar kernel-table entry (DeformBlocksFn): blocks [block_begin, block_end).
template <class T>
void deform_blocks_reference(const kernels::DeformFrame<T>& fr, std::size_t block_begin, std::size_t block_end) {
  for (std::size_t b = block_begin; b < block_end; ++b) {
    if (fr.weights == kernels::WeightSource::on_the_fly)
      deform_block_on_the_fly(fr, b);
    else if (fr.transform == Transform::affine)
      deform_block_affine(fr, b);
    else
      deform_block_table(fr, b);
  }
}

}  // namespace mlsdeform::detail
