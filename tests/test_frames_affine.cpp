// Frames of affine sessions (FramesOut::linear, mlsdeform/frames.hpp): the fit's matrix L = H G^-1 per vertex.
// Positions bitwise those of deform() without frames on every ISA and thread count; an affine motion
// x -> A x + t of every handle (well-conditioned, a shear, a reflection) gives L = A at every vertex, a vertex on
// a handle included (the fit's limit there); a non-affine motion gives the L of an independent long-double
// evaluation of Schaefer et al.'s normal equations; the other frame outputs stay refused. Without
// Options::affine_frames the session keeps alpha alone (memory and budget) and refuses linear.
#include "tests/support/deform_cases.hpp"
#include "tests/support/isa_guard.hpp"
#include "tests/support/random.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

using namespace mlsdeform;
using mlsdeform::testing::IsaGuard;

namespace {

using Mat3l = Eigen::Matrix<long double, 3, 3>;
using Vec3l = Eigen::Matrix<long double, 3, 1>;

/// The fit at rest point v in long double, independently of the library (point handles, w_j = |p_j - v|^-2,
/// the default weight exponent): L = (sum_j w_j qhat_j phat_j^T) (sum_j w_j phat_j phat_j^T)^-1, and what its
/// bound needs: sum_j |q_j - c| |B_j| (B_j = w_j G^-1 phat_j: L = sum_j (q_j - c) B_j^T for any c, here the
/// farthest the kernel's centre can be from q_j, the targets' bounding-box diagonal) and kappa(G).
struct AffineReference {
  Mat3l L;
  double spread = 0;  ///< sum_j diag(Q) |B_j|
  double kappa = 0;
};

/// At = the index of a handle that v is on: the fit's limit there (data.hpp), that handle's weight gone and
/// p*, q* on it.
template <class T>
AffineReference affine_reference(const Eigen::Vector3d& v, const Handles<T>& rest, const Handles<T>& moved,
                                 Eigen::Index at = -1) {
  const Eigen::Index k = rest.point_count();
  const auto nk = static_cast<std::size_t>(k);
  std::vector<Vec3l> p(nk), q(nk);
  std::vector<long double> w(nk);
  Vec3l ps = Vec3l::Zero(), qs = Vec3l::Zero(), lo = Vec3l::Constant(HUGE_VALL), hi = -lo;
  long double S = 0;
  for (Eigen::Index j = 0; j < k; ++j) {
    const auto u = std::size_t(j);
    p[u] = rest.points.row(j).transpose().template cast<long double>();
    q[u] = moved.points.row(j).transpose().template cast<long double>();
    w[u] = j == at ? 0 : 1 / (p[u] - v.cast<long double>()).squaredNorm();
    S += w[u];
    ps += w[u] * p[u];
    qs += w[u] * q[u];
    lo = lo.cwiseMin(q[u]);
    hi = hi.cwiseMax(q[u]);
  }
  ps /= S;
  qs /= S;
  if (at >= 0) {
    ps = p[std::size_t(at)];
    qs = q[std::size_t(at)];
  }
  Mat3l G = Mat3l::Zero(), H = Mat3l::Zero();
  for (std::size_t j = 0; j < std::size_t(k); ++j) {
    G += w[j] * (p[j] - ps) * (p[j] - ps).transpose();
    H += w[j] * (q[j] - qs) * (p[j] - ps).transpose();
  }
  AffineReference r;
  const Mat3l Gi = G.inverse();
  r.L = H * Gi;
  const long double diag = (hi - lo).norm();
  for (std::size_t j = 0; j < std::size_t(k); ++j) r.spread += double(diag * (w[j] * Gi * (p[j] - ps)).norm());
  const Eigen::SelfAdjointEigenSolver<Mat3l> es(G);
  r.kappa = double(es.eigenvalues()[2] / es.eigenvalues()[0]);
  return r;
}

/// The bound on |L - L_exact| (each entry) for the targets as given in T: the kernel's sum
/// L = sum_j (q_j - c) B_j^T is a 2J-step sum of products over terms |q_j - c| |B_j| (gamma_2J, stages.hpp
/// correlation_matrix), with q_j - c rounded once and B_j rounded once to T (2 eps more): (2J + 2) eps_T
/// spread; B_j is solved in double from G's eigen-decomposition, relative error a few kappa(G) eps_double
/// (16 counts the 3 x 3 decomposition's and A_j's roundings): 16 kappa eps_double spread.
template <class T>
double linear_bound(const AffineReference& r, std::size_t J) {
  const double eps = std::numeric_limits<T>::epsilon(), eps_d = std::numeric_limits<double>::epsilon();
  return (double(2 * J + 2) * eps + 16 * r.kappa * eps_d) * r.spread;
}

template <class T>
Eigen::Matrix3d row(const std::vector<T>& l, Eigen::Index i) {
  Eigen::Matrix3d L;
  for (int k = 0; k < 9; ++k) L(k / 3, k % 3) = double(l[9 * std::size_t(i) + std::size_t(k)]);
  return L;
}

}  // namespace

TEMPLATE_TEST_CASE("affine frames: positions bitwise those without frames, any ISA and thread count",
                   "[frames][affine]", float, double) {
  using T = TestType;
  const IsaGuard guard;
  const testing::DeformCase<T> c = testing::twisted_cube_case<T>(203, 7, 0, false, 1.2, 0.1, 3);
  const testing::DeformCase<T> cs = testing::twisted_cube_case<T>(203, 5, 2, false, 1.2, 0.1, 4);
  for (Isa isa : supported_isas())
    for (const testing::DeformCase<T>* k : {&c, &cs}) {
      INFO("isa " << to_string(isa) << " segments " << k->rest.segment_count());
      Options o;
      o.isa = isa;
      o.transform = Transform::affine;
      o.affine_frames = true;
      const Deformer<T> d(k->vertices, k->rest, o);
      Points<T> plain, with;
      d.deform(k->moved, plain);
      std::vector<T> l(9 * std::size_t(d.vertex_count()), T(-7));
      d.deform(k->moved, with, FramesOut<T>{{}, {}, {}, l});
      CHECK(std::memcmp(plain.data(), with.data(), std::size_t(plain.size()) * sizeof(T)) == 0);
      CHECK(std::none_of(l.begin(), l.end(), [](T x) { return x == T(-7) || !std::isfinite(x); }));
      Options o1 = o;
      o1.threads = 1;
      std::vector<T> l1(l.size());
      Deformer<T>(k->vertices, k->rest, o1).deform(k->moved, with, FramesOut<T>{{}, {}, {}, l1});
      CHECK(with == plain);
      CHECK(l1 == l);
    }
}

TEMPLATE_TEST_CASE("affine frames: an affine motion of every handle gives its matrix at every vertex",
                   "[frames][affine]", float, double) {
  using T = TestType;
  const IsaGuard guard;
  std::mt19937_64 g(17);
  const testing::DeformCase<T> c = testing::random_case<T>(g, 301, 9);
  const Eigen::Matrix3d R = testing::random_rotation(g);
  Eigen::Matrix3d shear = Eigen::Matrix3d::Identity(), N;
  shear(0, 1) = 0.8;
  for (int k = 0; k < 3; ++k) N.col(k) = testing::random_vector(g);
  const Eigen::Matrix3d reflection = R * Eigen::Vector3d(1, -1, 1).asDiagonal();
  const Eigen::Vector3d t(0.4, -0.2, 0.9);
  for (Isa isa : supported_isas())
    for (const Eigen::Matrix3d& A :
         {Eigen::Matrix3d(R * (Eigen::Matrix3d::Identity() + 0.4 * N)), shear, Eigen::Matrix3d(1.7 * reflection)}) {
      INFO("isa " << to_string(isa) << " A\n" << A);
      Options o;
      o.isa = isa;
      o.transform = Transform::affine;
      o.affine_frames = true;
      const Handles<T> moved = testing::transformed(c.rest, A, t);
      // Every rest handle is also a vertex: the fit's limit there is A too.
      Points<T> verts(c.vertices.rows() + c.rest.point_count(), 3);
      verts << c.vertices, c.rest.points;
      const Deformer<T> dh(verts, c.rest, o);
      Points<T> out;
      std::vector<T> l(9 * std::size_t(verts.rows()));
      dh.deform(moved, out, FramesOut<T>{{}, {}, {}, l});
      Eigen::Index failures = 0;
      double worst = 0;
      for (Eigen::Index i = 0; i < verts.rows(); ++i) {
        const Eigen::Index at = i >= c.vertices.rows() ? i - c.vertices.rows() : -1;
        const AffineReference r = affine_reference(verts.row(i).template cast<double>().transpose(), c.rest, moved, at);
        // The targets rounded to T move the exact L off A by sum_j |dq_j - dq*| |B_j| <= eps max|q_j| sum |B_j|
        // (here max|q_j| <= |A| sqrt(3) + |t| < 4 diag(Q)): 4 eps of spread more.
        const double tol =
            linear_bound<T>(r, std::size_t(c.rest.point_count())) + 4 * std::numeric_limits<T>::epsilon() * r.spread;
        const double err = (row(l, i) - A).cwiseAbs().maxCoeff();
        worst = std::max(worst, err / tol);
        if (!(err <= tol) && ++failures <= 3) UNSCOPED_INFO("vertex " << i << " |L - A| " << err << " / " << tol);
      }
      INFO("worst deviation / bound " << worst);
      CHECK(failures == 0);
      // Not vacuous: the bound is within a few hundred times the error seen.
      CHECK(worst > 1e-3);
    }
}

TEMPLATE_TEST_CASE("affine frames: a non-affine motion gives the long-double fit's matrix", "[frames][affine]", float,
                   double) {
  using T = TestType;
  const IsaGuard guard;
  std::mt19937_64 g(23);
  const testing::DeformCase<T> c = testing::random_case<T>(g, 400, 8);
  Handles<T> moved = c.rest;
  for (Eigen::Index j = 0; j < moved.point_count(); ++j)
    moved.points.row(j) += (0.5 * testing::random_vector(g)).cast<T>().transpose();
  for (Isa isa : supported_isas()) {
    INFO("isa " << to_string(isa));
    Options o;
    o.isa = isa;
    o.transform = Transform::affine;
    o.affine_frames = true;
    const Deformer<T> d(c.vertices, c.rest, o);
    Points<T> out;
    std::vector<T> l(9 * std::size_t(c.vertices.rows()));
    d.deform(moved, out, FramesOut<T>{{}, {}, {}, l});
    Eigen::Index failures = 0;
    double worst = 0;
    for (Eigen::Index i = 0; i < c.vertices.rows(); i += 7) {
      const AffineReference r = affine_reference(c.vertices.row(i).template cast<double>().transpose(), c.rest, moved);
      const double tol = linear_bound<T>(r, std::size_t(c.rest.point_count()));
      const double err = (row(l, i) - r.L.template cast<double>()).cwiseAbs().maxCoeff();
      worst = std::max(worst, err / tol);
      if (!(err <= tol) && ++failures <= 3) UNSCOPED_INFO("vertex " << i << " |L - L_ref| " << err << " / " << tol);
    }
    INFO("worst deviation / bound " << worst);
    CHECK(failures == 0);
    CHECK(worst > 1e-3);
  }
}

TEMPLATE_TEST_CASE("affine frames: quaternions, rotations and scales stay refused", "[frames][affine][errors]", float,
                   double) {
  using T = TestType;
  std::mt19937_64 g(2);
  const testing::DeformCase<T> c = testing::random_case<T>(g, 50, 5);
  Options o;
  o.transform = Transform::affine;
  o.affine_frames = true;
  const Deformer<T> d(c.vertices, c.rest, o);
  std::vector<T> q(4 * 50), r(9 * 50), s(50);
  Points<T> out;
  CHECK_THROWS_WITH(d.deform(c.rest, out, FramesOut<T>{q, {}, {}, {}}),
                    Catch::Matchers::ContainsSubstring("frames.quaternions") &&
                        Catch::Matchers::ContainsSubstring("frames.linear gives its matrix"));
  CHECK_THROWS_WITH(d.deform(c.rest, out, FramesOut<T>{{}, r, {}, {}}),
                    Catch::Matchers::ContainsSubstring("frames.rotations"));
  CHECK_THROWS_WITH(d.deform(c.rest, out, FramesOut<T>{{}, {}, s, {}}),
                    Catch::Matchers::ContainsSubstring("frames.scales"));
}

TEMPLATE_TEST_CASE("affine frames: a vertex where p* is the vertex itself (vhat = 0) has the fit's matrix",
                   "[frames][affine]", float, double) {
  using T = TestType;
  // The cube's corners as handles: at its centre every weight is equal and p* is the centre exactly, so vhat is
  // 0 and alpha = omega, but the fit, and its matrix, are there as anywhere.
  Handles<T> rest;
  rest.points.resize(8, 3);
  for (int i = 0; i < 8; ++i) rest.points.row(i) << T(i & 1), T((i >> 1) & 1), T(i >> 2);
  Points<T> verts(3, 3);
  verts << T(0.5), T(0.5), T(0.5), T(0.25), T(0.5), T(0.5), T(0.5), T(0.5), T(0.75);
  Eigen::Matrix3d A = Eigen::Matrix3d::Identity();
  A(0, 1) = 0.5;
  A(2, 0) = -0.25;
  const Handles<T> moved = testing::transformed(rest, A, Eigen::Vector3d(1, 2, 3));
  Options o;
  o.transform = Transform::affine;
  o.affine_frames = true;
  for (Isa isa : supported_isas()) {
    INFO("isa " << to_string(isa));
    o.isa = isa;
    Points<T> out;
    std::vector<T> l(27);
    Deformer<T>(verts, rest, o).deform(moved, out, FramesOut<T>{{}, {}, {}, l});
    for (Eigen::Index i = 0; i < 3; ++i) {
      const AffineReference r = affine_reference(verts.row(i).template cast<double>().transpose(), rest, moved);
      // As in the affine motion test: the kernel's and the precomputation's bound, and the targets' rounding.
      const double tol = linear_bound<T>(r, 8) + 4 * std::numeric_limits<T>::epsilon() * r.spread;
      CHECK((row(l, i) - A).cwiseAbs().maxCoeff() <= tol);
    }
  }
}

TEMPLATE_TEST_CASE("affine frames: a region's matrices are its own deformation's, the identity outside",
                   "[frames][affine]", float, double) {
  using T = TestType;
  std::mt19937_64 g(31);
  const testing::DeformCase<T> c = testing::random_case<T>(g, 300, 8);
  Handles<T> moved = c.rest;
  for (Eigen::Index j = 0; j < moved.point_count(); ++j)
    moved.points.row(j) += (0.3 * testing::random_vector(g)).cast<T>().transpose();
  Options o;
  o.transform = Transform::affine;
  o.affine_frames = true;
  for (Eigen::Index i = 0; i < c.vertices.rows(); i += 2) o.region.push_back(i);
  const Deformer<T> d(c.vertices, c.rest, o);
  Points<T> plain, with;
  d.deform(moved, plain);
  std::vector<T> l(9 * std::size_t(c.vertices.rows()), T(-7));
  d.deform(moved, with, FramesOut<T>{{}, {}, {}, l});
  CHECK(with == plain);
  for (Eigen::Index i = 0; i < c.vertices.rows(); ++i) {
    INFO("vertex " << i);
    const Eigen::Matrix3d L = row(l, i);
    if (i % 2)
      CHECK(L == Eigen::Matrix3d::Identity());
    else
      CHECK((L.allFinite() && L != Eigen::Matrix3d::Identity()));
  }
}

TEMPLATE_TEST_CASE("affine frames: without Options::affine_frames, alpha alone and linear refused",
                   "[frames][affine][errors]", float, double) {
  using T = TestType;
  std::mt19937_64 g(5);
  const testing::DeformCase<T> c = testing::random_case<T>(g, 50, 5);
  Handles<T> moved = c.rest;
  for (Eigen::Index j = 0; j < moved.point_count(); ++j)
    moved.points.row(j) += (0.3 * testing::random_vector(g)).cast<T>().transpose();
  Options o;
  o.transform = Transform::affine;
  o.weight_storage = WeightStorage::precomputed;
  Options with = o;
  with.affine_frames = true;
  const Deformer<T> d(c.vertices, c.rest, o), dw(c.vertices, c.rest, with);
  // 50 vertices pad to 64 (blocks of 16), 5 point handles are 5 pseudo-handles: the alpha table holds 64 x 5
  // values, the linear table 3 times as many; the session holds beside them the rest and target handles (3
  // coordinates each) and nothing else (no p*, vhat or D for affine).
  const std::size_t alpha = 64 * 5 * sizeof(T), handles = 2 * 5 * 3 * sizeof(T);
  CHECK(d.memory_bytes() == alpha + handles);
  CHECK(dw.memory_bytes() - d.memory_bytes() == 3 * alpha);
  Points<T> plain, with_frames, out = Points<T>::Constant(50, 3, T(-7));
  d.deform(moved, plain);
  std::vector<T> l(9 * 50, T(-7));
  dw.deform(moved, with_frames, FramesOut<T>{{}, {}, {}, l});
  CHECK(std::memcmp(plain.data(), with_frames.data(), std::size_t(plain.size()) * sizeof(T)) == 0);
  std::fill(l.begin(), l.end(), T(-7));
  CHECK_THROWS_WITH(d.deform(moved, out, FramesOut<T>{{}, {}, {}, l}),
                    Catch::Matchers::ContainsSubstring("frames.linear") &&
                        Catch::Matchers::ContainsSubstring("Options::affine_frames"));
  std::vector<T> interleaved(3 * 50, T(-7));
  CHECK_THROWS_WITH(d.deform(InterleavedView<T>(interleaved.data(), 50, 3), FramesOut<T>{{}, {}, {}, l}),
                    Catch::Matchers::ContainsSubstring("Options::affine_frames"));
  CHECK((out.array() == T(-7)).all());
  CHECK(std::all_of(interleaved.begin(), interleaved.end(), [](T x) { return x == T(-7); }));
  CHECK(std::all_of(l.begin(), l.end(), [](T x) { return x == T(-7); }));
  // The automatic budget counts what is built: alpha alone fits where alpha and B_j do not.
  o.weight_storage = with.weight_storage = WeightStorage::automatic;
  o.precompute_budget_bytes = with.precompute_budget_bytes = 2 * alpha;
  CHECK(Deformer<T>(c.vertices, c.rest, o).uses_precomputed_weights());
  CHECK_THROWS_WITH(Deformer<T>(c.vertices, c.rest, with),
                    Catch::Matchers::ContainsSubstring("precompute_budget_bytes"));
}
