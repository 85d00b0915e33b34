// The session's moved handles and the centring point of a frame's targets (targets.hpp).
#include "core/src/deformer/targets.hpp"

#include "core/src/deformer/validation.hpp"
#include "core/src/pow2.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace mlsdeform::detail {

namespace {

/// The image of x under x -> R (x - pivot) + pivot + t, in T and in the order deformer.hpp documents
/// (transform_handles), on the coordinates scaled by 2^-g (exact powers of two), so that no product
/// underflows at any scale of the scene: the image of a scene scaled by 2^k is the image times 2^k, rounded
/// once. In the normal range the scalings are exact, and so is the expression in the caller's units.
template <class T>
Vector3<T> rigid_image(const Vector3<T>& x, const Matrix3<T>& R, const Vector3<T>& t, const Vector3<T>& pivot, int g) {
  const auto down = [g](T v) { return std::ldexp(v, -g); };
  const Vector3<T> d(down(x[0]) - down(pivot[0]), down(x[1]) - down(pivot[1]), down(x[2]) - down(pivot[2]));
  Vector3<T> y;
  for (int i = 0; i < 3; ++i)
    y[i] = std::ldexp((((R(i, 0) * d[0] + R(i, 1) * d[1]) + R(i, 2) * d[2]) + down(pivot[i])) + down(t[i]), g);
  return y;
}

}  // namespace

template <class T>
Vector3<T> local_target_centre(const Handles<T>& q, T local_scale, T limit) {
  const std::size_t J = std::size_t(q.points.rows() + 2 * q.segment_a.rows());
  if (J == 0) return Vector3<T>::Zero();
  const int m = std::ilogb(T(J)) + 1;
  const T down = std::ldexp(T(1), -m);
  T sx = 0, sy = 0, sz = 0;
  auto check = [&](const Points<T>& p, Eigen::Index i, const char* what) {
    for (int c = 0; c < 3; ++c)
      if (!(std::abs(p(i, c)) <= limit))
        throw std::invalid_argument(
            std::string("Deformer: coordinate too large in moved handles ") + what + " (row " + std::to_string(i) +
            ": " + num(double(p(i, c))) + ", limit " + num(double(limit)) + " = max/64 times the scene's size 2^" +
            std::to_string(std::ilogb(1 / local_scale)) + ": the deformer computes relative to the scene, and " +
            (sizeof(T) == 4 ? "float" : "double") + " holds no more)");
  };
  auto add = [&](const Points<T>& p, Eigen::Index i) {
    sx += p(i, 0) * local_scale * down, sy += p(i, 1) * local_scale * down, sz += p(i, 2) * local_scale * down;
  };
  // The limits first in one branch-free pass over the values (vectorised; |x| <= limit is false for NaN), the
  // row-by-row search for the message only where it fails: this runs in every frame, serially (with a check per
  // value, a twentieth of Table 2's Cylinder frame, 322 handles, on two threads).
  bool fine = true;
  for (const Points<T>* p : {&q.points, &q.segment_a, &q.segment_b})
    for (Eigen::Index i = 0; i < p->size(); ++i) fine &= std::abs(p->data()[i]) <= limit;
  if (!fine) {
    for (Eigen::Index i = 0; i < q.points.rows(); ++i) check(q.points, i, "points");
    for (Eigen::Index i = 0; i < q.segment_a.rows(); ++i)
      check(q.segment_a, i, "segment_a"), check(q.segment_b, i, "segment_b");
  }
  for (Eigen::Index i = 0; i < q.points.rows(); ++i) add(q.points, i);
  for (Eigen::Index i = 0; i < q.segment_a.rows(); ++i) add(q.segment_a, i), add(q.segment_b, i);
  const T inv = T(1) / T(J) / down;
  return Vector3<T>(sx * inv, sy * inv, sz * inv);
}

template <class T>
void set_point_target(Handles<T>& targets, Eigen::Index i, const Vector3<T>& target) {
  if (i < 0 || i >= targets.points.rows())
    throw std::out_of_range("Deformer::set_point_target: index " + std::to_string(i) + " but " +
                            std::to_string(targets.points.rows()) + " point handles");
  if (!target.allFinite() || target.cwiseAbs().maxCoeff() > coordinate_limit<T>())
    throw std::invalid_argument("Deformer::set_point_target: non-finite or too large coordinate");
  targets.points.row(i) = target.transpose();
}

template <class T>
void set_segment_target(Handles<T>& targets, Eigen::Index i, const Vector3<T>& a, const Vector3<T>& b) {
  if (i < 0 || i >= targets.segment_a.rows())
    throw std::out_of_range("Deformer::set_segment_target: index " + std::to_string(i) + " but " +
                            std::to_string(targets.segment_a.rows()) + " segment handles");
  if (!a.allFinite() || !b.allFinite() || a.cwiseAbs().maxCoeff() > coordinate_limit<T>() ||
      b.cwiseAbs().maxCoeff() > coordinate_limit<T>())
    throw std::invalid_argument("Deformer::set_segment_target: non-finite or too large coordinate");
  targets.segment_a.row(i) = a.transpose();
  targets.segment_b.row(i) = b.transpose();
}

template <class T>
void transform_targets(Handles<T>& targets, const Handles<T>& rest, std::span<const Eigen::Index> point_indices,
                       std::span<const Eigen::Index> segment_indices, const Matrix3<T>& R, const Vector3<T>& t,
                       const Vector3<T>& pivot) {
  static constexpr const char* what = "Deformer::transform_handles";
  Handles<T>& q = targets;
  const Handles<T>& p = rest;
  const auto check_index = [](Eigen::Index i, Eigen::Index count, const char* kind) {
    if (i < 0 || i >= count)
      throw std::out_of_range(std::string(what) + ": " + kind + " index " + std::to_string(i) + " but " +
                              std::to_string(count) + " " + kind + " handles");
  };
  for (const Eigen::Index i : point_indices) check_index(i, p.points.rows(), "point");
  for (const Eigen::Index i : segment_indices) check_index(i, p.segment_a.rows(), "segment");
  check_rigid_motion(R, t, pivot, what);
  // The frame of rigid_image: g, the exponent of the largest coordinate involved.
  T largest = std::max(t.cwiseAbs().maxCoeff(), pivot.cwiseAbs().maxCoeff());
  for (const Eigen::Index i : point_indices) largest = std::max(largest, p.points.row(i).cwiseAbs().maxCoeff());
  for (const Eigen::Index i : segment_indices)
    largest = std::max({largest, p.segment_a.row(i).cwiseAbs().maxCoeff(), p.segment_b.row(i).cwiseAbs().maxCoeff()});
  const int g = exponent_of(largest);
  const auto image = [&](const Points<T>& m, Eigen::Index i) {
    const Vector3<T> y = rigid_image<T>(m.row(i).transpose(), R, t, pivot, g);
    if (!y.allFinite() || y.cwiseAbs().maxCoeff() > coordinate_limit<T>())
      throw std::invalid_argument(std::string(what) + ": the image of " + (&m == &p.points ? "point" : "segment") +
                                  " handle " + std::to_string(i) + " has a non-finite or too large coordinate");
    return y;
  };
  // Every image is checked before any target changes (strong guarantee), then computed again to be stored:
  // the same operations give the same bits, and nothing is allocated.
  for (const Eigen::Index i : point_indices) image(p.points, i);
  for (const Eigen::Index i : segment_indices) image(p.segment_a, i), image(p.segment_b, i);
  for (const Eigen::Index i : point_indices) q.points.row(i) = image(p.points, i).transpose();
  for (const Eigen::Index i : segment_indices) {
    q.segment_a.row(i) = image(p.segment_a, i).transpose();
    q.segment_b.row(i) = image(p.segment_b, i).transpose();
  }
}

#define MLSDEFORM_TARGETS(T)                                                                              \
  template Vector3<T> local_target_centre<T>(const Handles<T>&, T, T);                                    \
  template void set_point_target<T>(Handles<T>&, Eigen::Index, const Vector3<T>&);                        \
  template void set_segment_target<T>(Handles<T>&, Eigen::Index, const Vector3<T>&, const Vector3<T>&);   \
  template void transform_targets<T>(Handles<T>&, const Handles<T>&, std::span<const Eigen::Index>,       \
                                     std::span<const Eigen::Index>, const Matrix3<T>&, const Vector3<T>&, \
                                     const Vector3<T>&);
MLSDEFORM_TARGETS(float)
MLSDEFORM_TARGETS(double)
#undef MLSDEFORM_TARGETS

}  // namespace mlsdeform::detail
