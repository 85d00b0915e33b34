// Paper Sec. 5 for on-the-fly weights (WeightStorage::on_the_fly): no table; the rest geometry in the local
// frame, from which the kernels recompute the weights every frame (kernels/deformer/deform_kernel.hpp). With
// WeightStorage::precomputed_weights also the weights themselves, normalised, and p* (eq. 2).
#include "core/src/deformer/precompute.hpp"

#include "core/src/deformer/near_handles.hpp"
#include "core/src/deformer/snap.hpp"
#include "core/src/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mlsdeform::detail {

using Vec3d = Eigen::Vector3d;

namespace {

/// WeightStorage::precomputed_weights: vertex i's normalised weights w_j / S into data.weights and p* - v into
/// data.p_star_local, in double from the coordinates the frame reads (vt: v_local rounded to T, p_local),
/// relative to the nearest handle as the on-the-fly pass computes them (w_j = (d2 / |p_j - v|^2)^(u/2), all in
/// (0, 1]), each rounded once to T. The per-frame pass (deform_kernel.hpp, weights_only) then forms
/// phat_j = (p_j - v) - (p* - v) and A_j = (w_j / S) phat_j as the on-the-fly pass does.
template <class T>
void weights_of_vertex(DeformerData<T>& data, std::size_t i, const Vec3d& vt, double d2, double half_u) {
  const std::size_t k = data.points, np = data.padded(), b = i / kLanes, lane = i % kLanes;
  double S = 0;
  Vec3d ps = Vec3d::Zero();
  T* w = data.weights.data() + b * k * kLanes + lane;
  for (std::size_t j = 0; j < k; ++j) {
    const Vec3d p(double(data.p_local[j]), double(data.p_local[k + j]), double(data.p_local[2 * k + j]));
    const double r2 = d2 / (p - vt).squaredNorm();
    const double wj = half_u == 1 ? r2 : std::pow(r2, half_u);
    S += wj;
    ps += wj * (p - vt);
  }
  for (std::size_t j = 0; j < k; ++j) {
    const Vec3d p(double(data.p_local[j]), double(data.p_local[k + j]), double(data.p_local[2 * k + j]));
    const double r2 = d2 / (p - vt).squaredNorm();
    w[j * kLanes] = T((half_u == 1 ? r2 : std::pow(r2, half_u)) / S);
  }
  ps /= S;
  for (int c = 0; c < 3; ++c) data.p_star_local[std::size_t(c) * np + i] = T(ps[c]);
  // sum_j A_j and D = sum_j A_j . phat_j, in T from the values the per-frame pass reads, by its operations in its
  // order (phat_j = (p_j - v) - (p* - v), A_j = (w_j / S) phat_j): they depend on the rest pose alone, and the pass
  // subtracts (q* - c)(sum_j A_j)^T from its sum of ((w_j / S)(q_j - c)) phat_j^T, so that H is the centred sum of
  // the very phat_j it formed (deform_kernel.hpp, weights_only).
  const T vx = data.v_local[i], vy = data.v_local[np + i], vz = data.v_local[2 * np + i];
  const T psx = data.p_star_local[i], psy = data.p_star_local[np + i], psz = data.p_star_local[2 * np + i];
  T sa[3] = {0, 0, 0}, D = 0;
  for (std::size_t j = 0; j < k; ++j) {
    const T wj = w[j * kLanes];
    const T ph[3] = {(data.p_local[j] - vx) - psx, (data.p_local[k + j] - vy) - psy,
                     (data.p_local[2 * k + j] - vz) - psz};
    const T a[3] = {wj * ph[0], wj * ph[1], wj * ph[2]};
    for (int c = 0; c < 3; ++c) sa[c] = sa[c] + a[c];
    D = D + (a[0] * ph[0] + a[1] * ph[1] + a[2] * ph[2]);
  }
  for (int c = 0; c < 3; ++c) data.sum_a[std::size_t(c) * np + i] = sa[c];
  if (!data.D.empty()) data.D[i] = D;
}

}  // namespace

template <class T>
void precompute_on_the_fly(DeformerData<T>& data, const Points<T>& vertices, const LocalFrame& scene,
                           const RestHandles& rh, const Options& o, bool weights_only, tbb::task_arena* arena,
                           const CancelCheck& cancel) {
  const std::size_t np = data.padded(), k = rh.k;
  data.on_the_fly = true;
  data.half_u = T(o.weight_exponent / 2);
  data.v_local.assign(3 * np, T(0));
  data.dref2.assign(np, T(1));
  data.snap.assign(np, T(-1));
  data.p_local.assign(3 * k, T(0));
  data.weights_only = weights_only;
  if (data.weights_only) {
    data.weights.assign(np * k, T(0));
    data.p_star_local.assign(3 * np, T(0));
    data.sum_a.assign(3 * np, T(0));
    if (o.transform == Transform::similarity) data.D.assign(np, T(0));
  }
  for (std::size_t j = 0; j < k; ++j)
    for (int c = 0; c < 3; ++c) data.p_local[std::size_t(c) * k + j] = T(rh.P[j][c]);
  NearHandlesBuilder near_builder;
  // The handles' spread (their box's diagonal, local): a vertex kFarRatio of it from every handle is fitted apart.
  Vec3d lo = Vec3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const Vec3d& p : rh.P) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const double spread = k > 0 ? (hi - lo).norm() : 0.0;
  parallel_ranges(data.blocks, o.threads, arena, [&](std::size_t b0, std::size_t b1) {
    for (std::size_t i = b0 * kLanes; i < std::min(data.n, b1 * kLanes); ++i) {
      if (i % kLanes == 0) throw_if_cancelled(cancel);
      const Vec3d v = scene.local(vertices.row(static_cast<Eigen::Index>(i)).transpose().template cast<double>());
      for (int c = 0; c < 3; ++c) data.v_local[std::size_t(c) * np + i] = T(v[c]);
      // The same rounded coordinates the per-frame pass uses, read back from where it reads them, so that the
      // nearest handle gets w = 1 and a vertex on a handle is at distance 0.
      const Vec3d vt(double(data.v_local[i]), double(data.v_local[np + i]), double(data.v_local[2 * np + i]));
      NearestTwo near;  // of the squared distances
      for (std::size_t j = 0; j < k; ++j) {
        const Vec3d p(double(data.p_local[j]), double(data.p_local[k + j]), double(data.p_local[2 * k + j]));
        near.add((p - vt).squaredNorm(), j);
      }
      const double d2 = near.d_min;
      data.dref2[i] = T(d2);
      // The rule of snap.hpp; and where d2 is not a normal number in T, the per-frame sum of squares in T
      // (whose terms are each rounded by up to half of T's smallest subnormal) could be 0 and the nearest
      // handle's weight dref2 / d2 infinite.
      if (snaps<T>(std::sqrt(d2), std::sqrt(near.d_second)) || !(T(d2) >= std::numeric_limits<T>::min())) {
        data.snap[i] = T(near.nearest);
        // Its frame: the fit's limit at the handle, apart from the kernels (near_handles.hpp).
        NearRecord r;
        NearColumns cols;
        if (handle_limit(rh, o, near.nearest, 0.0, std::sqrt(near.d_second), r, cols)) {
          r.vertex = i;
          near_builder.add(std::move(r), cols);
        }
      } else {
        if (data.weights_only) weights_of_vertex(data, i, vt, d2, double(data.half_u));
        NearRecord r;
        NearColumns cols;
        if (std::sqrt(d2) > kFarRatio * spread && far_fit(rh, o, v, r, cols)) {
          r.vertex = i;
          near_builder.add(std::move(r), cols);
        }
      }
    }
  });
  data.near = near_builder.finish(k);
}

template void precompute_on_the_fly<float>(DeformerData<float>&, const Points<float>&, const LocalFrame&,
                                           const RestHandles&, const Options&, bool, tbb::task_arena*,
                                           const CancelCheck&);
template void precompute_on_the_fly<double>(DeformerData<double>&, const Points<double>&, const LocalFrame&,
                                            const RestHandles&, const Options&, bool, tbb::task_arena*,
                                            const CancelCheck&);

}  // namespace mlsdeform::detail
