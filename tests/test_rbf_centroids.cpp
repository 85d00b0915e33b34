// Centroids::rbf (paper Sec. 7-8): q* = g(p*) with g the polyharmonic RBF interpolant of the handles, with
// each kernel of core/src/deformer/rbf_centroids.hpp (r, the library's, and r^3, which bench_quality
// --centroids measures against it): the properties and bounds below hold for both.
//
// Bounds. The centroid weights beta(p*) come from one solve with the interpolant's matrix M in double:
// backward stable (partial pivoting), so each beta carries a relative error of at most (J + 4) eps(double)
// kappa(M) (kappa computed here independently, in long double), and is then rounded to T. The kernels form
// q* = sum_j beta_j q_j in T: at most (J + 1) roundings of terms of size |beta_j| |q_j|. So q* is off g(p*)
// by at most eps(T) (J + 2) B Q + (J + 4) eps(double) kappa(M) B Q with B = sum_j |beta_j| and Q = max |q_j|.
// What the rest of a vertex's transform adds (the rotation, mu) is the MLS path's own, bounded per vertex by
// the direct evaluation (tests/support/mls_reference.hpp, the bound the deformer tests use).
#include "tests/test_deformer_common.hpp"

#include "core/src/deformer/rbf_centroids.hpp"

#include <Eigen/SVD>

#include <cstdio>
#include <cstring>
#include <random>
#include <vector>

using namespace deformer_test;
using mlsdeform::detail::RbfCentroids;
using mlsdeform::detail::RbfKernel;
using LD = long double;

namespace {

/// kappa(M) of the interpolant's matrix for the centres P (long double, the polynomial in raw centred
/// coordinates: an orthonormal change of the polynomial basis is an orthogonal similarity of M, so kappa is
/// the same as the library's).
LD kappa_of(const std::vector<Vec3d>& P, RbfKernel kernel) {
  const auto m = Eigen::Index(P.size());
  Eigen::Matrix<LD, Eigen::Dynamic, Eigen::Dynamic> M =
      Eigen::Matrix<LD, Eigen::Dynamic, Eigen::Dynamic>::Zero(m + 4, m + 4);
  Vec3d mean = Vec3d::Zero();
  for (const Vec3d& p : P) mean += p;
  mean /= double(m);
  for (Eigen::Index i = 0; i < m; ++i) {
    for (Eigen::Index j = 0; j < m; ++j) {
      const LD r = (P[std::size_t(i)] - P[std::size_t(j)]).cast<LD>().norm();
      M(i, j) = kernel == RbfKernel::r ? r : r * r * r;
    }
    M(i, m) = M(m, i) = 1;
    for (int c = 0; c < 3; ++c) M(i, m + 1 + c) = M(m + 1 + c, i) = LD(P[std::size_t(i)][c] - mean[c]);
  }
  const auto sv = Eigen::JacobiSVD<Eigen::Matrix<LD, Eigen::Dynamic, Eigen::Dynamic>>(M).singularValues();
  return sv(0) / sv(sv.size() - 1);
}

std::vector<Vec3d> random_centres(std::mt19937_64& g, int J) {
  std::vector<Vec3d> P;
  for (int j = 0; j < J; ++j) P.push_back(random_vector(g));
  return P;
}

/// The pseudo-handles of h (points, then each segment's two ends: core/src/deformer/data.hpp).
template <class T>
std::vector<Vec3d> pseudo_handles(const Handles<T>& h) {
  std::vector<Vec3d> P;
  for (Eigen::Index i = 0; i < h.points.rows(); ++i) P.push_back(h.points.row(i).transpose().template cast<double>());
  for (Eigen::Index i = 0; i < h.segment_a.rows(); ++i) {
    P.push_back(h.segment_a.row(i).transpose().template cast<double>());
    P.push_back(h.segment_b.row(i).transpose().template cast<double>());
  }
  return P;
}

/// The scale of the deformer's local frame (core/src/deformer/local_frame.hpp): 2^-e, e the exponent of the
/// bounding-box diagonal of the rest vertices and handles.
template <class T>
double local_scale(const Scene<T>& sc) {
  return std::ldexp(1.0, -std::ilogb(scene_size(sc.vertices, sc.rest)));
}

/// The rest pseudo-handles in the deformer's local frame (scaled by local_scale; the translation cancels in
/// M): beta does not depend on the frame (phi is homogeneous and the linear polynomials are invariant under
/// similarity), but kappa(M) does.
template <class T>
std::vector<Vec3d> handle_points(const Scene<T>& sc) {
  const double scale = local_scale(sc);
  std::vector<Vec3d> P = pseudo_handles(sc.rest);
  for (Vec3d& p : P) p *= scale;
  return P;
}

/// p* of vertex v (eq. 2, u = 2; paper_constant segments: weight d^-u at their midpoint, Sec. 6.2). At a
/// point handle, that handle (the deformer interpolates there and uses no centroid weights).
template <class T>
Vec3d rest_centroid(const Vec3d& v, const Handles<T>& rest) {
  Vec3d s = Vec3d::Zero();
  double W = 0;
  for (Eigen::Index j = 0; j < rest.points.rows(); ++j) {
    const Vec3d p = rest.points.row(j).transpose().template cast<double>();
    if (p == v) return p;
    const double w = 1 / (p - v).squaredNorm();
    s += w * p, W += w;
  }
  for (Eigen::Index j = 0; j < rest.segment_a.rows(); ++j) {
    const Vec3d a = rest.segment_a.row(j).transpose().template cast<double>();
    const Vec3d b = rest.segment_b.row(j).transpose().template cast<double>();
    const double t = std::clamp((v - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
    const double w = 1 / (a + t * (b - a) - v).squaredNorm();
    s += w * 0.5 * (a + b), W += w;
  }
  return s / W;
}

/// The extra bound of the file comment for every vertex of a scene: max over vertices of the RBF terms, with
/// Q the largest |q_j| (so that sum_j |beta_j| |q_j| <= B Q bounds the error of q* in norm).
template <class T>
double rbf_extra(const Scene<T>& sc, const Handles<T>& moved) {
  const double scale = local_scale(sc);
  const std::vector<Vec3d> P = handle_points(sc);
  const RbfCentroids rbf(P);  // the kernel the deformer used: rbf_kernel()
  const LD kappa = kappa_of(P, mlsdeform::detail::rbf_kernel());
  double Q = 0;
  for (const Vec3d& q : pseudo_handles(moved)) Q = std::max(Q, q.norm());
  const double J = double(P.size());
  std::vector<double> beta;
  Eigen::VectorXd rhs;
  double B = 0;
  for (Eigen::Index i = 0; i < sc.vertices.rows(); ++i) {
    const Vec3d p_star = rest_centroid(sc.vertices.row(i).transpose().template cast<double>(), sc.rest);
    rbf.weights(scale * p_star, beta, rhs);  // in the frame of P (the same beta as in any other)
    double b = 0;
    for (double x : beta) b += std::abs(x);
    B = std::max(B, b);
  }
  return (std::numeric_limits<T>::epsilon() * (J + 2) +
          (J + 4) * std::numeric_limits<double>::epsilon() * double(kappa)) *
         B * Q;
}

/// x -> s Q x + t with a proper rotation Q, exact in T on a grid, so that a scene on the grid and its image
/// are exactly each other's motion. Q = M / n, M the integer matrix of the rotation of the integer quaternion
/// (a, b, c, d), n = a^2 + b^2 + c^2 + d^2; s = p / 2 (p = 2: a rigid motion); t a multiple of the unit
/// h = 2^-20. The grid's points are multiples of 2 n h; their images p M (x / (2 n h)) h + t are integers
/// times h, computed here in integers, and exact in T while those integers are below 2^digits(T) (checked).
struct GridMotion {
  static constexpr double h = 1.0 / (1 << 20);
  Eigen::Matrix<long long, 3, 3> M;
  Eigen::Matrix<long long, 3, 1> t;  ///< in units of h
  long long n = 1, p = 2;

  double grid() const { return double(2 * n) * h; }
  double scale() const { return double(p) / 2; }
  Mat3d matrix() const { return scale() / double(n) * M.cast<double>(); }  ///< s Q, rounded in double
  Vec3d translation() const { return h * t.cast<double>(); }
};

/// A rigid GridMotion with no zero component of the quaternion and not all four of one magnitude (which
/// would make Q a signed permutation of the axes), and a translation of up to 2 per coordinate.
GridMotion random_grid_motion(std::mt19937_64& g) {
  std::uniform_int_distribution<long long> magnitude(1, 3), sign(0, 1);
  long long a, b, c, d;
  do {
    a = magnitude(g), b = magnitude(g), c = magnitude(g), d = magnitude(g);
  } while (a == b && b == c && c == d);
  b *= sign(g) ? 1 : -1, c *= sign(g) ? 1 : -1, d *= sign(g) ? 1 : -1;
  GridMotion mo;
  mo.n = a * a + b * b + c * c + d * d;
  mo.M << a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c),  //
      2 * (b * c + a * d), a * a - b * b + c * c - d * d, 2 * (c * d - a * b),      //
      2 * (b * d - a * c), 2 * (c * d + a * b), a * a - b * b - c * c + d * d;
  const Vec3d t = random_vector(g, -2, 2) / GridMotion::h;
  for (int i = 0; i < 3; ++i) mo.t[i] = std::llround(t[i]);
  return mo;
}

/// Every coordinate of x rounded to the nearest multiple of `grid` (exact in T while |x| / h is below 2^24).
template <class T>
void snap_to_grid(Points<T>& x, double grid) {
  for (Eigen::Index i = 0; i < x.rows(); ++i)
    for (int c = 0; c < 3; ++c) x(i, c) = T(std::nearbyint(double(x(i, c)) / grid) * grid);
}

/// The exact image of grid points under mo.
template <class T>
Points<T> apply(const GridMotion& mo, const Points<T>& x) {
  Points<T> y(x.rows(), 3);
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    Eigen::Matrix<long long, 3, 1> m;
    for (int c = 0; c < 3; ++c) {
      const double r = double(x(i, c)) / mo.grid();
      m[c] = std::llround(r);
      REQUIRE(double(m[c]) == r);  // on the grid
    }
    const Eigen::Matrix<long long, 3, 1> image = mo.p * (mo.M * m) + mo.t;
    for (int c = 0; c < 3; ++c) {
      REQUIRE(std::llabs(image[c]) < (1LL << std::numeric_limits<T>::digits));  // exact in T
      y(i, c) = T(double(image[c]) * GridMotion::h);
    }
  }
  return y;
}

template <class T>
Handles<T> apply(const GridMotion& mo, const Handles<T>& h) {
  return {apply(mo, h.points), apply(mo, h.segment_a), apply(mo, h.segment_b)};
}

}  // namespace

TEST_CASE("RBF centroids: g interpolates the handles and reproduces affine maps", "[rbf]") {
  std::mt19937_64 g(seed());
  for (int J : {1, 2, 3, 4, 7, 20}) {
    for (RbfKernel kernel : {RbfKernel::r, RbfKernel::r3}) {
      const std::vector<Vec3d> P = random_centres(g, J);
      const RbfCentroids rbf(P, kernel);
      const double kappa = double(kappa_of(P, kernel));
      INFO("J = " << J << ", kernel " << (kernel == RbfKernel::r ? "r" : "r^3") << ", kappa(M) = " << kappa);
      std::vector<double> beta;
      Eigen::VectorXd rhs;
      // Interpolation: beta(p_i) = e_i to the solve's accuracy, (J + 4) eps kappa(M) relative to sum |beta|.
      for (int i = 0; i < J; ++i) {
        rbf.weights(P[std::size_t(i)], beta, rhs);
        double B = 0;
        for (double x : beta) B += std::abs(x);
        for (int j = 0; j < J; ++j)
          CHECK(std::abs(beta[std::size_t(j)] - (i == j ? 1.0 : 0.0)) <=
                (J + 4) * std::numeric_limits<double>::epsilon() * kappa * B);
      }
      // Affine reproduction at points of the centres' convex hull (where p* lies): sum_j beta_j (A p_j + b) = A x + b.
      Mat3d A;
      for (int c = 0; c < 3; ++c) A.col(c) = random_vector(g);
      const Vec3d b = random_vector(g);
      for (int trial = 0; trial < 5; ++trial) {
        Vec3d x = Vec3d::Zero();
        double W = 0;
        for (int j = 0; j < J; ++j) {
          const double w = std::uniform_real_distribution<double>(0, 1)(g);
          x += w * P[std::size_t(j)], W += w;
        }
        x /= W;
        rbf.weights(x, beta, rhs);
        Vec3d q = Vec3d::Zero();
        double B = 0;
        for (int j = 0; j < J; ++j)
          q += beta[std::size_t(j)] * (A * P[std::size_t(j)] + b), B += std::abs(beta[std::size_t(j)]);
        const double scale = (A.norm() * 2 + b.norm()) * B;
        CHECK((q - (A * x + b)).norm() <= (J + 4) * std::numeric_limits<double>::epsilon() * kappa * scale * 4);
      }
    }
  }
}

TEST_CASE("RBF centroids: coincident handles share a centre, nearly coincident ones are refused", "[rbf]") {
  std::vector<Vec3d> P = {Vec3d(0, 0, 0), Vec3d(1, 0, 0), Vec3d(0, 1, 0), Vec3d(1, 0, 0)};
  const RbfCentroids rbf(P);
  std::vector<double> beta;
  Eigen::VectorXd rhs;
  rbf.weights(Vec3d(1, 0, 0), beta, rhs);
  CHECK(beta[3] == 0.0);  // the second handle at (1, 0, 0) gets no weight: the first one's target counts
  // Two centres d apart give two rows of M that differ by about d (phi is 1-Lipschitz at this scale for r,
  // 3-Lipschitz for r^3; the affine columns differ by d), against entries of order 1: rcond(M) is of order d,
  // so d = 1e-12 falls below the constructor's 1e-10 under either kernel (at d = 1e-9, r's rcond is above it).
  P.push_back(Vec3d(1e-12, 0, 0));
  for (const RbfKernel kernel : {RbfKernel::r, RbfKernel::r3})
    CHECK_THROWS_WITH(RbfCentroids(P, kernel), Catch::Contains("nearly coincident"));
}

TEMPLATE_TEST_CASE("RBF centroids in the deformer: identity, interpolation, affine maps reproduced", "[rbf][deformer]",
                   float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  const RbfKernel kernel = GENERATE(RbfKernel::r, RbfKernel::r3);
  const mlsdeform::detail::ScopedRbfKernel scoped(kernel);
  INFO("kernel " << (kernel == RbfKernel::r ? "r" : "r^3"));
  for (int trial = 0; trial < 3; ++trial) {
    const Scene<T> sc = random_scene<T>(g, 250, 6 + 2 * trial, 0);
    const Mat3d R = random_rotation(g);
    const Vec3d t = random_vector(g, -2, 2);
    Mat3d N;
    for (int c = 0; c < 3; ++c) N.col(c) = random_vector(g);
    for (Transform tr : all_transforms) {
      Options o;
      o.transform = tr;
      o.centroids = Centroids::rbf;
      const Deformer<T> def(sc.vertices, sc.rest, o);
      const Mat3d map = tr == Transform::affine ? Mat3d(R * (Mat3d::Identity() + 0.4 * N)) : R;
      for (const Mat3d& M : {Mat3d(Mat3d::Identity()), map}) {
        const Handles<T> moved = transformed(sc.rest, M, t * (M == Mat3d::Identity() ? 0.0 : 1.0));
        const Vec3d shift = M == Mat3d::Identity() ? Vec3d::Zero() : t;
        Points<T> out;
        def.deform(moved, out);
        INFO(name(tr) << " trial " << trial << "\n" << M);
        // Vertices on handles: exactly their targets.
        for (Eigen::Index i = 0; i < sc.rest.points.rows(); ++i)
          for (Eigen::Index v = 0; v < sc.vertices.rows(); ++v)
            if (sc.vertices.row(v) == sc.rest.points.row(i)) CHECK(out.row(v) == moved.points.row(i));
        const double extra =
            rbf_extra(sc, moved) + 8 * std::numeric_limits<double>::epsilon() * (M.norm() * 2 + shift.norm());
        const double l = scene_size(sc.vertices, sc.rest);
        for (Eigen::Index i = 0; i < sc.vertices.rows(); ++i) {
          const Vec3d v = sc.vertices.row(i).transpose().template cast<double>();
          const DirectVertex d = direct_vertex(v, sc.rest, moved, o, l);
          const double bound = std::numeric_limits<T>::epsilon() * d.bound_unit + extra;
          const double dev = (out.row(i).transpose().template cast<double>() - (M * v + shift)).norm();
          INFO("vertex " << i << " deviation " << dev << " bound " << bound);
          REQUIRE(dev <= bound);
        }
      }
    }
  }
}

TEMPLATE_TEST_CASE("RBF centroids: a rigid motion or similarity of the whole scene moves the result with it",
                   "[rbf][deformer]", float, double) {
  using T = TestType;
  constexpr double eps_t = std::numeric_limits<T>::epsilon(), eps_d = std::numeric_limits<double>::epsilon();
  std::mt19937_64 g(seed() + 3);
  INFO("seed " << seed());
  const RbfKernel kernel = GENERATE(RbfKernel::r, RbfKernel::r3);
  const mlsdeform::detail::ScopedRbfKernel scoped(kernel);
  INFO("kernel " << (kernel == RbfKernel::r ? "r" : "r^3"));
  double worst = 0, worst_on_handles = 0;
  for (int trial = 0; trial < 4; ++trial) {
    // Scene a: point handles (even trials) or points and segments (odd trials, paper_constant weights),
    // moved by a rigid motion plus noise, so that q* = g(p*) is not an affine map of p*; every coordinate on
    // the motion's grid, and a vertex on each point handle (interpolated exactly).
    GridMotion mo = random_grid_motion(g);
    const Eigen::Index k = trial % 2 ? 6 : 8, segments = trial % 2 ? 2 : 0;
    Scene<T> a = random_scene<T>(g, 200, k, segments);
    a.moved = transformed(a.rest, random_rotation(g), random_vector(g, -0.5, 0.5));
    for (Points<T>* m : {&a.moved.points, &a.moved.segment_a, &a.moved.segment_b})
      *m += T(0.3) * random_points<T>(g, m->rows());
    for (Points<T>* x : {&a.vertices, &a.rest.points, &a.rest.segment_a, &a.rest.segment_b, &a.moved.points,
                         &a.moved.segment_a, &a.moved.segment_b})
      snap_to_grid(*x, mo.grid());
    a.vertices.topRows(k) = a.rest.points;
    const double la = scene_size(a.vertices, a.rest), extra_a = rbf_extra(a, a.moved);
    for (const long long p : {2, 3}) {  // s = 1 (a rigid motion), s = 3/2 (a similarity)
      mo.p = p;
      Scene<T> b;  // scene a's exact image: vertices, rest handles and moved handles
      b.vertices = apply(mo, a.vertices);
      b.rest = apply(mo, a.rest);
      b.moved = apply(mo, a.moved);
      const Mat3d sQ = mo.matrix();
      const Vec3d t = mo.translation();
      const double s = mo.scale(), lb = scene_size(b.vertices, b.rest), extra_b = rbf_extra(b, b.moved);
      for (Transform tr : all_transforms) {
        INFO(name(tr) << " trial " << trial << (segments ? " (segments)" : "") << " s = " << s << "\n" << sQ);
        Options o;
        o.transform = tr;
        o.centroids = Centroids::rbf;
        Points<T> out_a, out_b;
        Deformer<T>(a.vertices, a.rest, o).deform(a.moved, out_a);
        Deformer<T>(b.vertices, b.rest, o).deform(b.moved, out_b);
        // Tolerance. The inputs of b are exactly the motion's image of a's, and every stage commutes with
        // x -> s Q x + t (distances scale by s, so the normalised weights, p*'s weights and beta do not
        // change; H and G become s^2 Q H Q^T and s^2 Q G Q^T, so R becomes Q R Q^T, mu and H G^-1 Q-conjugate;
        // q* and p* move with the motion): the exact results satisfy v'_b = s Q v'_a + t. The motion changes
        // only the rounding, and each computed result is within this file's bound of its exact one (the
        // direct evaluation's eps(T) bound_unit for the fit, rbf_extra for q* = g(p*)); the error of a is
        // scaled by s. The expected value s Q v'_a + t, evaluated in double, adds 8 eps(double) (s |v'_a| + |t|).
        for (Eigen::Index i = 0; i < a.vertices.rows(); ++i) {
          const Vec3d va = a.vertices.row(i).transpose().template cast<double>();
          const Vec3d vb = b.vertices.row(i).transpose().template cast<double>();
          const DirectVertex da = direct_vertex(va, a.rest, a.moved, o, la);
          const DirectVertex db = direct_vertex(vb, b.rest, b.moved, o, lb);
          REQUIRE(da.snapped == db.snapped);
          // A vertex on a point handle is interpolated: both results are the targets, exactly each other's image.
          if (!da.snapped) {  // the bound is first order: the fits must be well-posed at T's rounding
            REQUIRE((da.well_posed && db.well_posed));
            if (tr != Transform::affine)
              REQUIRE(((eps_t + eps_d) * da.dH_unit < da.gap / 2 && (eps_t + eps_d) * db.dH_unit < db.gap / 2));
          }
          const Vec3d ya = out_a.row(i).transpose().template cast<double>();
          const Vec3d yb = out_b.row(i).transpose().template cast<double>();
          const double fit = da.snapped ? 0.0 : s * (eps_t * da.bound_unit + extra_a) + eps_t * db.bound_unit + extra_b;
          const double tol = fit + 8 * eps_d * (s * ya.norm() + t.norm());
          const double dev = (yb - (sQ * ya + t)).norm();
          INFO("vertex " << i << " deviation " << dev << " tolerance " << tol);
          REQUIRE(dev <= tol);
          double& w = da.snapped ? worst_on_handles : worst;
          w = std::max(w, dev / tol);
        }
      }
    }
  }
  std::printf("[rbf] %s, kernel %s: whole-scene motion, max deviation / tolerance %.3g (vertices on handles %.3g)\n",
              type_name<T>(), kernel == RbfKernel::r ? "r" : "r^3", worst, worst_on_handles);
}

TEMPLATE_TEST_CASE("RBF centroids: SIMD agrees with scalar, threads bitwise, on-the-fly refused", "[rbf][deformer]",
                   float, double) {
  using T = TestType;
  std::mt19937_64 g(seed() + 1);
  const Scene<T> sc = random_scene<T>(g, 700, 9, 0);
  Handles<T> moved = sc.rest;
  moved.points.row(0).array() += T(0.8);  // a large move: where RBF and MLS centroids differ most
  Options o;
  o.centroids = Centroids::rbf;
  o.isa = Isa::scalar;
  Points<T> scalar, simd, mls, two;
  Deformer<T>(sc.vertices, sc.rest, o).deform(moved, scalar);
  o.isa = std::nullopt;
  o.threads = 1;
  Deformer<T>(sc.vertices, sc.rest, o).deform(moved, simd);
  o.threads = 2;
  Deformer<T>(sc.vertices, sc.rest, o).deform(moved, two);
  CHECK(std::memcmp(simd.data(), two.data(), sizeof(T) * std::size_t(simd.size())) == 0);
  // q* is the same sum in both paths; the rotations differ as in the SIMD deformer test (256 eps there,
  // derived in tests/test_deformer_simd.cpp).
  CHECK((simd - scalar).cwiseAbs().maxCoeff() <= T(256) * std::numeric_limits<T>::epsilon());
  o.centroids = Centroids::mls;
  Deformer<T>(sc.vertices, sc.rest, o).deform(moved, mls);
  CHECK((simd - mls).cwiseAbs().maxCoeff() > T(1e-3));  // the option changes the result
  o.centroids = Centroids::rbf;
  o.weight_storage = WeightStorage::on_the_fly;
  CHECK_THROWS_WITH(Deformer<T>(sc.vertices, sc.rest, o), Catch::Contains("Centroids::rbf"));
}

TEST_CASE("RBF centroids: a Deformer takes the kernel set when it is constructed", "[rbf][deformer]") {
  std::mt19937_64 g(seed() + 2);
  const Scene<double> sc = random_scene<double>(g, 300, 7, 0);
  Handles<double> moved = sc.rest;
  moved.points.row(0).array() += 0.8;
  Options o;
  o.centroids = Centroids::rbf;
  const RbfKernel before = mlsdeform::detail::rbf_kernel();
  CHECK(before == RbfKernel::r);  // the library's kernel (rbf_centroids.cpp)
  Points<double> r, r3, again;
  Deformer<double>(sc.vertices, sc.rest, o).deform(moved, r);
  {
    const mlsdeform::detail::ScopedRbfKernel scoped(RbfKernel::r3);
    const Deformer<double> d(sc.vertices, sc.rest, o);
    mlsdeform::detail::set_rbf_kernel(RbfKernel::r);  // read at construction only: d keeps r^3
    d.deform(moved, r3);
  }
  CHECK(mlsdeform::detail::rbf_kernel() == before);
  Deformer<double>(sc.vertices, sc.rest, o).deform(moved, again);
  CHECK((r - r3).cwiseAbs().maxCoeff() > 1e-3);  // the kernels give different q*
  CHECK(std::memcmp(again.data(), r.data(), sizeof(double) * std::size_t(r.size())) == 0);
}
