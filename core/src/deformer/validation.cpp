#include "core/src/deformer/validation.hpp"

#include <Eigen/LU>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <stdexcept>
#include <utility>

namespace mlsdeform::detail {

using Vec3d = Eigen::Vector3d;

std::string num(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
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
  if (o.isa) {
    const int isa = static_cast<int>(*o.isa);
    if (isa < static_cast<int>(Isa::scalar) || isa > static_cast<int>(Isa::neon))
      throw std::invalid_argument("Deformer: unknown Isa value " + std::to_string(isa));
    const std::vector<Isa> runs = supported_isas();
    if (std::find(runs.begin(), runs.end(), *o.isa) == runs.end())
      throw std::invalid_argument("Deformer: Options::isa = " + std::string(to_string(*o.isa)) +
                                  ": this CPU cannot run it");
  }
  if (o.weight_storage != WeightStorage::automatic && o.weight_storage != WeightStorage::precomputed &&
      o.weight_storage != WeightStorage::on_the_fly && o.weight_storage != WeightStorage::precomputed_weights)
    throw std::invalid_argument("Deformer: unknown WeightStorage value " +
                                std::to_string(static_cast<int>(o.weight_storage)));
  if (o.centroids != Centroids::mls && o.centroids != Centroids::rbf)
    throw std::invalid_argument("Deformer: unknown Centroids value " + std::to_string(static_cast<int>(o.centroids)));
  if (o.arap_iterations < 0)
    throw std::invalid_argument("Deformer: arap_iterations must be >= 0 (got " + std::to_string(o.arap_iterations) +
                                ")");
  if (o.threads < 0)
    throw std::invalid_argument("Deformer: threads must be >= 0 (got " + std::to_string(o.threads) + ")");
  if (o.arap_acceleration != ArapAcceleration::none && o.arap_acceleration != ArapAcceleration::anderson)
    throw std::invalid_argument("Deformer: unknown ArapAcceleration value " +
                                std::to_string(static_cast<int>(o.arap_acceleration)));
  if (!(o.arap_warm_start_limit >= 0) || !std::isfinite(o.arap_warm_start_limit))
    throw std::invalid_argument("Deformer: arap_warm_start_limit must be finite and >= 0 (got " +
                                std::to_string(o.arap_warm_start_limit) + ")");
  if (!o.region.empty() && o.arap_iterations > 0)
    throw std::invalid_argument(
        "Deformer: a region (Options::region) with arap_iterations > 0 is not supported; use one or the other");
}

template <class T>
void check_points(const Points<T>& p, const char* what, const char* part, T limit) {
  // Every frame checks its targets: first one branch-free pass over the values (|x| <= limit is false for NaN
  // and infinities; vectorised), then, only if it fails, the row-by-row search for the message. 322 handles
  // (Table 2's Cylinder): 0.36 us of a 27 us frame on two threads, all of it serial, before the pass.
  bool fine = true;
  for (Eigen::Index i = 0; i < p.size(); ++i) fine &= std::abs(p.data()[i]) <= limit;
  if (fine) return;
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

template <class T>
CoincidentPairs coincident_points(const Points<T>& p) {
  std::vector<Eigen::Index> order(static_cast<std::size_t>(p.rows()));
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<Eigen::Index>(i);
  const auto key = [&p](Eigen::Index i) { return std::array<T, 3>{p(i, 0), p(i, 1), p(i, 2)}; };
  // Ties broken by index: std::stable_sort's order, without its temporary buffer (std::get_temporary_buffer,
  // deprecated: clang warns inside Debian 12's libstdc++).
  std::sort(order.begin(), order.end(),
            [&](Eigen::Index a, Eigen::Index b) { return std::pair(key(a), a) < std::pair(key(b), b); });
  CoincidentPairs pairs;
  for (std::size_t a = 0; a < order.size();) {
    std::size_t b = a + 1;
    while (b < order.size() && key(order[b]) == key(order[a])) ++b;
    for (std::size_t c = a + 1; c < b; ++c)
      pairs.emplace_back(std::min(order[a], order[c]), std::max(order[a], order[c]));
    a = b;
  }
  return pairs;
}

template <class T>
void check_coincident(const Handles<T>& moved, const CoincidentPairs& pairs) {
  for (const auto& [i, j] : pairs)
    if (moved.points.row(i) != moved.points.row(j))
      throw std::invalid_argument("Deformer: point handles " + std::to_string(i) + " and " + std::to_string(j) +
                                  " share their rest position but have different targets (" +
                                  num(double(moved.points(i, 0))) + ", " + num(double(moved.points(i, 1))) + ", " +
                                  num(double(moved.points(i, 2))) + ") and (" + num(double(moved.points(j, 0))) + ", " +
                                  num(double(moved.points(j, 1))) + ", " + num(double(moved.points(j, 2))) +
                                  "); a vertex there cannot follow both");
}

template <class T>
T orthonormality_error(const Matrix3<T>& R) {
  T worst = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const T e = (R(0, i) * R(0, j) + R(1, i) * R(1, j)) + R(2, i) * R(2, j) - T(i == j ? 1 : 0);
      worst = std::max(worst, std::abs(e));
    }
  return worst;
}

template <class T>
void check_rigid_motion(const Matrix3<T>& R, const Vector3<T>& t, const Vector3<T>& pivot, const char* what) {
  if (!R.allFinite()) throw std::invalid_argument(std::string(what) + ": the rotation has a non-finite entry");
  const T e = orthonormality_error(R);
  if (!(e <= rotation_tolerance<T>()))
    throw std::invalid_argument(std::string(what) + ": not a rotation (largest entry of |R^T R - I| is " +
                                num(double(e)) + ", tolerance " + num(double(rotation_tolerance<T>())) + ")");
  if (!(R.determinant() > 0))
    throw std::invalid_argument(std::string(what) + ": not a rotation (det R < 0: a reflection)");
  if (!t.allFinite()) throw std::invalid_argument(std::string(what) + ": non-finite translation");
  if (!pivot.allFinite()) throw std::invalid_argument(std::string(what) + ": non-finite pivot");
}

#define MLSDEFORM_VALIDATION(T)                                                 \
  template void check_points<T>(const Points<T>&, const char*, const char*, T); \
  template void check_handles<T>(const Handles<T>&, const char*, T);            \
  template void check_moved<T>(const Handles<T>&, const Handles<T>&);           \
  template CoincidentPairs coincident_points<T>(const Points<T>&);              \
  template void check_coincident<T>(const Handles<T>&, const CoincidentPairs&); \
  template T orthonormality_error<T>(const Matrix3<T>&);                        \
  template void check_rigid_motion<T>(const Matrix3<T>&, const Vector3<T>&, const Vector3<T>&, const char*);
MLSDEFORM_VALIDATION(float)
MLSDEFORM_VALIDATION(double)
#undef MLSDEFORM_VALIDATION

}  // namespace mlsdeform::detail
