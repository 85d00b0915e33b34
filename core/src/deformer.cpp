// The MLS deformer (paper Sec. 3-6): validation, the rest-pose precomputation (Sec. 5) and the per-frame
// driver over blocks of 16 vertices (TBB). The per-vertex algebra is documented in deformer_data.hpp, the
// weights in weights.hpp, and the per-frame stages in deformer_scalar.hpp.
#include "deformer_data.hpp"
#include "deformer_scalar.hpp"
#include "dispatch.hpp"
#include "weights.hpp"

#include <mlsdeform/deformer.hpp>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace mlsdeform {

namespace {

using Vec3d = Eigen::Vector3d;

std::string num(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

/// Coordinates of targets may not exceed this: with |A_j| summing to O(1) (deformer_data.hpp, units), the
/// correlation matrix, q* and their intermediate differences then stay finite.
template <class T>
constexpr T coordinate_limit() {
  return std::numeric_limits<T>::max() / 64;
}

void check_options(const Options& o) {
  if (!std::isfinite(o.weight_exponent) || o.weight_exponent < 1.0)
    throw std::invalid_argument("Deformer: weight_exponent must be a finite real >= 1 (got " + num(o.weight_exponent) +
                                ")");
  if (o.transform != Transform::rigid && o.transform != Transform::similarity && o.transform != Transform::affine)
    throw std::invalid_argument("Deformer: unknown Transform value " + std::to_string(static_cast<int>(o.transform)));
  if (std::find(std::begin(all_rotation_methods), std::end(all_rotation_methods), o.method) ==
      std::end(all_rotation_methods))
    throw std::invalid_argument("Deformer: unknown RotationMethod value " + std::to_string(static_cast<int>(o.method)));
  if (o.segment_weight != SegmentWeight::paper_constant && o.segment_weight != SegmentWeight::exact_integral)
    throw std::invalid_argument("Deformer: unknown SegmentWeight value " +
                                std::to_string(static_cast<int>(o.segment_weight)));
  if (o.backend != Backend::simd && o.backend != Backend::scalar)
    throw std::invalid_argument("Deformer: unknown Backend value " + std::to_string(static_cast<int>(o.backend)));
  if (o.weight_storage != WeightStorage::automatic && o.weight_storage != WeightStorage::precomputed &&
      o.weight_storage != WeightStorage::on_the_fly)
    throw std::invalid_argument("Deformer: unknown WeightStorage value " +
                                std::to_string(static_cast<int>(o.weight_storage)));
  if (o.threads < 0) throw std::invalid_argument("Deformer: threads must be >= 0 (got " + std::to_string(o.threads) + ")");
}

/// `what` and `part` name the array in messages (no std::string is built unless there is an error: deform()
/// calls this and must not allocate).
template <class T>
void check_points(const Points<T>& p, const char* what, const char* part, T limit) {
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (Eigen::Index c = 0; c < 3; ++c) {
      const T x = p(i, c);
      if (!std::isfinite(x))
        throw std::invalid_argument(std::string("Deformer: non-finite coordinate in ") + what + part + " (row " +
                                    std::to_string(i) + ")");
      if (std::abs(x) > limit)
        throw std::invalid_argument(std::string("Deformer: coordinate too large in ") + what + part + " (row " +
                                    std::to_string(i) + ": " + num(double(x)) + ", limit " + num(double(limit)) + ")");
    }
}

template <class T>
void check_handles(const Handles<T>& h, const char* what, T limit) {
  if (h.segment_a.rows() != h.segment_b.rows())
    throw std::invalid_argument(std::string("Deformer: ") + what + " have " + std::to_string(h.segment_a.rows()) +
                                " segment start points (segment_a) but " + std::to_string(h.segment_b.rows()) +
                                " end points (segment_b)");
  check_points(h.points, what, " points", limit);
  check_points(h.segment_a, what, " segment_a", limit);
  check_points(h.segment_b, what, " segment_b", limit);
}

/// Moved handles must match the rest handles one to one.
template <class T>
void check_moved(const Handles<T>& moved, const Handles<T>& rest) {
  if (moved.points.rows() != rest.points.rows())
    throw std::invalid_argument("Deformer: " + std::to_string(rest.points.rows()) + " point handles at rest but " +
                                std::to_string(moved.points.rows()) + " moved point handles");
  if (moved.segment_a.rows() != rest.segment_a.rows() || moved.segment_b.rows() != rest.segment_b.rows())
    throw std::invalid_argument("Deformer: " + std::to_string(rest.segment_a.rows()) + " segment handles at rest but " +
                                std::to_string(moved.segment_a.rows()) + " moved segment_a and " +
                                std::to_string(moved.segment_b.rows()) + " moved segment_b rows");
  check_handles(moved, "moved handles", coordinate_limit<T>());
}

/// The local frame of the precomputation: the scene (rest vertices and handles) translated to its
/// bounding-box centre and scaled by 2^-e, e = ilogb(diagonal), an exact power of two. Distances in it are
/// O(1): no overflow or underflow, and scaling the scene by a power of two changes nothing at all.
struct Scene {
  Vec3d centre = Vec3d::Zero();
  int e = 0;
  double size_local = 0;  ///< bounding-box diagonal in local units: in [1, 2), or 0 for a single point

  Vec3d local(const Vec3d& x) const {
    const Vec3d d = x - centre;
    return Vec3d(std::ldexp(d[0], -e), std::ldexp(d[1], -e), std::ldexp(d[2], -e));
  }
};

template <class T>
Scene make_scene(const Points<T>& vertices, const Handles<T>& handles) {
  Vec3d lo = Vec3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  auto add = [&](const Points<T>& p) {
    for (Eigen::Index i = 0; i < p.rows(); ++i) {
      const Vec3d x = p.row(i).transpose().template cast<double>();
      lo = lo.cwiseMin(x);
      hi = hi.cwiseMax(x);
    }
  };
  add(vertices);
  add(handles.points);
  add(handles.segment_a);
  add(handles.segment_b);
  Scene s;
  const Vec3d half = 0.5 * hi - 0.5 * lo;  // halves first: no overflow
  s.centre = 0.5 * hi + 0.5 * lo;
  const double m = half.maxCoeff();
  const double diag = m > 0 ? 2 * m * (half / m).norm() : 0.0;
  if (!(diag <= double(coordinate_limit<T>())))
    throw std::invalid_argument("Deformer: the scene (bounding box of rest vertices and handles) is too large for the "
                                "precision: diagonal " + num(diag));
  s.e = diag > 0 ? std::ilogb(diag) : 0;
  s.size_local = std::ldexp(diag, -s.e);
  return s;
}

/// Affine MLS needs handles spanning 3D (otherwise G is singular at every vertex): numerical rank of the
/// centred pseudo-handle positions, with the usual relative tolerance max(J, 3) eps(T) sigma_1.
template <class T>
void check_affine_rank(const std::vector<Vec3d>& P) {
  const std::size_t J = P.size();
  if (J < 4)
    throw std::invalid_argument("Deformer: the affine transform needs handles spanning 3D (at least four non-coplanar "
                                "points, segment end points included); got " + std::to_string(J));
  Vec3d mean = Vec3d::Zero();
  for (const Vec3d& p : P) mean += p;
  mean /= double(J);
  Eigen::Matrix<double, Eigen::Dynamic, 3> M(static_cast<Eigen::Index>(J), 3);
  for (std::size_t j = 0; j < J; ++j) M.row(static_cast<Eigen::Index>(j)) = (P[j] - mean).transpose();
  const Vec3d sv = Eigen::JacobiSVD<Eigen::Matrix<double, Eigen::Dynamic, 3>>(M).singularValues();
  const double tol = double(std::max<std::size_t>(J, 3)) * double(std::numeric_limits<T>::epsilon()) * sv[0];
  if (!(sv[2] > tol))
    throw std::invalid_argument("Deformer: the affine transform needs handles spanning 3D, but the handle points are " +
                                std::string(sv[1] > tol ? "coplanar" : "collinear") + " (singular values " +
                                num(sv[0]) + ", " + num(sv[1]) + ", " + num(sv[2]) + ")");
}

/// Everything the precomputation needs besides the vertices.
struct RestHandles {
  std::vector<Vec3d> P;  ///< pseudo-handle rest positions, local frame
  std::size_t k = 0, s = 0;
};

template <class T>
RestHandles make_rest_handles(const Handles<T>& h, const Scene& scene) {
  RestHandles r;
  r.k = static_cast<std::size_t>(h.points.rows());
  r.s = static_cast<std::size_t>(h.segment_a.rows());
  r.P.reserve(r.k + 2 * r.s);
  for (Eigen::Index i = 0; i < h.points.rows(); ++i)
    r.P.push_back(scene.local(h.points.row(i).transpose().template cast<double>()));
  for (Eigen::Index i = 0; i < h.segment_a.rows(); ++i) {
    r.P.push_back(scene.local(h.segment_a.row(i).transpose().template cast<double>()));
    r.P.push_back(scene.local(h.segment_b.row(i).transpose().template cast<double>()));
  }
  return r;
}

/// Runs f(b) for every block b: serially for threads == 1, else tbb::parallel_for (in `arena` if given).
template <class F>
void for_blocks(std::size_t blocks, int threads, tbb::task_arena* arena, const F& f) {
  if (blocks == 0) return;
  if (threads == 1 || blocks == 1) {
    for (std::size_t b = 0; b < blocks; ++b) f(b);
    return;
  }
  auto run = [&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t b = r.begin(); b != r.end(); ++b) f(b);
    });
  };
  if (arena)
    arena->execute(run);
  else
    run();
}

/// Sec. 5: the rest-pose precomputation for the vertices of block b (see deformer_data.hpp for what is
/// stored). Everything in double in the local frame; results rounded to T once, at the end.
template <class T>
void precompute_block(detail::DeformerData<T>& data, std::size_t b, const Points<T>& vertices, const Scene& scene,
                      const RestHandles& rh, const Options& o) {
  using detail::kLanes;
  const std::size_t J = rh.P.size(), k = rh.k, s = rh.s;
  const double u = o.weight_exponent;
  // A vertex this close to a handle maps exactly to its target (no 0 * inf, no overflow of w = d^-u).
  const double snap = 64 * double(std::numeric_limits<T>::epsilon()) * scene.size_local;
  const bool affine = data.transform == Transform::affine;
  const bool exact = o.segment_weight == SegmentWeight::exact_integral;
  std::vector<double> dist(k), omega(J);
  std::vector<detail::SegmentGeometry> geo(s);
  std::vector<detail::SegmentMoments> mom(s);
  std::vector<Vec3d> A(J);
  const std::size_t first = b * kLanes, count = std::min(kLanes, data.n - first), np = data.padded();
  for (std::size_t lane = 0; lane < count; ++lane) {
    const std::size_t i = first + lane;
    const Vec3d v = scene.local(vertices.row(static_cast<Eigen::Index>(i)).transpose().template cast<double>());
    // Distances to every handle; the nearest one.
    double d_min = std::numeric_limits<double>::infinity();
    std::size_t nearest = 0;  // point index, or k + segment index
    for (std::size_t p = 0; p < k; ++p) {
      dist[p] = (rh.P[p] - v).norm();
      if (dist[p] < d_min) d_min = dist[p], nearest = p;
    }
    for (std::size_t q = 0; q < s; ++q) {
      geo[q] = detail::segment_geometry(v, rh.P[k + 2 * q], rh.P[k + 2 * q + 1]);
      if (geo[q].d < d_min) d_min = geo[q].d, nearest = k + q;
    }
    std::fill(omega.begin(), omega.end(), 0.0);
    std::fill(A.begin(), A.end(), Vec3d::Zero());
    Vec3d p_star, vhat = Vec3d::Zero();
    double D = 0;
    Eigen::Matrix3d G_vertex = Eigen::Matrix3d::Zero();  // G = sum_j A_j phat_j^T, symmetric (affine; D = trace)
    // At a handle (closer than `snap`) the vertex takes the map's limit there, so that the map is continuous:
    //   point handle, or segment with exact_integral weights: the weight concentrates at the closest point,
    //     and the limit is the interpolation f(p_i) = q_i (Sec. 3), (1 - t) c + t d on a segment;
    //   segment with paper_constant weights: the segment's weight is constant along it (Sec. 6.2), so the
    //     limit is the fit to that segment alone (every other weight vanishes relative to it): p* and q* its
    //     midpoints, H = (d - c)(b - a)^T / 12. Rigid maps a stretched segment rigidly, not onto c..d, so
    //     interpolating there would be a jump; similarity and affine reproduce (1 - t) c + t d.
    const bool snapped = d_min <= snap;
    const bool interpolate = snapped && (nearest < k || exact);
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
      for (std::size_t p = 0; p < k; ++p) {
        omega[p] = snapped ? 0.0 : detail::relative_weight(d_min / dist[p], u);
        S += omega[p];
      }
      for (std::size_t q = 0; q < s; ++q) {
        if (snapped)
          mom[q] = q + k == nearest ? detail::segment_moments_of_constant(1.0, geo[q].tc) : detail::SegmentMoments{};
        else
          mom[q] = exact ? detail::segment_moments_exact(geo[q], d_min, u)
                         : detail::segment_moments_constant(geo[q], d_min, u);
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
      // A_j (deformer_data.hpp): sum_j q_j A_j^T = sum_i w_i qhat_i phat_i^T / S, with the segments' W_i.
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
        const detail::SegmentMoments& m = mom[q];
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
    if (affine) {
      // Normal equations: L G = H with G = sum_j A_j phat_j^T (symmetric positive definite when the handles
      // span 3D), so v' = q* + H G^-1 vhat = sum_j (omega_j + A_j . G^-1 vhat) q_j. G is solved through its
      // eigen-decomposition; eigenvalues below 64 eps lambda_max (reachable only when weights leave the
      // double range, u log10(d_min / d) < -300) are dropped (minimum-norm solution) instead of dividing by
      // rounding noise.
      Vec3d x = Vec3d::Zero();
      if (vhat != Vec3d::Zero()) {
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(G_vertex);
        const Vec3d lambda = es.eigenvalues();
        const double cut = 64 * std::numeric_limits<double>::epsilon() * lambda[2];
        for (int c = 0; c < 3; ++c)
          if (lambda[c] > cut) x += (es.eigenvectors().col(c).dot(vhat) / lambda[c]) * es.eigenvectors().col(c);
      }
      // alpha_j = omega_j + beta_j with beta_j = A_j . x; as for A, project beta onto sum_j beta_j = 0 so
      // that the rounding of x (relative eps kappa(G)) cannot move q* = sum_j omega_j q_j.
      double sum_beta = 0;
      for (std::size_t j = 0; j < J; ++j) sum_beta += A[j].dot(x);
      for (std::size_t j = 0; j < J; ++j)
        data.coefficients(b, j)[lane] = T(omega[j] + (A[j].dot(x) - omega[j] * sum_beta));
    } else {
      for (std::size_t j = 0; j < J; ++j) {
        T* co = data.coefficients(b, j) + lane;
        co[0] = T(omega[j]);
        for (int c = 0; c < 3; ++c) co[(c + 1) * kLanes] = T(A[j][c]);
      }
      for (int c = 0; c < 3; ++c) {
        data.p_star[c * np + i] = T(scene.centre[c] + std::ldexp(p_star[c], scene.e));
        data.vhat[c * np + i] = T(std::ldexp(vhat[c], scene.e));
      }
      // Units (deformer_data.hpp): A in local units times 2^s, D as (physical D) / 2^e times 2^s.
      if (data.transform == Transform::similarity) data.D[i] = T(std::ldexp(D, scene.e));
    }
  }
}

/// WeightStorage (deformer.hpp): on the fly is implemented for rigid and similarity with point handles
/// only. `automatic` picks it (and refuses settings without it) when the precomputed table (16 bytes per
/// vertex and handle in float, 32 in double; affine 4 and 8) would exceed precompute_budget_bytes (default
/// 32 MiB, about a last-level cache), so that it never allocates more than the budget: beyond the cache
/// the table streams from memory every frame, and recomputing the weights (two passes of a few tens of flops
/// per handle) costs about as much as reading 16-32 bytes per handle (bench/bench_scaling.cpp measures both).
template <class T>
bool use_on_the_fly(const Options& o, const RestHandles& rh, std::size_t padded) {
  const bool supported = o.transform != Transform::affine && rh.s == 0;
  if (o.weight_storage == WeightStorage::on_the_fly && !supported)
    throw std::invalid_argument(std::string("Deformer: WeightStorage::on_the_fly supports rigid and similarity "
                                            "transforms with point handles only (got ") +
                                (o.transform == Transform::affine ? "the affine transform" : "segment handles") +
                                "); use precomputed or automatic");
  if (o.weight_storage != WeightStorage::automatic) return o.weight_storage == WeightStorage::on_the_fly;
  const double components = o.transform == Transform::affine ? 1 : 4;
  const double table = double(padded) * double(rh.P.size()) * components * sizeof(T);
  if (!(table > double(o.precompute_budget_bytes))) return false;
  if (supported) return true;
  char msg[512];
  std::snprintf(msg, sizeof msg,
                "Deformer: the weight table would take %.1f MiB (%zu vertices x %zu pseudo-handles), over "
                "precompute_budget_bytes = %.1f MiB, and on-the-fly weights support only rigid and similarity "
                "transforms with point handles (got %s); raise Options::precompute_budget_bytes (CLI: "
                "--weight-budget MiB) or set WeightStorage::precomputed to allow it",
                table / 1048576.0, padded, rh.P.size(), double(o.precompute_budget_bytes) / 1048576.0,
                o.transform == Transform::affine ? "the affine transform" : "segment handles");
  throw std::invalid_argument(msg);
}

/// The on-the-fly session data: the rest vertices and handles in the local frame, each vertex's squared
/// distance to its nearest handle (weights are relative to it), and the handle a vertex sits on, if any.
template <class T>
void precompute_on_the_fly(detail::DeformerData<T>& data, const Points<T>& vertices, const Scene& scene,
                           const RestHandles& rh, tbb::task_arena* arena, const Options& o) {
  const std::size_t np = data.padded(), k = rh.k;
  data.on_the_fly = true;
  data.world_scale = std::ldexp(1.0, scene.e);
  data.half_u = T(o.weight_exponent / 2);
  data.v_local.assign(3 * np, T(0));
  data.dref2.assign(np, T(1));
  data.snap.assign(np, T(-1));
  data.p_local.assign(3 * k, T(0));
  for (std::size_t j = 0; j < k; ++j)
    for (int c = 0; c < 3; ++c) data.p_local[std::size_t(c) * k + j] = T(rh.P[j][c]);
  const double snap = 64 * double(std::numeric_limits<T>::epsilon()) * scene.size_local;
  for_blocks(data.blocks, o.threads, arena, [&](std::size_t b) {
    for (std::size_t i = b * detail::kLanes; i < std::min(data.n, (b + 1) * detail::kLanes); ++i) {
      const Vec3d v = scene.local(vertices.row(static_cast<Eigen::Index>(i)).transpose().template cast<double>());
      double d2 = std::numeric_limits<double>::infinity();
      std::size_t nearest = 0;
      for (std::size_t j = 0; j < k; ++j) {
        // The same rounded coordinates the per-frame pass uses, so that the nearest handle gets w = 1.
        const Vec3d p(double(data.p_local[j]), double(data.p_local[k + j]), double(data.p_local[2 * k + j]));
        const double dj = (p - Vec3d(double(T(v[0])), double(T(v[1])), double(T(v[2])))).squaredNorm();
        if (dj < d2) d2 = dj, nearest = j;
      }
      for (int c = 0; c < 3; ++c) data.v_local[std::size_t(c) * np + i] = T(v[c]);
      data.dref2[i] = T(d2);
      if (!(std::sqrt(d2) > snap) || !(T(d2) > T(0))) data.snap[i] = T(nearest);
    }
  });
}

/// Validates the rest pose and builds the session data. Throws std::invalid_argument (nothing is changed).
template <class T>
detail::DeformerData<T> precompute(const Points<T>& vertices, const Handles<T>& handles, const Options& o,
                                   tbb::task_arena* arena) {
  check_options(o);
  check_points(vertices, "rest vertices", "", std::numeric_limits<T>::max());
  check_handles(handles, "rest handles", std::numeric_limits<T>::max());
  if (handles.points.rows() + handles.segment_a.rows() == 0)
    throw std::invalid_argument("Deformer: no handles (need at least one point or segment handle)");
  const Scene scene = make_scene(vertices, handles);
  const RestHandles rh = make_rest_handles(handles, scene);
  // A segment shorter than the snapping distance is a point: reject it rather than divide by its length.
  const double snap = 64 * double(std::numeric_limits<T>::epsilon()) * scene.size_local;
  for (std::size_t q = 0; q < rh.s; ++q)
    if (!((rh.P[rh.k + 2 * q + 1] - rh.P[rh.k + 2 * q]).norm() > snap))
      throw std::invalid_argument("Deformer: segment handle " + std::to_string(q) +
                                  " has zero length (|b - a| <= 64 eps times the scene size); use a point handle");
  if (o.transform == Transform::affine) check_affine_rank<T>(rh.P);

  detail::DeformerData<T> data;
  data.transform = o.transform;
  data.n = static_cast<std::size_t>(vertices.rows());
  data.blocks = (data.n + detail::kLanes - 1) / detail::kLanes;
  data.points = rh.k;
  data.segments = rh.s;
  data.scale = std::ldexp(1.0, scene.e);
  const std::size_t J = rh.P.size(), np = data.padded();
  if (use_on_the_fly<T>(o, rh, np)) {
    precompute_on_the_fly(data, vertices, scene, rh, arena, o);
    return data;
  }
  data.table.assign(np * J * data.components(), T(0));
  if (o.transform != Transform::affine) {
    data.p_star.assign(3 * np, T(0));
    data.vhat.assign(3 * np, T(0));
  }
  if (o.transform == Transform::similarity) data.D.assign(np, T(0));
  for_blocks(data.blocks, o.threads, arena,
             [&](std::size_t b) { precompute_block(data, b, vertices, scene, rh, o); });
  return data;
}

/// Pairs (i, j), i < j, of point handles at the same rest position. A vertex there is snapped to one of them,
/// while the map's limit at that position is the mean of their targets: such pairs must keep equal targets.
template <class T>
std::vector<std::pair<Eigen::Index, Eigen::Index>> coincident_points(const Points<T>& p) {
  std::vector<Eigen::Index> order(static_cast<std::size_t>(p.rows()));
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<Eigen::Index>(i);
  const auto key = [&p](Eigen::Index i) { return std::array<T, 3>{p(i, 0), p(i, 1), p(i, 2)}; };
  std::stable_sort(order.begin(), order.end(), [&](Eigen::Index a, Eigen::Index b) { return key(a) < key(b); });
  std::vector<std::pair<Eigen::Index, Eigen::Index>> pairs;
  for (std::size_t a = 0; a < order.size();) {
    std::size_t b = a + 1;
    while (b < order.size() && key(order[b]) == key(order[a])) ++b;
    for (std::size_t c = a + 1; c < b; ++c)
      pairs.emplace_back(std::min(order[a], order[c]), std::max(order[a], order[c]));
    a = b;
  }
  return pairs;
}

/// Coincident point handles must be moved together (see coincident_points). Allocates only on error.
template <class T>
void check_coincident(const Handles<T>& moved, const std::vector<std::pair<Eigen::Index, Eigen::Index>>& pairs) {
  for (const auto& [i, j] : pairs)
    if (moved.points.row(i) != moved.points.row(j))
      throw std::invalid_argument("Deformer: point handles " + std::to_string(i) + " and " + std::to_string(j) +
                                  " share their rest position but have different targets (" +
                                  num(double(moved.points(i, 0))) + ", " + num(double(moved.points(i, 1))) + ", " +
                                  num(double(moved.points(i, 2))) + ") and (" + num(double(moved.points(j, 0))) +
                                  ", " + num(double(moved.points(j, 1))) + ", " + num(double(moved.points(j, 2))) +
                                  "); a vertex there cannot follow both");
}

std::unique_ptr<tbb::task_arena> make_arena(int threads) {
  // threads == 0: TBB's default arena (all cores); 1: serial, no TBB at all; more: an arena of that many,
  // capped at the hardware's (TBB would ignore the excess anyway, with a warning on stderr).
  const int cap = tbb::info::default_concurrency();
  if (threads > 1 && cap > 1) return std::make_unique<tbb::task_arena>(std::min(threads, cap));
  return nullptr;
}

}  // namespace

template <class T>
struct Deformer<T>::Impl {
  Options options;
  Handles<T> rest, targets;
  std::vector<std::pair<Eigen::Index, Eigen::Index>> coincident;  ///< point handles at one rest position
  detail::DeformerData<T> data;
  std::unique_ptr<tbb::task_arena> arena;

  /// The SIMD kernels for this session's settings, or nullptr for the scalar path (Backend::scalar,
  /// Isa::scalar, or a rotation method without a SIMD kernel: kanatani, horn_matrix, svd).
  kernels::DeformBlocksFn<T> simd_kernel() const {
    if (options.backend != Backend::simd) return nullptr;
    const bool in_lanes = data.transform == Transform::affine || options.method == RotationMethod::axis_angle ||
                          options.method == RotationMethod::horn_quaternion;
    const kernels::KernelTable* k = detail::active_kernels();
    if (!k || !in_lanes) return nullptr;
    if constexpr (std::is_same_v<T, float>) return k->deform_f;
    else return k->deform_d;
  }

  /// Per frame with the SIMD kernels: vertex v, coordinate c goes to out[c * cstride + v * vstride].
  /// Returns false (nothing done) where the scalar path must run.
  bool run_simd(const Handles<T>& moved, T* out, std::size_t vstride, std::size_t cstride) const {
    const kernels::DeformBlocksFn<T> kernel = simd_kernel();
    if (!kernel) return false;
    kernels::DeformFrame<T> fr{};
    fr.table = data.table.empty() ? nullptr : data.table.data();
    fr.on_the_fly = data.on_the_fly;
    if (data.on_the_fly) {
      fr.v_local = data.v_local.data();
      fr.dref2 = data.dref2.data();
      fr.snap = data.snap.data();
      fr.p_local = data.p_local.data();
      fr.world_scale = T(data.world_scale);
      fr.half_u = data.half_u;
    }
    fr.vhat = data.vhat.empty() ? nullptr : data.vhat.data();
    fr.D = data.D.empty() ? nullptr : data.D.data();
    fr.padded = data.padded();
    fr.points = moved.points.data();
    fr.k = static_cast<std::size_t>(moved.points.rows());
    fr.seg_a = moved.segment_a.data();
    fr.seg_b = moved.segment_b.data();
    fr.s = static_cast<std::size_t>(moved.segment_a.rows());
    const Vector3<T> c = detail::target_centre(moved);
    for (int i = 0; i < 3; ++i) fr.centre[i] = c[i];
    fr.transform = data.transform == Transform::rigid ? 0 : (data.transform == Transform::similarity ? 1 : 2);
    fr.method = options.method == RotationMethod::horn_quaternion ? 1 : 0;
    fr.out = out;
    fr.out_vertex_stride = vstride;
    fr.out_coord_stride = cstride;
    fr.n = data.n;
    for_blocks(data.blocks, options.threads, arena.get(), [&](std::size_t b) { kernel(fr, b, b + 1, nullptr); });
    return true;
  }

  /// Per frame: validated `moved`, write(v, x, y, z) for every vertex. Nothing is allocated here; scratch
  /// lives on the stack of each block.
  template <class Write>
  void run(const Handles<T>& moved, const Write& write) const {
    if (data.on_the_fly) {
      const Vector3<T> c = detail::target_centre(moved);
      for_blocks(data.blocks, options.threads, arena.get(), [&](std::size_t b) {
        detail::deform_block_on_the_fly(data, b, moved, c, options.method, write);
      });
    } else if (data.transform == Transform::affine) {
      for_blocks(data.blocks, options.threads, arena.get(),
                 [&](std::size_t b) { detail::deform_block_affine(data, b, moved, write); });
    } else {
      const Vector3<T> c = detail::target_centre(moved);
      for_blocks(data.blocks, options.threads, arena.get(), [&](std::size_t b) {
        detail::deform_block_rotation(data, b, moved, c, options.method, write);
      });
    }
  }
};

template <class T>
Deformer<T>::Deformer(const Points<T>& rest_vertices, const Handles<T>& rest_handles, const Options& options)
    : impl_(std::make_unique<Impl>()) {
  check_options(options);
  impl_->options = options;
  impl_->arena = make_arena(options.threads);
  impl_->data = precompute(rest_vertices, rest_handles, options, impl_->arena.get());
  impl_->rest = rest_handles;
  impl_->targets = rest_handles;
  impl_->coincident = coincident_points(rest_handles.points);
}

template <class T>
typename Deformer<T>::Impl& Deformer<T>::impl() {
  if (!impl_) throw std::logic_error("Deformer: this session was moved from; assign a new one before use");
  return *impl_;
}

template <class T>
const typename Deformer<T>::Impl& Deformer<T>::impl() const {
  if (!impl_) throw std::logic_error("Deformer: this session was moved from; assign a new one before use");
  return *impl_;
}

template <class T>
Deformer<T>::~Deformer() = default;
template <class T>
Deformer<T>::Deformer(Deformer&&) noexcept = default;
template <class T>
Deformer<T>& Deformer<T>::operator=(Deformer&&) noexcept = default;

template <class T>
void Deformer<T>::deform(const Handles<T>& moved_handles, Points<T>& out) const {
  check_moved(moved_handles, impl().rest);
  check_coincident(moved_handles, impl().coincident);
  const auto n = static_cast<Eigen::Index>(impl().data.n);
  if (out.rows() != n) out.resize(n, 3);
  if (impl().run_simd(moved_handles, out.data(), 1, static_cast<std::size_t>(n))) return;
  impl().run(moved_handles, [&out](std::size_t v, T x, T y, T z) {
    const auto r = static_cast<Eigen::Index>(v);
    out(r, 0) = x;
    out(r, 1) = y;
    out(r, 2) = z;
  });
}

template <class T>
void Deformer<T>::deform(const Handles<T>& moved_handles, InterleavedView<T> out) const {
  check_moved(moved_handles, impl().rest);
  check_coincident(moved_handles, impl().coincident);
  if (out.rows() != static_cast<Eigen::Index>(impl().data.n))
    throw std::invalid_argument("Deformer: the interleaved output has " + std::to_string(out.rows()) +
                                " rows but the model has " + std::to_string(impl().data.n) + " vertices");
  if (impl().run_simd(moved_handles, out.data(), 3, 1)) return;
  impl().run(moved_handles, [&out](std::size_t v, T x, T y, T z) {
    const auto r = static_cast<Eigen::Index>(v);
    out(r, 0) = x;
    out(r, 1) = y;
    out(r, 2) = z;
  });
}

template <class T>
void Deformer<T>::set_point_target(Eigen::Index i, const Vector3<T>& target) {
  if (i < 0 || i >= impl().targets.points.rows())
    throw std::out_of_range("Deformer::set_point_target: index " + std::to_string(i) + " but " +
                            std::to_string(impl().targets.points.rows()) + " point handles");
  if (!target.allFinite() || target.cwiseAbs().maxCoeff() > coordinate_limit<T>())
    throw std::invalid_argument("Deformer::set_point_target: non-finite or too large coordinate");
  impl().targets.points.row(i) = target.transpose();
}

template <class T>
void Deformer<T>::set_segment_target(Eigen::Index i, const Vector3<T>& a, const Vector3<T>& b) {
  if (i < 0 || i >= impl().targets.segment_a.rows())
    throw std::out_of_range("Deformer::set_segment_target: index " + std::to_string(i) + " but " +
                            std::to_string(impl().targets.segment_a.rows()) + " segment handles");
  if (!a.allFinite() || !b.allFinite() || a.cwiseAbs().maxCoeff() > coordinate_limit<T>() ||
      b.cwiseAbs().maxCoeff() > coordinate_limit<T>())
    throw std::invalid_argument("Deformer::set_segment_target: non-finite or too large coordinate");
  impl().targets.segment_a.row(i) = a.transpose();
  impl().targets.segment_b.row(i) = b.transpose();
}

template <class T>
const Handles<T>& Deformer<T>::targets() const {
  return impl().targets;
}

template <class T>
void Deformer<T>::deform(Points<T>& out) const {
  deform(impl().targets, out);
}

template <class T>
void Deformer<T>::deform(InterleavedView<T> out) const {
  deform(impl().targets, out);
}

template <class T>
void Deformer<T>::reset_rest_pose(const Points<T>& rest_vertices, const Handles<T>& rest_handles) {
  // Strong guarantee: build everything first, then commit with non-throwing moves.
  detail::DeformerData<T> data = precompute(rest_vertices, rest_handles, impl().options, impl().arena.get());
  Handles<T> rest = rest_handles, targets = rest_handles;
  auto coincident = coincident_points(rest_handles.points);
  impl().data = std::move(data);
  impl().rest = std::move(rest);
  impl().targets = std::move(targets);
  impl().coincident = std::move(coincident);
}

template <class T>
Eigen::Index Deformer<T>::vertex_count() const {
  return static_cast<Eigen::Index>(impl().data.n);
}

template <class T>
const Options& Deformer<T>::options() const {
  return impl().options;
}

template <class T>
std::size_t Deformer<T>::memory_bytes() const {
  // Everything the session holds on the heap: the table and per-vertex arrays, and the rest and target
  // handles (3 coordinates each).
  const auto handle_values = [](const Handles<T>& h) {
    return static_cast<std::size_t>(h.points.size() + h.segment_a.size() + h.segment_b.size());
  };
  return impl().data.bytes() + (handle_values(impl().rest) + handle_values(impl().targets)) * sizeof(T);
}

template <class T>
bool Deformer<T>::uses_precomputed_weights() const {
  return !impl().data.on_the_fly;
}

template class Deformer<float>;
template class Deformer<double>;

}  // namespace mlsdeform
