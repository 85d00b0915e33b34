// Vertices on and beside handles, apart from the kernels: near_handles.hpp derives what is computed.
#include "core/src/deformer/near_handles.hpp"

#include "core/src/deformer/output_check.hpp"
#include "core/src/deformer/weights.hpp"
#include "core/src/parallel.hpp"
#include "kernels/deformer/stages.hpp"

#include <mlsdeform/rotation.hpp>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <atomic>
#include <cmath>

namespace mlsdeform::detail {

namespace {

using Vec3d = Eigen::Vector3d;
using Mat3d = Eigen::Matrix3d;

/// tr(Z^T G Z) for Z an orthonormal basis of e's orthogonal complement: the spread of G across e.
double across(const Mat3d& G, const Vec3d& e) {
  const Vec3d u = e.normalized();
  return G.trace() - u.dot(G * u);
}

/// The symmetric pseudo-inverse of G, eigenvalues below 64 eps lambda_max dropped (as precompute_table.cpp's
/// affine solve: only rounding noise lies below).
Mat3d pseudo_inverse(const Mat3d& G) {
  const Eigen::SelfAdjointEigenSolver<Mat3d> es(0.5 * (G + G.transpose()));
  const Vec3d lambda = es.eigenvalues();
  const double cut = 64 * std::numeric_limits<double>::epsilon() * lambda[2];
  Mat3d P = Mat3d::Zero();
  for (int c = 0; c < 3; ++c)
    if (lambda[c] > cut && lambda[c] > 0)
      P += es.eigenvectors().col(c) * es.eigenvectors().col(c).transpose() / lambda[c];
  return P;
}

/// The minimal rotation taking unit a to unit b (a quaternion (1 + a.b, a x b), stable for a.b >= 0); for a.b < 0,
/// that from -a to b after the half turn about an axis orthogonal to a (which takes a to -a).
Mat3d rotation_taking(const Vec3d& a, const Vec3d& b) {
  if (a.dot(b) < 0) {
    const Vec3d n = a.unitOrthogonal();
    return rotation_taking(-a, b) * (2 * n * n.transpose() - Mat3d::Identity());
  }
  const Vec3d c = a.cross(b);
  Eigen::Quaterniond q(1 + a.dot(b), c.x(), c.y(), c.z());
  q.normalize();
  return q.toRotationMatrix();
}

/// The lexicographic limit (near_handles.hpp): R e^ = f^, then the twist about f^ that maximises tr(R^T H').
Mat3d dominated_rotation(const Vec3d& e, const Vec3d& f, const Mat3d& Hp, RotationMethod method) {
  if (!(f.norm() > 0)) return fit_rotation<double>(Hp, method);  // the segment collapsed: its term is gone
  const Vec3d a = f.normalized();
  const Mat3d R0 = rotation_taking(e.normalized(), a);
  const Mat3d N = Hp * R0.transpose();
  const double c = N.trace() - a.dot(N * a);
  const double s = a.dot(Vec3d(N(2, 1) - N(1, 2), N(0, 2) - N(2, 0), N(1, 0) - N(0, 1)));
  const double theta = c == 0 && s == 0 ? 0.0 : std::atan2(s, c);
  return Eigen::AngleAxisd(theta, a).toRotationMatrix() * R0;
}

/// The dominated affine limit: L e = f, the others' least squares on e's orthogonal complement.
Mat3d dominated_linear(const Vec3d& e, const Vec3d& f, const Mat3d& Hp, const Mat3d& G) {
  const Vec3d u = e.normalized(), z1 = u.unitOrthogonal(), z2 = u.cross(z1);
  Eigen::Matrix<double, 3, 2> Z;
  Z.col(0) = z1, Z.col(1) = z2;
  const Eigen::Matrix2d G22 = Z.transpose() * G * Z;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(0.5 * (G22 + G22.transpose()));
  const double cut = 64 * std::numeric_limits<double>::epsilon() * es.eigenvalues()[1];
  Eigen::Matrix2d inv = Eigen::Matrix2d::Zero();
  for (int c = 0; c < 2; ++c)
    if (es.eigenvalues()[c] > cut && es.eigenvalues()[c] > 0)
      inv += es.eigenvectors().col(c) * es.eigenvectors().col(c).transpose() / es.eigenvalues()[c];
  const Mat3d P = Z * inv * Z.transpose();
  return (f / e.norm()) * (u.transpose() - u.transpose() * G * P) + Hp * P;
}

}  // namespace

bool far_fit(const RestHandles& rh, const Options& o, const Vec3d& v, NearRecord& r, NearColumns& cols) {
  const std::size_t k = rh.k;
  if (k < 2 || rh.s != 0) return false;
  double d_min = std::numeric_limits<double>::infinity();
  for (std::size_t j = 0; j < k; ++j) d_min = std::min(d_min, (rh.P[j] - v).norm());
  if (!(d_min > 0)) return false;
  r = NearRecord{};
  cols.c.assign(k, 0.0);
  cols.A.assign(k, Vec3d::Zero());
  double S = 0;
  for (std::size_t j = 0; j < k; ++j) S += cols.c[j] = relative_weight(d_min / (rh.P[j] - v).norm(), o.weight_exponent);
  Vec3d p_star = Vec3d::Zero();
  for (std::size_t j = 0; j < k; ++j) p_star += (cols.c[j] /= S) * rh.P[j];
  for (std::size_t j = 0; j < k; ++j) {
    cols.A[j] = cols.c[j] * (rh.P[j] - p_star);
    r.G += cols.A[j] * (rh.P[j] - p_star).transpose();
  }
  r.G = 0.5 * (r.G + r.G.transpose());
  cols.star = cols.c;
  r.vhat = v - p_star;
  r.position = true;
  return true;
}

bool handle_limit(const RestHandles& rh, const Options& o, std::size_t nearest, double t, double d_ref, NearRecord& r,
                  NearColumns& cols) {
  if (!(d_ref > 0) || !std::isfinite(d_ref)) return false;
  const std::size_t k = rh.k, s = rh.s, J = k + 2 * s;
  const double u = o.weight_exponent;
  const bool exact = o.segment_weight == SegmentWeight::exact_integral;
  cols.c.assign(J, 0.0);
  cols.A.assign(J, Vec3d::Zero());
  r = NearRecord{};
  Vec3d p_ref;
  std::size_t own = s;  // none
  if (nearest < k) {
    p_ref = rh.P[nearest];
    cols.c[nearest] = 1;
  } else {
    own = nearest - k;
    const Vec3d& a = rh.P[k + 2 * own];
    r.e = rh.P[k + 2 * own + 1] - a;
    p_ref = a + t * r.e;
    cols.c[k + 2 * own] = 1 - t;
    cols.c[k + 2 * own + 1] = t;
    r.own = std::ptrdiff_t(k + 2 * own);
  }
  // The other handles' weights relative to d_ref at p_ref, and their A_j and share of G (precompute_table.cpp's
  // forms with p* = p_ref and S = 1: H matters only up to a positive factor, and D and G carry the same one).
  for (std::size_t p = 0; p < k; ++p) {
    if (p == nearest) continue;
    const Vec3d d = rh.P[p] - p_ref;
    const double dist = d.norm();
    if (!(dist > 0)) return false;
    cols.A[p] = relative_weight(d_ref / dist, u) * d;
    r.G += cols.A[p] * d.transpose();
  }
  for (std::size_t q = 0; q < s; ++q) {
    if (q == own) continue;
    const Vec3d a = rh.P[k + 2 * q], e = rh.P[k + 2 * q + 1] - a;
    const SegmentGeometry geo = segment_geometry(p_ref, a, rh.P[k + 2 * q + 1]);
    if (!(geo.d > 0)) return false;
    const SegmentMoments mo = exact ? segment_moments_exact(geo, d_ref, u) : segment_moments_constant(geo, d_ref, u);
    const double tc = geo.tc;
    const Vec3d g = (a + tc * e) - p_ref;
    cols.A[k + 2 * q] = g * (mo.I0 + mo.I1) + e * ((1 - tc) * mo.J1 - mo.J2);
    cols.A[k + 2 * q + 1] = g * (mo.I1 + mo.I2) + e * (tc * mo.J1 + mo.J2);
    const double J0 = mo.I0 + 2 * mo.I1 + mo.I2;
    r.G += J0 * g * g.transpose() + mo.J1 * (g * e.transpose() + e * g.transpose()) + mo.J2 * e * e.transpose();
  }
  r.G = 0.5 * (r.G + r.G.transpose());
  cols.star = cols.c;  // the position is the kernels' (interpolated): not used
  if (own < s) {
    // The segment's own second moment about t (near_handles.hpp): finite for exact_integral with u < 3.
    const double L = r.e.norm();
    r.m = exact && u < 3 ? relative_weight(d_ref / L, u) * (std::pow(t, 3 - u) + std::pow(1 - t, 3 - u)) / (3 - u)
                         : std::numeric_limits<double>::infinity();
    r.dominated = !std::isfinite(r.m) || !(across(r.G, r.e) >= kDominatedRatio * r.m * L * L);
    if (r.dominated) r.m = 0;
  }
  return true;
}

void NearHandlesBuilder::add(NearRecord r, const NearColumns& cols) {
  const std::lock_guard<std::mutex> lock(mutex_);
  pending_.emplace_back(std::move(r), cols);
}

NearHandles NearHandlesBuilder::finish(std::size_t J) {
  std::sort(pending_.begin(), pending_.end(),
            [](const auto& x, const auto& y) { return x.first.vertex < y.first.vertex; });
  NearHandles nh;
  nh.J = J;
  nh.records.reserve(pending_.size());
  nh.coefficients.reserve(pending_.size() * kWidth * J);
  for (auto& [r, cols] : pending_) {
    r.offset = nh.coefficients.size();
    for (std::size_t j = 0; j < J; ++j) {
      nh.coefficients.push_back(cols.c[j]);
      nh.coefficients.push_back(cols.star[j]);
      for (int c = 0; c < 3; ++c) nh.coefficients.push_back(cols.A[j][c]);
    }
    if (r.position) nh.positions.push_back(nh.records.size());
    nh.records.push_back(r);
  }
  pending_.clear();
  return nh;
}

namespace {

/// Pseudo-handle j's target in the local frame (fr's moved handles times local_scale, exact), in double.
template <class T>
Vec3d target_of(const kernels::DeformFrame<T>& fr, std::size_t j) {
  const double ls = double(fr.local_scale);
  if (j < fr.k) return ls * Vec3d(double(fr.points[j]), double(fr.points[fr.k + j]), double(fr.points[2 * fr.k + j]));
  const std::size_t i = (j - fr.k) / 2;
  const T* x = (j - fr.k) % 2 == 0 ? fr.seg_a : fr.seg_b;
  return ls * Vec3d(double(x[i]), double(x[fr.s + i]), double(x[2 * fr.s + i]));
}

/// The targets as apply_record reads them, centred on the frame's centre c (DeformFrame::centre, the kernels'):
/// from `cache` (3 J values, filled once per range of records) where the frame has at most kCachedTargets
/// pseudo-handles, else computed again from fr each time.
inline constexpr std::size_t kCachedTargets = kernels::kCachedTargets;

template <class T>
struct Targets {
  const kernels::DeformFrame<T>& fr;
  const double* cache;
  void centred(std::size_t j, double (&q)[3]) const {
    if (cache) {
      for (int a = 0; a < 3; ++a) q[a] = cache[3 * j + std::size_t(a)];
      return;
    }
    const Vec3d x = target_of(fr, j);
    for (int a = 0; a < 3; ++a) q[a] = x[a] - double(fr.centre[a]);
  }
  Vec3d operator()(std::size_t j) const {
    double q[3];
    centred(j, q);
    return Vec3d(q[0], q[1], q[2]);
  }
};

/// One record: its frame into the wanted outputs, and its position where it has one. False where a value is not
/// finite in T.
template <class T>
bool apply_record(const NearHandles& nh, const NearRecord& r, const kernels::DeformFrame<T>& fr, RotationMethod method,
                  bool frames, const Targets<T>& target) {
  constexpr std::size_t W = NearHandlesBuilder::kWidth;
  const double* co = nh.coefficients.data() + r.offset;
  // One pass over the pseudo-handles, the targets centred on c: q_ref - c = sum_j c_j (q_j - c) (sum_j c_j = 1),
  // q* = sum_j c*_j (q_j - c) + (sum_j c*_j) c (RBF centroid weights need not sum to 1), and
  // H' = sum_j (q_j - q_ref) A'_j^T = sum_j (q_j - c) A'_j^T - (q_ref - c)(sum_j A'_j)^T.
  double ref[3] = {0, 0, 0}, star[3] = {0, 0, 0}, star_sum = 0, h[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0}, sa[3] = {0, 0, 0};
  for (std::size_t j = 0; j < nh.J; ++j) {
    const double* cj = co + W * j;
    double q[3];
    target.centred(j, q);
    star_sum += cj[1];
    for (int a = 0; a < 3; ++a) {
      ref[a] += cj[0] * q[a];
      star[a] += cj[1] * q[a];
      sa[a] += cj[2 + a];
      for (int b = 0; b < 3; ++b) h[3 * a + b] += q[a] * cj[2 + b];
    }
  }
  Mat3d Hp;
  Vec3d q_star;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) Hp(a, b) = h[3 * a + b] - ref[a] * sa[b];
    q_star[a] = star[a] + star_sum * double(fr.centre[a]);
  }
  const Vec3d f = r.own >= 0 ? Vec3d(target(std::size_t(r.own) + 1) - target(std::size_t(r.own))) : Vec3d::Zero();
  Mat3d R = Mat3d::Identity(), L;
  double mu = 1;
  if (fr.transform == Transform::affine) {
    L = r.dominated ? dominated_linear(r.e, f, Hp, r.G)
                    : Mat3d((Hp + r.m * f * r.e.transpose()) * pseudo_inverse(r.G + r.m * r.e * r.e.transpose()));
  } else {
    if (r.dominated) {
      R = dominated_rotation(r.e, f, Hp, method);
      if (fr.transform == Transform::similarity) mu = f.norm() / r.e.norm();
    } else {
      const Mat3d H = Hp + r.m * f * r.e.transpose();
      R = fit_rotation<double>(H, method);
      const double D = r.G.trace() + r.m * r.e.squaredNorm();
      if (fr.transform == Transform::similarity && D > 0) mu = (R.transpose() * H).trace() / D;
    }
    L = mu * R;
  }
  bool finite = true;
  const auto put = [&](T* dst, std::size_t width, const double* src) {
    for (std::size_t c = 0; c < width; ++c) {
      const T x = T(src[c]);
      finite = finite && std::isfinite(x);
      dst[r.vertex * width + c] = x;
    }
  };
  if (frames) {
    double rm[9], lm[9];
    for (int i = 0; i < 9; ++i) rm[i] = R(i / 3, i % 3), lm[i] = L(i / 3, i % 3);
    if (fr.quaternions) {
      double q[4];
      kernels::rotation_quaternion<double>(rm, q);
      put(fr.quaternions, 4, q);
    }
    if (fr.rotations) put(fr.rotations, 9, rm);
    if (fr.scales) put(fr.scales, 1, &mu);
    if (fr.linear) put(fr.linear, 9, lm);
  }
  if (r.position) {
    const Vec3d v = q_star + L * r.vhat;  // q* + mu R vhat, or affine q* + H G^-1 vhat
    for (int c = 0; c < 3; ++c) {
      // Rounded to T in the local frame, then scaled, as the kernels store (DeformKernel::store): a scene scaled
      // by a power of two gives these bits scaled, rounded once where subnormal (test_scale_invariance).
      const T x = T(v[c]) * fr.world_scale;
      finite = finite && std::isfinite(x);
      fr.out[std::size_t(c) * fr.out_coord_stride + r.vertex * fr.out_vertex_stride] = x;
    }
  }
  return finite;
}

}  // namespace

template <class T>
std::size_t apply_near_handles(const NearHandles& nh, const kernels::DeformFrame<T>& fr, RotationMethod method,
                               int threads, tbb::task_arena* arena) {
  const bool frames = fr.quaternions || fr.rotations || fr.scales || fr.linear;
  const std::size_t count = frames ? nh.records.size() : nh.positions.size();
  std::atomic<std::size_t> first_bad{kAllFinite};
  parallel_ranges(count, threads, arena, [&](std::size_t i0, std::size_t i1) {
    alignas(64) double cache[3 * kCachedTargets];
    const bool cached = nh.J <= kCachedTargets;
    if (cached)
      for (std::size_t j = 0; j < nh.J; ++j) {
        const Vec3d q = target_of(fr, j);
        for (int c = 0; c < 3; ++c) cache[3 * j + std::size_t(c)] = q[c] - double(fr.centre[c]);
      }
    const Targets<T> target{fr, cached ? cache : nullptr};
    for (std::size_t i = i0; i < i1; ++i) {
      const NearRecord& r = nh.records[frames ? i : nh.positions[i]];
      if (apply_record(nh, r, fr, method, frames, target)) continue;
      for (std::size_t seen = first_bad.load(); r.vertex < seen && !first_bad.compare_exchange_weak(seen, r.vertex);) {
      }
    }
  });
  return first_bad.load();
}

template std::size_t apply_near_handles<float>(const NearHandles&, const kernels::DeformFrame<float>&, RotationMethod,
                                               int, tbb::task_arena*);
template std::size_t apply_near_handles<double>(const NearHandles&, const kernels::DeformFrame<double>&, RotationMethod,
                                                int, tbb::task_arena*);

}  // namespace mlsdeform::detail
