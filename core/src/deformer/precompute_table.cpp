// Paper Sec. 5 for precomputed weights: per vertex, the centroid weights omega_j and the vectors A_j (or the
// affine alpha_j), p*, vhat and D, in double in the local frame, rounded to T once (data.hpp has the algebra).
#include "core/src/deformer/precompute.hpp"

#include "core/src/deformer/fold.hpp"
#include "core/src/deformer/rbf_centroids.hpp"
#include "core/src/deformer/snap.hpp"
#include "core/src/deformer/weights.hpp"
#include "core/src/parallel.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

namespace mlsdeform::detail {

namespace {

using Vec3d = Eigen::Vector3d;

/// Sec. 5: the rest-pose precomputation for the vertices of block b (see data.hpp for what is
/// stored). Everything in double in the local frame; results rounded to T once, at the end. `fold`: the
/// weights beta of the data.folded fixed point handles that end the point handles (fold.hpp), or empty.
template <class T>
void precompute_block(DeformerData<T>& data, std::size_t b, const Points<T>& vertices, const LocalFrame& scene,
                      const RestHandles& rh, const Options& o, const RbfCentroids* rbf,
                      const std::vector<std::array<double, kFoldedHandles>>& fold) {
  const std::size_t J = rh.P.size(), k = rh.k, s = rh.s;
  const double u = o.weight_exponent;
  const bool affine = data.transform == Transform::affine;
  const bool exact = o.segment_weight == SegmentWeight::exact_integral;
  std::vector<double> dist(k), omega(J);
  std::vector<SegmentGeometry> geo(s);
  std::vector<SegmentMoments> mom(s);
  std::vector<Vec3d> A(J);
  std::vector<double> rbf_weights;  // Centroids::rbf: q* = g(p*) = sum_j rbf_weights_j q_j (rbf_centroids.hpp)
  Eigen::VectorXd rbf_rhs;
  std::vector<double> column(J);  // what a table column holds: the centroid weight, or alpha (affine)
  std::vector<Vec3d> A_column(J);
  std::vector<Vec3d> B_column(J);  // affine: G^-1 A_j, the frames' linear part (data.hpp)
  const std::size_t first = b * kLanes, count = std::min(kLanes, data.n - first), np = data.padded();
  for (std::size_t lane = 0; lane < count; ++lane) {
    const std::size_t i = first + lane;
    const Vec3d v = scene.local(vertices.row(static_cast<Eigen::Index>(i)).transpose().template cast<double>());
    // Distances to every handle; the nearest two (snap.hpp).
    NearestTwo near;  // nearest: point index, or k + segment index
    for (std::size_t p = 0; p < k; ++p) {
      dist[p] = (rh.P[p] - v).norm();
      near.add(dist[p], p);
    }
    for (std::size_t q = 0; q < s; ++q) {
      geo[q] = segment_geometry(v, rh.P[k + 2 * q], rh.P[k + 2 * q + 1]);
      near.add(geo[q].d, k + q);
    }
    const double d_min = near.d_min;
    const std::size_t nearest = near.nearest;
    std::fill(omega.begin(), omega.end(), 0.0);
    std::fill(A.begin(), A.end(), Vec3d::Zero());
    Vec3d p_star, vhat = Vec3d::Zero();
    double D = 0;
    Eigen::Matrix3d G_vertex = Eigen::Matrix3d::Zero();  // G = sum_j A_j phat_j^T, symmetric (affine; D = trace)
    // At a handle (snap.hpp) the vertex takes the map's limit there, so that the map is continuous:
    //   point handle, or segment with exact_integral weights: the weight concentrates at the closest point,
    //     and the limit is the interpolation f(p_i) = q_i (Sec. 3), (1 - t) c + t d on a segment;
    //   segment with paper_constant weights: the segment's weight is constant along it (Sec. 6.2), so the
    //     limit is the fit to that segment alone (every other weight vanishes relative to it): p* and q* its
    //     midpoints, H = (d - c)(b - a)^T / 12. Rigid maps a stretched segment rigidly, not onto c..d, so
    //     interpolating there would be a jump; similarity and affine reproduce (1 - t) c + t d.
    const bool snapped = snaps<T>(d_min, near.d_second);
    // At a point handle (rigid, similarity, another handle at a distance): q* = q_n and vhat = 0 as below,
    // but A and D hold the fit's limit there, so that the vertex's frame (FramesOut, frames.hpp) is the
    // rotation the map has around the handle rather than the identity of H = 0. As v -> p_n the weights
    // relative to the nearest handle make H = sum_j (q_j - c) A_j^T tend to the direction of
    //   sum_{j != n} w_j (q_j - q_n)(p_j - p_n)^T,   w_j = (d_2 / |p_j - p_n|)^u (segments: their moments),
    // with d_2 the distance to the second-nearest handle (D stays 0: scale 1). The position q* + mu R vhat
    // is q_n for any finite R (vhat = 0, mu = 1): the same bits as with A = 0. Affine likewise: the limit of
    // G = sum_j A_j phat_j^T is that of the same weights (w_n |phat_n|^2 -> 0 as phat_n ~ 1 / w_n), L = H G^-1
    // its matrix, and with vhat = 0 alpha = omega to the bit.
    const bool limit =
        snapped && nearest < k && near.d_second > 0 && near.d_second < std::numeric_limits<double>::infinity();
    const bool interpolate = snapped && (nearest < k || exact) && !limit;
    if (interpolate) {
      // All weight on the nearest handle, A = 0, vhat = 0.
      if (nearest < k) {
        omega[nearest] = 1;
        p_star = rh.P[nearest];
      } else {
        const std::size_t q = nearest - k;
        const double t = geo[q].tc;
        omega[k + 2 * q] = 1 - t;
        omega[k + 2 * q + 1] = t;
        p_star = (1 - t) * rh.P[k + 2 * q] + t * rh.P[k + 2 * q + 1];
      }
    } else {
      // Weights relative to the nearest handle (weights.hpp): the nearest has weight 1, all are in [0, 1].
      // Snapped to a paper_constant segment: only that segment, with relative weight 1 (the limit above).
      // At a point handle's limit: the other handles, relative to the second-nearest.
      double S = 0;
      const double d_ref = limit ? near.d_second : d_min;
      for (std::size_t p = 0; p < k; ++p) {
        omega[p] = (snapped && !limit) || (limit && p == nearest) ? 0.0 : relative_weight(d_ref / dist[p], u);
        S += omega[p];
      }
      for (std::size_t q = 0; q < s; ++q) {
        if (snapped && !limit)
          mom[q] = q + k == nearest ? segment_moments_of_constant(1.0, geo[q].tc) : SegmentMoments{};
        else
          mom[q] = exact ? segment_moments_exact(geo[q], d_ref, u) : segment_moments_constant(geo[q], d_ref, u);
        S += mom[q].I0 + 2 * mom[q].I1 + mom[q].I2;
      }
      // Weighted centroid p* (eq. 2; Sec. 6.2: segment end points weighted by int w (1-t) and int w t).
      for (std::size_t p = 0; p < k; ++p) omega[p] /= S;
      for (std::size_t q = 0; q < s; ++q) {
        omega[k + 2 * q] = (mom[q].I0 + mom[q].I1) / S;
        omega[k + 2 * q + 1] = (mom[q].I1 + mom[q].I2) / S;
      }
      p_star.setZero();
      for (std::size_t j = 0; j < J; ++j) p_star += omega[j] * rh.P[j];
      if (limit) p_star = rh.P[nearest];  // phat_j = p_j - p_n
      // A_j (data.hpp): sum_j q_j A_j^T = sum_i w_i qhat_i phat_i^T / S, with the segments' W_i.
      // Segments about their closest point pc = p(tc): phat(t) = g + (t - tc) e with g = pc - p* and e = b - a,
      // so A_c = int w (1 - t) phat / S = (g (I0 + I1) + e ((1 - tc) J1 - J2)) / S and
      // A_d = int w t phat / S = (g (I1 + I2) + e (tc J1 + J2)) / S: near a segment g, J1 and J2 are small
      // and each term keeps its relative accuracy (as I0 ahat + I1 bhat the O(1) end points would cancel).
      // The segment's share of G = sum_i int w phat phat^T / S (affine) and of D = trace G (similarity) is
      // (J0 g g^T + J1 (g e^T + e g^T) + J2 e e^T) / S likewise, J0 = I0 + 2 I1 + I2.
      Eigen::Matrix3d G = Eigen::Matrix3d::Zero();
      for (std::size_t p = 0; p < k; ++p) {
        A[p] = omega[p] * (rh.P[p] - p_star);
        G += A[p] * (rh.P[p] - p_star).transpose();
      }
      for (std::size_t q = 0; q < s; ++q) {
        const SegmentMoments& m = mom[q];
        const Vec3d a = rh.P[k + 2 * q], e = rh.P[k + 2 * q + 1] - a;
        const double tc = geo[q].tc;
        const Vec3d g = (a + tc * e) - p_star;
        A[k + 2 * q] = (g * (m.I0 + m.I1) + e * ((1 - tc) * m.J1 - m.J2)) / S;
        A[k + 2 * q + 1] = (g * (m.I1 + m.I2) + e * (tc * m.J1 + m.J2)) / S;
        const double J0 = m.I0 + 2 * m.I1 + m.I2;
        G += (J0 * g * g.transpose() + m.J1 * (g * e.transpose() + e * g.transpose()) + m.J2 * e * e.transpose()) / S;
      }
      // sum_j A_j = 0 exactly, but the rounding error of p* (eps times the scene size, shared by every
      // phat_j) enters each A_j as -omega_j dp* and their sum as -dp*: near a handle, where every A_j is
      // small (omega_j tiny or phat_j tiny), that common error would dominate H = sum q_j A_j^T. Project it
      // out: A_j -= omega_j sum_k A_k removes any error of the form -omega_j d (sum_j omega_j = 1), so what
      // remains of each A_j is its own relative rounding.
      // At a point handle's limit, q* is the handle's target (omega its interpolation) and the projection
      // makes A_n = -sum_{j != n} A_j: H = sum_{j != n} (q_j - q_n) A_j^T, whatever c is.
      if (limit) {
        std::fill(omega.begin(), omega.end(), 0.0);
        omega[nearest] = 1;
      }
      Vec3d sum_A = Vec3d::Zero();
      for (std::size_t j = 0; j < J; ++j) sum_A += A[j];
      for (std::size_t j = 0; j < J; ++j) A[j] -= omega[j] * sum_A;
      vhat = limit ? Vec3d::Zero() : Vec3d(v - p_star);
      // Sec. 6.1: D = sum_i w_i |phat_i|^2 / S (segments: int w |phat(t)|^2 / S). At a point handle's limit
      // D = 0 (mu = 1): a similarity scale beyond T's range must not reach the position as inf * 0.
      D = limit ? 0.0 : G.trace();
      G_vertex = 0.5 * (G + G.transpose());
    }
    // H matters only up to a positive factor (the rotation fit is scale-invariant and mu = trace(R^T H) / D,
    // and for affine only H G^-1 does), so A and D are scaled per vertex by a power of two 2^s that brings
    // sum_j |A_j|_1 into [1, 2): near a handle every A_j is about (d_min / d)^u, which for u = 8 is below the
    // float range a few 1e-5 of the scene away, and would drop out of H entirely; for affine, G^-1 vhat
    // would overflow where G is that small. (The sum, not the largest: |H| <= 2 max_j |q_j - c|.)
    double a_sum = 0;
    for (std::size_t j = 0; j < J; ++j) a_sum += A[j].cwiseAbs().sum();
    const int s_v = a_sum > 0 ? -std::ilogb(a_sum) : 0;
    for (std::size_t j = 0; j < J; ++j)
      for (int c = 0; c < 3; ++c) A[j][c] = std::ldexp(A[j][c], s_v);
    D = std::ldexp(D, s_v);
    G_vertex *= std::ldexp(1.0, s_v);
    // Centroids::rbf: the weights of q* = g(p*) take omega's place as the centroid weights (A_j keep omega's
    // projection above: it concerns p*, not q*). At a handle the interpolation is kept as it is: g interpolates
    // there too, and f(p_i) = q_i stays exact.
    const std::vector<double>* centroid = &omega;
    if (rbf && !interpolate && !limit) {
      rbf->weights(p_star, rbf_weights, rbf_rhs);
      centroid = &rbf_weights;
    }
    if (affine) {
      // Normal equations: L G = H with G = sum_j A_j phat_j^T (symmetric positive definite when the handles
      // span 3D), so v' = q* + H G^-1 vhat = sum_j (omega_j + A_j . G^-1 vhat) q_j. G is solved through its
      // eigen-decomposition; eigenvalues below 64 eps lambda_max (reachable only when weights leave the
      // double range, u log10(d_min / d) < -300) are dropped (minimum-norm solution) instead of dividing by
      // rounding noise.
      // The frames' B_j = G^-1 A_j by the same eigen-decomposition (data.hpp), projected onto sum_j B_j = 0 as A.
      // Only with Options::affine_frames (its table allocated); alpha does not depend on it.
      const bool frames = !data.linear_table.empty();
      Vec3d x = Vec3d::Zero();
      B_column.assign(frames ? J : 0, Vec3d::Zero());
      if (!interpolate) {  // else G = 0 and A = 0: no fit
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(G_vertex);
        const Vec3d lambda = es.eigenvalues();
        const double cut = 64 * std::numeric_limits<double>::epsilon() * lambda[2];
        for (int c = 0; c < 3; ++c)
          if (lambda[c] > cut) {
            if (vhat != Vec3d::Zero()) x += (es.eigenvectors().col(c).dot(vhat) / lambda[c]) * es.eigenvectors().col(c);
            for (std::size_t j = 0; j < B_column.size(); ++j)
              B_column[j] += (es.eigenvectors().col(c).dot(A[j]) / lambda[c]) * es.eigenvectors().col(c);
          }
        Vec3d sum_B = Vec3d::Zero();
        for (std::size_t j = 0; j < B_column.size(); ++j) sum_B += B_column[j];
        for (std::size_t j = 0; j < B_column.size(); ++j) B_column[j] -= omega[j] * sum_B;
      }
      // alpha_j = omega_j + beta_j with beta_j = A_j . x; as for A, project beta onto sum_j beta_j = 0 so
      // that the rounding of x (relative eps kappa(G)) cannot move q* = sum_j omega_j q_j.
      double sum_beta = 0;
      for (std::size_t j = 0; j < J; ++j) sum_beta += A[j].dot(x);
      column.resize(J);
      for (std::size_t j = 0; j < J; ++j) column[j] = (*centroid)[j] + (A[j].dot(x) - omega[j] * sum_beta);
      if (!fold.empty()) {
        fold_columns(column, k - fold.size(), fold);
        if (frames) fold_columns(B_column, k - fold.size(), fold);
      }
      for (std::size_t j = 0; j < column.size(); ++j) {
        data.coefficients(b, j)[lane] = T(column[j]);
        if (!frames) continue;
        T* bj = data.linear_table.data() + kernels::linear_table_offset(b, j, data.pseudo_handles()) + lane;
        for (int c = 0; c < 3; ++c) bj[c * kLanes] = T(B_column[j][c]);
      }
    } else {
      column.assign(centroid->begin(), centroid->end());
      A_column.assign(A.begin(), A.end());
      if (!fold.empty()) {
        fold_columns(column, k - fold.size(), fold);
        fold_columns(A_column, k - fold.size(), fold);
      }
      for (std::size_t j = 0; j < column.size(); ++j) {
        T* co = data.coefficients(b, j) + lane;
        co[0] = T(column[j]);
        for (int c = 0; c < 3; ++c) co[(c + 1) * kLanes] = T(A_column[j][c]);
      }
      for (int c = 0; c < 3; ++c) {
        data.p_star[c * np + i] = T(scene.centre[c] + std::ldexp(p_star[c], scene.e));
        data.vhat[c * np + i] = T(vhat[c]);
      }
      // Units (data.hpp): vhat local, A and D local times 2^s.
      if (data.transform == Transform::similarity) data.D[i] = T(D);
    }
  }
}

}  // namespace

template <class T>
void precompute_table(DeformerData<T>& data, const Points<T>& vertices, const LocalFrame& scene, const RestHandles& rh,
                      const Options& o, tbb::task_arena* arena, const CancelCheck& cancel, const Handles<T>& handles,
                      const FixedHandles<T>& fixed) {
  const std::size_t np = data.padded();
  data.table.assign(np * data.pseudo_handles() * data.components(), T(0));
  const std::vector<std::array<double, kFoldedHandles>> fold =
      data.folded ? fold_weights(Points<T>(handles.points.bottomRows(Eigen::Index(data.folded))), fixed.targets)
                  : std::vector<std::array<double, kFoldedHandles>>();
  if (o.transform == Transform::affine && o.affine_frames)
    data.linear_table.assign(np * data.pseudo_handles() * 3, T(0));
  if (o.transform != Transform::affine) {
    data.p_star.assign(3 * np, T(0));
    data.vhat.assign(3 * np, T(0));
  }
  if (o.transform == Transform::similarity) data.D.assign(np, T(0));
  const std::unique_ptr<RbfCentroids> rbf =
      o.centroids == Centroids::rbf ? std::make_unique<RbfCentroids>(rh.P) : nullptr;
  parallel_ranges(data.blocks, o.threads, arena, [&](std::size_t b0, std::size_t b1) {
    for (std::size_t b = b0; b < b1; ++b) {
      throw_if_cancelled(cancel);
      precompute_block(data, b, vertices, scene, rh, o, rbf.get(), fold);
    }
  });
}

template void precompute_table<float>(DeformerData<float>&, const Points<float>&, const LocalFrame&, const RestHandles&,
                                      const Options&, tbb::task_arena*, const CancelCheck&, const Handles<float>&,
                                      const FixedHandles<float>&);
template void precompute_table<double>(DeformerData<double>&, const Points<double>&, const LocalFrame&,
                                       const RestHandles&, const Options&, tbb::task_arena*, const CancelCheck&,
                                       const Handles<double>&, const FixedHandles<double>&);

}  // namespace mlsdeform::detail
