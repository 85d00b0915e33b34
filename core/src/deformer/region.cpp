#include "core/src/deformer/region.hpp"

#include "core/src/deformer/fold.hpp"
#include "core/src/parallel.hpp"
#include "core/src/pow2.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

namespace mlsdeform::detail {

namespace {

/// Sorted region indices; throws on an index out of range or repeated.
std::vector<Eigen::Index> checked_region(const std::vector<Eigen::Index>& region, Eigen::Index n) {
  for (std::size_t r = 0; r < region.size(); ++r)
    if (region[r] < 0 || region[r] >= n)
      throw std::invalid_argument("Deformer: region entry " + std::to_string(r) + " is vertex " +
                                  std::to_string(region[r]) + ", outside [0, " + std::to_string(n) + ")");
  std::vector<Eigen::Index> sorted = region;
  std::sort(sorted.begin(), sorted.end());
  const auto twin = std::adjacent_find(sorted.begin(), sorted.end());
  if (twin != sorted.end())
    throw std::invalid_argument("Deformer: region lists vertex " + std::to_string(*twin) + " more than once");
  return sorted;
}

/// Outside vertices next to the region, ascending (see RegionStage::make).
template <class T>
std::vector<Eigen::Index> ring(const Points<T>& v, const Triangles& triangles, const std::vector<char>& in,
                               const std::vector<Eigen::Index>& inside, int threads, const CancelCheck& cancel) {
  const auto n = static_cast<std::size_t>(v.rows());
  std::vector<char> on_ring(n, 0);
  if (triangles.rows() > 0) {
    for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
      const std::array<std::size_t, 3> c = {std::size_t(triangles(f, 0)), std::size_t(triangles(f, 1)),
                                            std::size_t(triangles(f, 2))};
      if (!in[c[0]] && !in[c[1]] && !in[c[2]]) continue;
      for (std::size_t x : c)
        if (!in[x]) on_ring[x] = 1;
    }
  } else {
    // The kRingNeighbours nearest vertices of each region vertex (ties to the lower index), by a scan of
    // all vertices: O(region x n), in parallel over the region. Sessions over large meshes should pass
    // the triangles.
    const std::size_t K = kRingNeighbours;
    // Squared distances on the vertices scaled by 2^-e, e the exponent of the largest coordinate: they cannot
    // overflow or underflow, and the choice is the same at every scale (pow2.hpp).
    const int e = exponent_of(v.size() ? double(v.cwiseAbs().maxCoeff()) : 0.0);
    Points<double> vs(v.rows(), 3);
    for (Eigen::Index i = 0; i < v.size(); ++i) vs.data()[i] = std::ldexp(double(v.data()[i]), -e);
    std::vector<std::array<std::size_t, kRingNeighbours>> near(inside.size());
    parallel_ranges(inside.size(), threads, nullptr, [&](std::size_t r0, std::size_t r1) {
      for (std::size_t r = r0; r < r1; ++r) {
        throw_if_cancelled(cancel);
        const auto i = inside[r];
        std::array<std::pair<double, std::size_t>, kRingNeighbours> best;
        best.fill({std::numeric_limits<double>::infinity(), n});
        for (std::size_t j = 0; j < n; ++j) {
          if (Eigen::Index(j) == i) continue;
          const double d = (vs.row(Eigen::Index(j)) - vs.row(i)).squaredNorm();
          if (!(d < best[K - 1].first)) continue;
          std::size_t at = K - 1;
          while (at > 0 && d < best[at - 1].first) best[at] = best[at - 1], --at;
          best[at] = {d, j};
        }
        for (std::size_t q = 0; q < K; ++q) near[r][q] = best[q].second;
      }
    });
    for (const auto& nb : near)
      for (std::size_t j : nb)
        if (j < n && !in[j]) on_ring[j] = 1;
  }
  std::vector<Eigen::Index> out;
  for (std::size_t i = 0; i < n; ++i)
    if (on_ring[i]) out.push_back(Eigen::Index(i));
  return out;
}

}  // namespace

template <class T>
std::unique_ptr<RegionStage<T>> RegionStage<T>::make(const Points<T>& rest_vertices, const Triangles& triangles,
                                                     const Handles<T>& rest_handles, const Options& options,
                                                     const CancelCheck& cancel) {
  auto st = std::make_unique<RegionStage<T>>();
  st->n = rest_vertices.rows();
  st->inside = checked_region(options.region, st->n);
  std::vector<char> in(std::size_t(st->n), 0);
  for (Eigen::Index i : st->inside) in[std::size_t(i)] = 1;
  for (Eigen::Index i = 0; i < st->n; ++i)
    if (!in[std::size_t(i)]) st->outside.push_back(i);
  st->rest_inside.resize(Eigen::Index(st->inside.size()), 3);
  for (std::size_t r = 0; r < st->inside.size(); ++r)
    st->rest_inside.row(Eigen::Index(r)) = rest_vertices.row(st->inside[r]);
  st->rest_outside.resize(Eigen::Index(st->outside.size()), 3);
  for (std::size_t r = 0; r < st->outside.size(); ++r)
    st->rest_outside.row(Eigen::Index(r)) = rest_vertices.row(st->outside[r]);

  // The ring's rest positions, each once, none at a position the caller's handles already take (their
  // targets win there: a vertex at that position follows the caller's handle).
  using Key = std::tuple<T, T, T>;
  auto key = [](const auto& row) { return Key(row(0), row(1), row(2)); };
  std::vector<Key> taken;
  for (Eigen::Index i = 0; i < rest_handles.points.rows(); ++i) taken.push_back(key(rest_handles.points.row(i)));
  for (Eigen::Index i = 0; i < rest_handles.segment_a.rows(); ++i) {
    taken.push_back(key(rest_handles.segment_a.row(i)));
    taken.push_back(key(rest_handles.segment_b.row(i)));
  }
  std::sort(taken.begin(), taken.end());
  std::vector<Eigen::Index> fixed;
  std::vector<Key> fixed_keys;
  for (Eigen::Index i : ring(rest_vertices, triangles, in, st->inside, options.threads, cancel)) {
    const Key k = key(rest_vertices.row(i));
    if (std::binary_search(taken.begin(), taken.end(), k)) continue;
    if (std::find(fixed_keys.begin(), fixed_keys.end(), k) != fixed_keys.end()) continue;
    fixed_keys.push_back(k);
    fixed.push_back(i);
  }
  st->user_points = rest_handles.points.rows();
  st->rest_handles = rest_handles;
  st->rest_handles.points.resize(st->user_points + Eigen::Index(fixed.size()), 3);
  st->rest_handles.points.topRows(st->user_points) = rest_handles.points;
  for (std::size_t f = 0; f < fixed.size(); ++f)
    st->rest_handles.points.row(st->user_points + Eigen::Index(f)) = rest_vertices.row(fixed[f]);
  if (fixed.size() > kFoldedHandles)
    st->fold_targets = detail::fold_targets<T>(st->rest_handles.points.bottomRows(Eigen::Index(fixed.size())));
  st->moved = st->rest_handles;
  st->compact.resize(st->rest_inside.rows(), 3);
  return st;
}

template <class T>
void RegionStage<T>::set_folded(bool folded) {
  moved = rest_handles;
  if (!folded) return;
  moved.points.conservativeResize(user_points + Eigen::Index(kFoldedHandles), 3);
  moved.points.bottomRows(Eigen::Index(kFoldedHandles)) = fold_targets;
}

template <class T>
void RegionStage<T>::set_targets(const Handles<T>& user) {
  moved.points.topRows(user_points) = user.points;
  moved.segment_a = user.segment_a;
  moved.segment_b = user.segment_b;
}

template <class T>
void RegionStage<T>::scatter(T* out, std::size_t vstride, std::size_t cstride) const {
  for (std::size_t c = 0; c < 3; ++c) {
    T* o = out + c * cstride;
    const T* x = compact.data() + c * inside.size();
    for (std::size_t r = 0; r < inside.size(); ++r) o[std::size_t(inside[r]) * vstride] = x[r];
    const T* y = rest_outside.data() + c * outside.size();
    for (std::size_t r = 0; r < outside.size(); ++r) o[std::size_t(outside[r]) * vstride] = y[r];
  }
}

template <class T>
std::size_t RegionStage<T>::bytes() const {
  const auto values = [](const Handles<T>& h) {
    return std::size_t(h.points.size() + h.segment_a.size() + h.segment_b.size());
  };
  return (inside.capacity() + outside.capacity()) * sizeof(Eigen::Index) +
         (std::size_t(rest_inside.size() + rest_outside.size() + compact.size()) + values(rest_handles) +
          values(moved) + std::size_t(fold_targets.size())) *
             sizeof(T);
}

template struct RegionStage<float>;
template struct RegionStage<double>;

}  // namespace mlsdeform::detail
