// The MLS deformer's per-frame evaluation, scalar reference: one block of 16 vertices, one vertex at a time,
// reading the precomputed table of deformer_data.hpp. A SIMD kernel computes the same stages in the same
// order with one vertex per lane; tests compare it with this code.
//
// Stages per vertex (Algorithm 1 with the precomputation of Sec. 5; see deformer_data.hpp for the algebra):
//   weighted_centroid   q* = sum_j omega_j q_j                                     (eq. 2)
//   correlation_matrix  H  = sum_j (q_j - c) A_j^T                                 (eq. 6; Sec. 6.2)
//   fit_rotation        R  = argmax trace(R^T H)                                   (eqs. 13-15, or a baseline)
//   scale               mu = trace(R^T H) / D (similarity, Sec. 6.1), else 1
//   apply               v' = q* + mu R vhat                                        (steps 8-10)
// Affine: v' = sum_j alpha_j q_j.
//
// Accumulation runs over j in increasing order in T, so a vertex's result depends only on its own data and
// the targets: bitwise the same for any thread count or block schedule.
#pragma once

#include "deformer_data.hpp"

#include <mlsdeform/deformer.hpp>
#include <mlsdeform/rotation.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace mlsdeform::detail {

/// Calls f(x, y, z) for the target q_j of every pseudo-handle j = 0, 1, ..., J-1 in order: the point
/// targets, then for each segment its two end targets (c, d).
template <class T, class F>
inline void for_each_target(const Handles<T>& q, F&& f) {
  const Eigen::Index k = q.points.rows(), s = q.segment_a.rows();
  for (Eigen::Index i = 0; i < k; ++i) f(q.points(i, 0), q.points(i, 1), q.points(i, 2));
  for (Eigen::Index i = 0; i < s; ++i) {
    f(q.segment_a(i, 0), q.segment_a(i, 1), q.segment_a(i, 2));
    f(q.segment_b(i, 0), q.segment_b(i, 1), q.segment_b(i, 2));
  }
}

/// The centring point c of the correlation matrix: the mean target, summed in pseudo-handle order in T.
template <class T>
inline Vector3<T> target_centre(const Handles<T>& q) {
  T sx = 0, sy = 0, sz = 0;
  std::size_t J = 0;
  for_each_target(q, [&](T x, T y, T z) {
    sx += x;
    sy += y;
    sz += z;
    ++J;
  });
  if (J == 0) return Vector3<T>::Zero();
  const T inv = T(1) / T(J);
  return Vector3<T>(sx * inv, sy * inv, sz * inv);
}

/// Rigid or similarity transform of the vertices of block b; write(v, x, y, z) stores vertex v's result.
template <class T, class Write>
void deform_block_rotation(const DeformerData<T>& data, std::size_t b, const Handles<T>& q, const Vector3<T>& c,
                           RotationMethod method, Write&& write) {
  const bool similarity = data.transform == Transform::similarity;
  const std::size_t first = b * kLanes, count = std::min(kLanes, data.n - first);
  const T* vx = data.vhat_block(b, 0);
  const T* vy = data.vhat_block(b, 1);
  const T* vz = data.vhat_block(b, 2);
  for (std::size_t lane = 0; lane < count; ++lane) {
    // weighted_centroid and correlation_matrix, in one pass over the pseudo-handles.
    T qs[3] = {0, 0, 0};
    T h[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    std::size_t j = 0;
    for_each_target(q, [&](T x, T y, T z) {
      const T* co = data.coefficients(b, j) + lane;
      const T omega = co[0], a[3] = {co[kLanes], co[2 * kLanes], co[3 * kLanes]};
      qs[0] += omega * x;
      qs[1] += omega * y;
      qs[2] += omega * z;
      const T d[3] = {x - c[0], y - c[1], z - c[2]};
      for (int r = 0; r < 3; ++r)
        for (int s = 0; s < 3; ++s) h[r][s] += d[r] * a[s];
      ++j;
    });
    Matrix3<T> H;
    for (int r = 0; r < 3; ++r)
      for (int s = 0; s < 3; ++s) H(r, s) = h[r][s];
    const Matrix3<T> R = fit_rotation<T>(H, method);
    T mu = 1;
    if (similarity) {
      const T D = data.D_block(b)[lane];
      // Sec. 6.1: mu_s = y / sum_i w_i |phat_i|^2 with y = trace(R^T H). D = 0 only where vhat = 0.
      if (D > T(0)) mu = R.cwiseProduct(H).sum() / D;
    }
    const Vector3<T> vh(vx[lane], vy[lane], vz[lane]);
    const Vector3<T> rv = R * vh;
    write(first + lane, qs[0] + mu * rv[0], qs[1] + mu * rv[1], qs[2] + mu * rv[2]);
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
/// then R, mu and v' = q* + mu R vhat as in deform_block_rotation (vhat = v - p*, local units: times
/// world_scale for rigid; the local scale cancels in mu vhat for similarity).
template <class T, class Write>
void deform_block_on_the_fly(const DeformerData<T>& data, std::size_t b, const Handles<T>& q, const Vector3<T>& c,
                             RotationMethod method, Write&& write) {
  const bool similarity = data.transform == Transform::similarity;
  const std::size_t first = b * kLanes, count = std::min(kLanes, data.n - first), np = data.padded(), k = data.points;
  const T* px = data.p_local.data();
  const T *py = px + k, *pz = px + 2 * k;
  for (std::size_t lane = 0; lane < count; ++lane) {
    const std::size_t i = first + lane;
    if (data.snap[i] >= T(0)) {  // Sec. 3: f(p_i) = q_i exactly
      const auto j = static_cast<Eigen::Index>(data.snap[i]);
      write(i, q.points(j, 0), q.points(j, 1), q.points(j, 2));
      continue;
    }
    const T vx = data.v_local[i], vy = data.v_local[np + i], vz = data.v_local[2 * np + i], dref2 = data.dref2[i];
    auto weight = [&](std::size_t j, T& dx, T& dy, T& dz) {
      dx = px[j] - vx, dy = py[j] - vy, dz = pz[j] - vz;
      const T r2 = dref2 / (dx * dx + dy * dy + dz * dz);
      return data.half_u == T(1) ? r2 : T(std::pow(r2, data.half_u));
    };
    T S = 0, ps[3] = {0, 0, 0}, qs[3] = {0, 0, 0};
    for (std::size_t j = 0; j < k; ++j) {
      T dx, dy, dz;
      const T w = weight(j, dx, dy, dz);
      S += w;
      ps[0] += w * dx, ps[1] += w * dy, ps[2] += w * dz;
      qs[0] += w * q.points(j, 0), qs[1] += w * q.points(j, 1), qs[2] += w * q.points(j, 2);
    }
    const T inv_S = T(1) / S;
    for (T& x : ps) x *= inv_S;  // p* - v
    for (T& x : qs) x *= inv_S;  // q*
    T h[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}, sum_a[3] = {0, 0, 0}, D = 0;
    for (std::size_t j = 0; j < k; ++j) {
      T dx, dy, dz;
      const T w = weight(j, dx, dy, dz) * inv_S;
      const T ph[3] = {dx - ps[0], dy - ps[1], dz - ps[2]};
      const T a[3] = {w * ph[0], w * ph[1], w * ph[2]};
      const T d[3] = {q.points(j, 0) - c[0], q.points(j, 1) - c[1], q.points(j, 2) - c[2]};
      for (int r = 0; r < 3; ++r)
        for (int s = 0; s < 3; ++s) h[r][s] += d[r] * a[s];
      for (int r = 0; r < 3; ++r) sum_a[r] += a[r];
      D += a[0] * ph[0] + a[1] * ph[1] + a[2] * ph[2];
    }
    Matrix3<T> H;
    for (int r = 0; r < 3; ++r)
      for (int s = 0; s < 3; ++s) H(r, s) = h[r][s] - (qs[r] - c[r]) * sum_a[s];
    const Matrix3<T> R = fit_rotation<T>(H, method);
    T mu = T(data.world_scale);
    if (similarity) mu = D > T(0) ? R.cwiseProduct(H).sum() / D : T(data.world_scale);
    const Vector3<T> rv = R * Vector3<T>(-ps[0], -ps[1], -ps[2]);
    write(i, qs[0] + mu * rv[0], qs[1] + mu * rv[1], qs[2] + mu * rv[2]);
  }
}

/// Affine transform of the vertices of block b: v' = sum_j alpha_j q_j.
template <class T, class Write>
void deform_block_affine(const DeformerData<T>& data, std::size_t b, const Handles<T>& q, Write&& write) {
  const std::size_t first = b * kLanes, count = std::min(kLanes, data.n - first);
  for (std::size_t lane = 0; lane < count; ++lane) {
    T x = 0, y = 0, z = 0;
    std::size_t j = 0;
    for_each_target(q, [&](T qx, T qy, T qz) {
      const T alpha = data.coefficients(b, j)[lane];
      x += alpha * qx;
      y += alpha * qy;
      z += alpha * qz;
      ++j;
    });
    write(first + lane, x, y, z);
  }
}

}  // namespace mlsdeform::detail
