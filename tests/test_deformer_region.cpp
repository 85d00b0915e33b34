// A region of interest (Options::region): vertices outside it keep their rest positions bitwise, the region
// is the deformation of its own vertices with the ring of outside vertices next to it held as fixed point
// handles (bitwise with on-the-fly weights; precomputed, the ring is folded into four pseudo-handles, to a
// derived bound), the result is continuous across the border (a derived bound that goes to zero at the
// ring), an empty region is the whole model, and bad regions are refused.
#include "tests/support/deform_cases.hpp"
#include "tests/support/isa_guard.hpp"
#include "tests/support/meshes.hpp"
#include "tests/support/mls_reference.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <set>
#include <tuple>
#include <vector>

using namespace mlsdeform;
using mlsdeform::testing::human;
using mlsdeform::testing::IsaGuard;

namespace {

constexpr Eigen::Index kRightHand = 2445;  // data/human_bend.json

/// The human's vertices within `radius` of the right hand: the hand and the forearm.
std::vector<Eigen::Index> forearm(double radius) {
  std::vector<Eigen::Index> r;
  for (Eigen::Index i = 0; i < human().v.rows(); ++i)
    if ((human().v.row(i) - human().v.row(kRightHand)).norm() < radius) r.push_back(i);
  return r;
}

/// The ring as documented (Options::region): outside vertices sharing a triangle with a region vertex.
std::vector<Eigen::Index> mesh_ring(const Triangles& f, Eigen::Index n, const std::vector<Eigen::Index>& region) {
  std::vector<char> in(std::size_t(n), 0);
  for (Eigen::Index i : region) in[std::size_t(i)] = 1;
  std::set<Eigen::Index> ring;
  for (Eigen::Index t = 0; t < f.rows(); ++t) {
    const bool touches = in[std::size_t(f(t, 0))] || in[std::size_t(f(t, 1))] || in[std::size_t(f(t, 2))];
    for (int c = 0; c < 3 && touches; ++c)
      if (!in[std::size_t(f(t, c))]) ring.insert(f(t, c));
  }
  return {ring.begin(), ring.end()};
}

/// One point handle on the right hand, moved by `offset`.
template <class T>
std::pair<Handles<T>, Handles<T>> hand_handles(const Points<T>& v, const Eigen::Vector3d& offset) {
  Handles<T> rest, moved;
  rest.points = v.row(kRightHand);
  moved = rest;
  moved.points.row(0) += offset.cast<T>().transpose();
  return {rest, moved};
}

template <class T>
bool rows_bitwise_equal(const Points<T>& a, Eigen::Index i, const Points<T>& b, Eigen::Index j) {
  for (int c = 0; c < 3; ++c)
    if (std::memcmp(&a(i, c), &b(j, c), sizeof(T)) != 0) return false;
  return true;
}

/// The precomputed path folds the ring's fixed handles into four pseudo-handles with targets z_m
/// (core/src/deformer/fold.hpp), coefficients c'_m = sum_j beta_jm c_j with sum_m |beta_jm| <= 7 and
/// |z_m - p_j| <= 3 s, s < 2 e a power of two, e the ring's largest coordinate extent. The error bound of the
/// precomputed path (tests/support/mls_reference.hpp) sums, per pseudo-handle, |c_j| times |q_j| (q*, affine)
/// or |q_j - c| + |q_j| (H), over at most m = J + 16 roundings; folded, the ring's part of those sums becomes
/// sum_m |c'_m| (|z_m - c| + |z_m|) <= 7 sum_j |c_j| (|q_j - c| + |q_j| + 6 s)
///                                    <= 7 (1 + 6 s / min_j |q_j|) sum_j |c_j| (|q_j - c| + |q_j|),
/// and the folded path has fewer terms (J' = J - ring + 4), so K = 7 (1 + 6 s / min_j |q_j|) times the
/// direct comparison's bound bounds its deviation (K >= 1 scales every term, the user handles' too). Vertices
/// the direct comparison calls snapped or ill-posed (gap below K times the H error) are skipped and counted.
struct FoldedComparison {
  Eigen::Index checked = 0, skipped = 0, failures = 0;
  double max_ratio = 0;
};

template <class T>
FoldedComparison compare_folded(const Points<T>& out, const Points<T>& compact, const Handles<T>& rest,
                                const Handles<T>& moved, const Options& o, Eigen::Index first_ring) {
  const Points<double> ring = rest.points.bottomRows(rest.points.rows() - first_ring).template cast<double>();
  const double extent = (ring.colwise().maxCoeff() - ring.colwise().minCoeff()).maxCoeff();
  const double K = 7 * (1 + 6 * 2 * extent / ring.rowwise().norm().minCoeff());
  const double l = testing::scene_size(compact, rest);
  const double eps = std::numeric_limits<T>::epsilon() + std::numeric_limits<double>::epsilon();
  FoldedComparison c;
  for (Eigen::Index i = 0; i < compact.rows(); ++i) {
    const Eigen::Vector3d x = compact.row(i).template cast<double>().transpose();
    const testing::DirectVertex d = testing::direct_vertex(x, rest, moved, o, l);
    const bool rotation = o.transform != Transform::affine;
    if (d.snapped || !d.well_posed || (rotation && K * eps * d.dH_unit >= d.gap / 2)) {
      ++c.skipped;
      continue;
    }
    ++c.checked;
    const double dev = (out.row(i).template cast<double>().transpose() - d.out).norm();
    const double bound = K * eps * d.bound_unit;
    c.max_ratio = std::max(c.max_ratio, dev / bound);
    if (!(dev <= bound)) ++c.failures;
  }
  return c;
}

}  // namespace

TEMPLATE_TEST_CASE("region: outside vertices stay bitwise, the region is its own deformation with the ring fixed",
                   "[deformer][region]", float, double) {
  using T = TestType;
  const IsaGuard guard;
  const Points<T> v = human().v.cast<T>();
  const std::vector<Eigen::Index> region = forearm(0.3);
  const std::vector<Eigen::Index> ring = mesh_ring(human().f, v.rows(), region);
  REQUIRE(region.size() > 100);
  REQUIRE(!ring.empty());
  const auto [rest, moved] = hand_handles(v, Eigen::Vector3d(0.05, 0.15, 0.1));
  // The same deformation built by hand: the region's vertices alone, the caller's handle then the ring's
  // rest positions (each once: the human has no two ring vertices at one position) as fixed handles.
  Points<T> compact(Eigen::Index(region.size()), 3);
  for (std::size_t r = 0; r < region.size(); ++r) compact.row(Eigen::Index(r)) = v.row(region[r]);
  Handles<T> rest_aug = rest, moved_aug = moved;
  rest_aug.points.resize(1 + Eigen::Index(ring.size()), 3);
  rest_aug.points.row(0) = rest.points.row(0);
  for (std::size_t q = 0; q < ring.size(); ++q) rest_aug.points.row(1 + Eigen::Index(q)) = v.row(ring[q]);
  moved_aug.points = rest_aug.points;
  moved_aug.points.row(0) = moved.points.row(0);

  double worst_folded = 0;
  for (Isa isa : supported_isas()) {
    set_isa(isa);
    for (const std::optional<Isa> session_isa : {std::optional<Isa>(), std::optional<Isa>(Isa::scalar)})
      for (Transform tr : {Transform::rigid, Transform::similarity, Transform::affine})
        for (WeightStorage ws : {WeightStorage::precomputed, WeightStorage::on_the_fly}) {
          if (tr == Transform::affine && ws == WeightStorage::on_the_fly) continue;
          INFO("isa " << to_string(isa) << " session isa " << (session_isa ? to_string(*session_isa) : "active")
                      << " transform " << int(tr) << " storage " << int(ws));
          Options o;
          o.isa = session_isa;
          o.transform = tr;
          o.weight_storage = ws;
          Options o_region = o;
          o_region.region = region;
          std::shuffle(o_region.region.begin(), o_region.region.end(), std::mt19937(7));  // any order
          const Deformer<T> d(v, human().f, rest, o_region);
          CHECK(d.vertex_count() == v.rows());
          Points<T> out;
          d.deform(moved, out);
          std::vector<char> in(std::size_t(v.rows()), 0);
          for (Eigen::Index i : region) in[std::size_t(i)] = 1;
          Eigen::Index outside_moved = 0;
          for (Eigen::Index i = 0; i < v.rows(); ++i)
            if (!in[std::size_t(i)] && !rows_bitwise_equal(out, i, v, i)) ++outside_moved;
          CHECK(outside_moved == 0);

          if (ws == WeightStorage::on_the_fly) {  // the ring's handles as they are: the same bits
            const Deformer<T> by_hand(compact, rest_aug, o);
            Points<T> expected;
            by_hand.deform(moved_aug, expected);
            Eigen::Index differ = 0;
            for (std::size_t r = 0; r < region.size(); ++r)
              if (!rows_bitwise_equal(out, region[r], expected, Eigen::Index(r))) ++differ;
            CHECK(differ == 0);
          } else {  // the ring folded into four pseudo-handles: the same map, to the bound derived above
            Points<T> compact_out(Eigen::Index(region.size()), 3);
            for (std::size_t r = 0; r < region.size(); ++r) compact_out.row(Eigen::Index(r)) = out.row(region[r]);
            const FoldedComparison c = compare_folded(compact_out, compact, rest_aug, moved_aug, o, 1);
            INFO("checked " << c.checked << " skipped " << c.skipped << " largest deviation / bound " << c.max_ratio);
            CHECK(c.failures == 0);
            CHECK(c.checked >= Eigen::Index(region.size()) * 9 / 10);
            worst_folded = std::max(worst_folded, c.max_ratio);
          }
          CHECK(out.row(kRightHand) == moved.points.row(0));  // the handle's vertex is interpolated

          // Interleaved output, and the stateful targets, give the same bits.
          PointsRowMajor<T> buffer(v.rows(), 3);
          d.deform(moved, InterleavedView<T>(buffer.data(), buffer.rows(), 3));
          CHECK(Points<T>(buffer) == out);
        }
  }
  std::printf("%s: folded ring against the direct evaluation: deviation / bound at most %.3g\n",
              sizeof(T) == 4 ? "float" : "double", worst_folded);
}

TEMPLATE_TEST_CASE("region: empty is the whole model, every vertex is the whole model bitwise", "[deformer][region]",
                   float, double) {
  using T = TestType;
  const Points<T> v = human().v.cast<T>();
  const auto [rest, moved] = hand_handles(v, Eigen::Vector3d(0.05, 0.15, 0.1));
  for (Transform tr : {Transform::rigid, Transform::similarity}) {
    Options o;
    o.transform = tr;
    Points<T> whole, empty, all;
    Deformer<T>(v, rest, o).deform(moved, whole);
    Options oe = o;
    oe.region.clear();
    Deformer<T>(v, human().f, rest, oe).deform(moved, empty);
    CHECK(empty == whole);
    // Every vertex: no ring, the same vertices in the same order (the region is sorted), so the same bits.
    Options oa = o;
    oa.region.resize(std::size_t(v.rows()));
    std::iota(oa.region.rbegin(), oa.region.rend(), Eigen::Index(0));  // descending
    Deformer<T>(v, human().f, rest, oa).deform(moved, all);
    CHECK(all == whole);
  }
}

// Continuity across the border. Rigid MLS at a region vertex v is f(v) = q* + R (v - p*), with p* and q*
// the weighted centroids (eq. 2) and R a rotation. Let p_0 be the nearest fixed ring handle (q_0 = p_0),
// d = |v - p_0|, r_j = (d / |v - p_j|)^u the weights relative to p_0's (r_0 = 1) and S = sum_{j != 0} r_j,
// so omega_j = r_j / (1 + S). Then
//   f(v) - v = (q* - p*) + (R - I)(v - p*),
//   |q* - p*| = |sum_j omega_j (q_j - p_j)| <= S max_j |q_j - p_j|,
//   |v - p*| <= d + |p_0 - p*| <= d + sum_{j != 0} r_j |p_0 - p_j|,
// and |R - I| <= 2, so |f(v) - v| <= B(v) := S max_j |q_j - p_j| + 2 (d + sum_{j != 0} r_j |p_0 - p_j|). Extra
// terms only raise B (a ring position listed twice, a handle the library dropped at a user handle's
// position), so B may be computed over any superset of the pseudo-handles that contains p_0. Near the ring
// S = O(d^u) and B(v) = O(d): the displacement vanishes as v approaches the ring, whatever the handles do.
// The evaluation's rounding adds a few eps of the coordinates (below 2 here); we allow 1024 eps.
namespace {

double border_bound(const Eigen::Vector3d& x, const std::vector<Eigen::Vector3d>& P, std::size_t first_fixed,
                    double max_offset, double u) {
  std::size_t p0 = first_fixed;
  for (std::size_t j = first_fixed; j < P.size(); ++j)
    if ((P[j] - x).norm() < (P[p0] - x).norm()) p0 = j;
  const double d = (P[p0] - x).norm();
  double S = 0, spread = 0;
  for (std::size_t j = 0; j < P.size(); ++j) {
    if (j == p0) continue;
    const double r = std::pow(d / (P[j] - x).norm(), u);
    S += r;
    spread += r * (P[p0] - P[j]).norm();
  }
  return S * max_offset + 2 * (d + spread);
}

/// The ring without triangles as documented (Options::region): outside vertices among the 8 nearest
/// vertices (ties to the lower index) of some region vertex.
std::vector<Eigen::Index> nearest_ring(const Points<double>& v, const std::vector<Eigen::Index>& region) {
  std::vector<char> in(std::size_t(v.rows()), 0);
  for (Eigen::Index i : region) in[std::size_t(i)] = 1;
  std::set<Eigen::Index> ring;
  for (Eigen::Index i : region) {
    std::vector<std::pair<double, Eigen::Index>> d;
    for (Eigen::Index j = 0; j < v.rows(); ++j)
      if (j != i) d.emplace_back((v.row(j) - v.row(i)).squaredNorm(), j);
    std::partial_sort(d.begin(), d.begin() + 8, d.end());
    for (int q = 0; q < 8; ++q)
      if (!in[std::size_t(d[std::size_t(q)].second)]) ring.insert(d[std::size_t(q)].second);
  }
  return {ring.begin(), ring.end()};
}

}  // namespace

TEMPLATE_TEST_CASE("region: displacement near the border is bounded by the distance to the ring", "[deformer][region]",
                   float, double) {
  using T = TestType;
  const Points<T> v = human().v.cast<T>();
  const std::vector<Eigen::Index> region = forearm(0.3);
  const Eigen::Vector3d offset(0.1, 0.3, 0.2);
  const auto [rest, moved] = hand_handles(v, offset);
  const double slack = 1024 * double(std::numeric_limits<T>::epsilon()) * 2;
  for (bool with_triangles : {true, false}) {
    INFO((with_triangles ? "mesh ring" : "nearest-neighbour ring"));
    Options o;
    o.region = region;
    const Deformer<T> d = with_triangles ? Deformer<T>(v, human().f, rest, o) : Deformer<T>(v, rest, o);
    Points<T> out;
    d.deform(moved, out);
    const std::vector<Eigen::Index> ring =
        with_triangles ? mesh_ring(human().f, v.rows(), region) : nearest_ring(v.template cast<double>(), region);
    std::vector<Eigen::Vector3d> P{rest.points.row(0).template cast<double>().transpose()};
    for (Eigen::Index i : ring) P.push_back(v.row(i).template cast<double>().transpose());
    double worst = 0, worst_adjacent = 0;
    const std::vector<Eigen::Index> adjacent = mesh_ring(human().f, v.rows(), ring);  // next to the ring
    for (Eigen::Index i : region) {
      const Eigen::Vector3d x = v.row(i).template cast<double>().transpose();
      const double B = border_bound(x, P, 1, offset.norm(), o.weight_exponent);
      const double disp = (out.row(i).template cast<double>().transpose() - x).norm();
      CHECK(disp <= B + slack);
      worst = std::max(worst, disp / (B + slack));
      if (std::binary_search(adjacent.begin(), adjacent.end(), i))
        worst_adjacent = std::max(worst_adjacent, disp / offset.norm());
    }
    std::printf(
        "%s, %s: %zu region vertices, %zu ring handles; displacement / bound at most %.3f; region "
        "vertices next to the ring move at most %.3f of the handle's offset\n",
        sizeof(T) == 4 ? "float" : "double", with_triangles ? "mesh ring" : "nearest-neighbour ring", region.size(),
        ring.size(), worst, worst_adjacent);
  }
}

TEST_CASE("region: displacement vanishes as a vertex approaches the ring", "[deformer][region]") {
  // A 9 x 9 grid (unit spacing, triangulated) whose left part x <= 4 is the region, moved by a handle at
  // (1, 4); probes (region vertices in no triangle) approach the ring vertex (5, 4) along -x.
  const Points<double> g = testing::grid(9);
  const Eigen::Vector3d ring_vertex(5, 4, 0);
  const std::vector<double> dist = {0.5, 0.1, 1e-2, 1e-3, 1e-4, 1e-6};
  Points<double> v(g.rows() + Eigen::Index(dist.size()), 3);
  v.topRows(g.rows()) = g;
  for (std::size_t k = 0; k < dist.size(); ++k)
    v.row(g.rows() + Eigen::Index(k)) = (ring_vertex - Eigen::Vector3d(dist[k], 0, 0)).transpose();
  auto at = [&](double x, double y) {
    for (Eigen::Index i = 0; i < g.rows(); ++i)
      if (g(i, 0) == x && g(i, 1) == y) return int(i);
    return -1;
  };
  std::vector<Eigen::Index> region;
  for (Eigen::Index i = 0; i < v.rows(); ++i)
    if (v(i, 0) <= 4 || i >= g.rows()) region.push_back(i);
  const int handle_vertex = at(1, 4);
  REQUIRE(handle_vertex >= 0);
  Triangles f(2 * 8 * 8, 3);
  Eigen::Index t = 0;
  for (int x = 0; x < 8; ++x)
    for (int y = 0; y < 8; ++y) {
      f.row(t++) << at(x, y), at(x + 1, y), at(x + 1, y + 1);
      f.row(t++) << at(x, y), at(x + 1, y + 1), at(x, y + 1);
    }
  Handles<double> rest, moved;
  rest.points = v.row(handle_vertex);
  moved = rest;
  moved.points.row(0) += Eigen::RowVector3d(-1, 2, 3);
  Options o;
  o.region = region;
  const Deformer<double> d(v, f, rest, o);
  Points<double> out;
  d.deform(moved, out);
  std::vector<Eigen::Vector3d> P{rest.points.row(0).transpose()};
  for (Eigen::Index i : mesh_ring(f, v.rows(), region)) P.push_back(v.row(i).transpose());
  double previous = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < dist.size(); ++k) {
    const Eigen::Index i = g.rows() + Eigen::Index(k);
    const double disp = (out.row(i) - v.row(i)).norm();
    const double B = border_bound(v.row(i).transpose(), P, 1, 3.75, o.weight_exponent);
    INFO("distance " << dist[k] << " displacement " << disp << " bound " << B);
    CHECK(disp <= B + 1e-13);
    if (dist[k] <= 1e-2) CHECK(B <= 3 * dist[k]);  // O(d): 2 d plus O(d^2) terms
    CHECK(disp < previous);
    previous = disp;
  }
}

TEST_CASE("region: bad regions are refused", "[deformer][region]") {
  const Points<double> v = human().v;
  const auto [rest, moved] = hand_handles(v, Eigen::Vector3d(0, 0.1, 0));
  auto refused = [&](std::vector<Eigen::Index> region, const char* what, int arap = 0) {
    Options o;
    o.region = std::move(region);
    o.arap_iterations = arap;
    CHECK_THROWS_WITH(Deformer<double>(v, human().f, rest, o), Catch::Matchers::ContainsSubstring(what));
  };
  refused({1, 2, v.rows()}, "region entry 2 is vertex 6890, outside [0, 6890)");
  refused({-1}, "region entry 0 is vertex -1");
  refused({5, 7, 5}, "region lists vertex 5 more than once");
  refused({5, 7}, "not supported", 2);
  Options o;
  o.region = {1, 2, 3};
  Deformer<double> d(v, rest, o);
  const Points<double> fewer = v.topRows(3);
  CHECK_THROWS_WITH(d.reset_rest_pose(fewer, rest), Catch::Matchers::ContainsSubstring("outside [0, 3)"));
  Points<double> out;
  d.deform(moved, out);  // the session is unchanged by the refused reset
  CHECK(out.rows() == v.rows());
}
