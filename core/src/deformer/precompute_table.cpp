// Paper Sec. 5 for precomputed weights: per vertex, the centroid weights omega_j and the vectors A_j (or the
// affine alpha_j), p*, vhat and D, in double in the local frame, rounded to T once (data.hpp has the algebra).
#include "core/src/deformer/precompute.hpp"

#include "core/src/deformer/fold.hpp"
#include "core/src/deformer/near_handles.hpp"
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

/// Beside a segment handle (not snapped; near_handles.hpp): the fit's sums split into the
/// segment's own term and the rest, each formed without the other. Centred on the segment's closest point pc = p(tc)
/// (q_pc = (1 - tc) c + tc d) rather than on p*, the segment's own share is exact: p(t) - pc = (t - tc) e and
/// q(t) - q_pc = (t - tc) f (f = d - c), so with omega_j = w_j / S, j1 = J1 / S, j2 = J2 / S (its moments about tc,
/// weights.hpp) and a = sum_{others} omega_j (p_j - pc) (another segment: its integral), from
/// sum_j w_j (q_j - q*)(p_j - p*)^T = sum_j w_j (q_j - q_pc)(p_j - p*)^T and p* - pc = a + j1 e:
///   H = H' + m f e^T,  H' = sum_{others} omega_j (q_j - q_pc)(p_j - p*)^T - j1 f a^T,   m = j2 - j1^2 (the
///                      variance of t about its weighted mean, >= 0)
///   G = G' + m e e^T,  G' = sum_{others} omega_j (p_j - pc)(p_j - p*)^T - j1 e a^T
/// H' is sum_j (q_j - q_pc) A'_j^T with A'_j = omega_j (p_j - p*) (another segment: the table's A of its ends) and,
/// on the segment's ends, A'_c = j1 a, A'_d = -j1 a. Nothing of order m is subtracted anywhere: H' keeps its own
/// relative accuracy however small it is beside m (the others' weights fall as delta^u next to the segment).
struct BandSums {
  double m = 0;
  std::vector<double> ref;  ///< q_pc's weights
  std::vector<Vec3d> A;     ///< A'_j
  Eigen::Matrix3d G = Eigen::Matrix3d::Zero();
};

BandSums band_sums(const RestHandles& rh, const std::vector<double>& omega, const std::vector<SegmentMoments>& mom,
                   const std::vector<SegmentGeometry>& geo, double S, const Vec3d& p_star, std::size_t own) {
  const std::size_t k = rh.k, s = rh.s, J = k + 2 * s;
  BandSums b;
  b.ref.assign(J, 0.0);
  b.A.assign(J, Vec3d::Zero());
  const Vec3d e = rh.P[k + 2 * own + 1] - rh.P[k + 2 * own];
  const double tc = geo[own].tc;
  const Vec3d pc = rh.P[k + 2 * own] + tc * e;
  b.ref[k + 2 * own] = 1 - tc;
  b.ref[k + 2 * own + 1] = tc;
  Vec3d a = Vec3d::Zero();
  Eigen::Matrix3d G = Eigen::Matrix3d::Zero();
  for (std::size_t p = 0; p < k; ++p) {
    b.A[p] = omega[p] * (rh.P[p] - p_star);
    a += omega[p] * (rh.P[p] - pc);
    G += omega[p] * (rh.P[p] - pc) * (rh.P[p] - p_star).transpose();
  }
  for (std::size_t q = 0; q < s; ++q) {
    if (q == own) continue;
    const SegmentMoments& m = mom[q];
    const Vec3d eq = rh.P[k + 2 * q + 1] - rh.P[k + 2 * q];
    const double t = geo[q].tc, J0 = m.I0 + 2 * m.I1 + m.I2;
    const Vec3d g = (rh.P[k + 2 * q] + t * eq) - p_star;
    b.A[k + 2 * q] = (g * (m.I0 + m.I1) + eq * ((1 - t) * m.J1 - m.J2)) / S;
    b.A[k + 2 * q + 1] = (g * (m.I1 + m.I2) + eq * (t * m.J1 + m.J2)) / S;
    const Vec3d integral = g * J0 + eq * m.J1;  // int w (p - p*)
    a += (integral + J0 * (p_star - pc)) / S;
    G += (J0 * g * g.transpose() + m.J1 * (g * eq.transpose() + eq * g.transpose()) + m.J2 * eq * eq.transpose() +
          (p_star - pc) * integral.transpose()) /
         S;
  }
  const double j1 = mom[own].J1 / S, j2 = mom[own].J2 / S;
  b.m = j2 - j1 * j1;
  b.A[k + 2 * own] = j1 * a;
  b.A[k + 2 * own + 1] = -j1 * a;
  G -= j1 * e * a.transpose();
  b.G = 0.5 * (G + G.transpose());
  return b;
}

/// Vertex i's record for near_handles.hpp, where it has one: on a handle (snapped), the fit's limit there; beside a
/// segment handle whose own term swamps the others' (rho < kBandRatio<T>), its fit apart:
/// `band` (band_sums), and the centroid weights for its position. In the unscaled local units of the table.
template <class T>
void add_near_record(NearHandlesBuilder& builder, std::size_t i, const RestHandles& rh, const Options& o,
                     const NearestTwo& near, const std::vector<SegmentGeometry>& geo, bool snapped,
                     const BandSums& band, const std::vector<double>& centroid, const Vec3d& vhat,
                     const std::vector<std::array<double, kFoldedHandles>>& fold) {
  const std::size_t k = rh.k;
  NearRecord r;
  NearColumns cols;
  if (snapped) {
    const double t = near.nearest < k ? 0.0 : geo[near.nearest - k].tc;
    if (!handle_limit(rh, o, near.nearest, t, near.d_second, r, cols)) return;
  } else {
    if (!(band.m > 0)) return;
    const std::size_t a = k + 2 * (near.nearest - k);
    const double m_own = band.m;
    r.e = rh.P[a + 1] - rh.P[a];
    r.G = band.G;
    const Vec3d u = r.e.normalized();
    const double rho = (r.G.trace() - u.dot(r.G * u)) / (m_own * r.e.squaredNorm());
    if (!(rho < kBandRatio<T>)) return;
    r.dominated = !(rho >= kDominatedRatio);
    r.m = r.dominated ? 0.0 : m_own;
    r.own = std::ptrdiff_t(a);
    r.position = true;
    r.vhat = vhat;
    cols.c = band.ref;
    cols.star = centroid;
    cols.A = band.A;
  }
  r.vertex = i;
  if (!fold.empty()) {
    fold_columns(cols.c, k - fold.size(), fold);
    fold_columns(cols.star, k - fold.size(), fold);
    fold_columns(cols.A, k - fold.size(), fold);
    if (r.own >= 0) r.own = r.own - std::ptrdiff_t(fold.size()) + std::ptrdiff_t(kFoldedHandles);
  }
  builder.add(std::move(r), cols);
}

/// Sec. 5: the rest-pose precomputation for the vertices of block b (see data.hpp for what is
/// stored). Everything in double in the local frame; results rounded to T once, at the end. `fold`: the
/// weights beta of the data.folded fixed point handles that end the point handles (fold.hpp), or empty.
template <class T>
void precompute_block(DeformerData<T>& data, std::size_t b, const Points<T>& vertices, const LocalFrame& scene,
                      const RestHandles& rh, const Options& o, const RbfCentroids* rbf,
                      const std::vector<std::array<double, kFoldedHandles>>& fold, NearHandlesBuilder& near_builder) {
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
    // Their frames are the fit's limit there, taken apart (near_handles.hpp); the table holds the map's value.
    const bool interpolate = snapped && (nearest < k || exact);
    BandSums band;  // beside a segment: the sums without its own second moment (near_handles.hpp)
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
      double S = 0;
      const double d_ref = d_min;
      for (std::size_t p = 0; p < k; ++p) {
        omega[p] = snapped ? 0.0 : relative_weight(d_ref / dist[p], u);
        S += omega[p];
      }
      for (std::size_t q = 0; q < s; ++q) {
        if (snapped)
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
      Vec3d sum_A = Vec3d::Zero();
      for (std::size_t j = 0; j < J; ++j) sum_A += A[j];
      for (std::size_t j = 0; j < J; ++j) A[j] -= omega[j] * sum_A;
      vhat = v - p_star;
      // Sec. 6.1: D = sum_i w_i |phat_i|^2 / S (segments: int w |phat(t)|^2 / S).
      D = G.trace();
      G_vertex = 0.5 * (G + G.transpose());
      // Beside a segment: the fit's sums split, for near_handles.hpp (band_sums).
      if (!snapped && nearest >= k) band = band_sums(rh, omega, mom, geo, S, p_star, nearest - k);
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
    if (rbf && !interpolate) {
      rbf->weights(p_star, rbf_weights, rbf_rhs);
      centroid = &rbf_weights;
    }
    add_near_record<T>(near_builder, i, rh, o, near, geo, snapped, band, *centroid, vhat, fold);
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
  NearHandlesBuilder near_builder;
  parallel_ranges(data.blocks, o.threads, arena, [&](std::size_t b0, std::size_t b1) {
    for (std::size_t b = b0; b < b1; ++b) {
      throw_if_cancelled(cancel);
      precompute_block(data, b, vertices, scene, rh, o, rbf.get(), fold, near_builder);
    }
  });
  data.near = near_builder.finish(data.pseudo_handles());
}

template void precompute_table<float>(DeformerData<float>&, const Points<float>&, const LocalFrame&, const RestHandles&,
                                      const Options&, tbb::task_arena*, const CancelCheck&, const Handles<float>&,
                                      const FixedHandles<float>&);
template void precompute_table<double>(DeformerData<double>&, const Points<double>&, const LocalFrame&,
                                       const RestHandles&, const Options&, tbb::task_arena*, const CancelCheck&,
                                       const Handles<double>&, const FixedHandles<double>&);

}  // namespace mlsdeform::detail
