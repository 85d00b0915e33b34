// Snapping: which rest vertices the deformer puts exactly on a handle (data.hpp, "Snapped vertices"). One rule
// for the precomputed table (precompute_table.cpp) and the on-the-fly weights (precompute_on_the_fly.cpp),
// decided once per vertex at set-up, in double, for every ISA and both precisions; and the zero-length segment
// check (precompute.cpp) is the same rule: a segment whose end b would snap onto its end a (d_min = |b - a|,
// d_2 = the distance from a to the nearest other handle) is a point.
//
// Why snap at all. The weights are taken relative to the nearest handle, r_j = (d_min / d_j)^u in [0, 1]
// (weights.hpp), so nothing overflows as d_min -> 0; but at d_min = 0 they are 0 / 0, and the map must
// interpolate there (Sec. 3: f(p_i) = q_i; on a segment, its limit, data.hpp).
//
// How close. Let d_2 be the vertex's distance to its second-nearest handle (a point, or a segment's nearest
// point), N the number of handles. Every other handle j has r_j <= (d_min / d_2)^u, and r_j |p_j - p_n| <=
// r_j (d_j + d_min) <= 2 d_min for u >= 1. Snap when d_min <= 64 eps(T) d_2. Then:
//   - r_j <= (64 eps(T))^u <= 64 eps(T): q* - q_n = sum_j omega_j (q_j - q_n) is at most
//     (N - 1) 64 eps(T) max_j |q_j - q_n|: in T the other handles' share of q* is at the level of rounding;
//   - |vhat| = |v - p*| <= d_min + sum_j r_j |p_j - p_n| <= (2 N - 1) d_min, so mu R vhat is at most
//     (2 N - 1) 64 eps(T) mu d_2.
// So the exact map differs from q_n by a few dozen eps(T) of the vertex's own neighbourhood (the spacing
// d_2 of the handles and their displacements), and snapping moves the vertex by no more than T's rounding
// of the geometry the map resolves there. The scale is the vertex's own: no vertex elsewhere in the model
// (however far) and no handle but the two nearest changes it. (The model's bounding box would let one far
// vertex widen the radius for every vertex, and the handles' spread would do the same for two handles
// close together beside a far third: both snap, and so collapse, vertices that the map separates.)
//
// One handle: its map has no length scale (a translation; one segment's fit, the same everywhere, or with
// exact_integral weights its interpolation as d -> 0, continuous), so only d_min = 0 snaps.
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>

namespace mlsdeform::detail {

/// The nearest and second-nearest of a sequence of distances (ties: the first index is the nearest, and the
/// second distance equals the first).
struct NearestTwo {
  double d_min = std::numeric_limits<double>::infinity();
  double d_second = std::numeric_limits<double>::infinity();
  std::size_t nearest = 0;
  void add(double d, std::size_t index) {
    if (d < d_min) {
      d_second = d_min;
      d_min = d;
      nearest = index;
    } else if (d < d_second) {
      d_second = d;
    }
  }
};

/// The snapping radius relative to d_second (see above).
inline constexpr double kSnapEpsilons = 64;

/// True when a vertex at distance d_min from its nearest handle and d_second from its second-nearest
/// (+infinity with a single handle) is put on the nearest handle.
template <class T>
bool snaps(double d_min, double d_second) {
  const double scale = std::isfinite(d_second) ? d_second : 0.0;
  return !(d_min > kSnapEpsilons * double(std::numeric_limits<T>::epsilon()) * scale);
}

}  // namespace mlsdeform::detail
