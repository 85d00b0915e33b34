// See rotation_cases.hpp.
#include "tests/support/rotation_cases.hpp"

#include <Eigen/LU>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <stdexcept>
#include <string>

namespace mlsdeform::testing {

// ---------------------------------------------------------------------------------------------------------
// Reference
// ---------------------------------------------------------------------------------------------------------

Reference reference(const Matrix3L& H) {
  Reference ref;
  ref.norm = H.norm();
  const long double det = H.determinant();
  ref.sign_det = det > 0 ? 1 : (det < 0 ? -1 : 0);
  if (ref.norm == 0) {  // every rotation attains the optimum 0
    ref.kappa = std::numeric_limits<long double>::infinity();
    return ref;
  }
  Eigen::JacobiSVD<Matrix3L> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Matrix3L U = svd.matrixU(), V = svd.matrixV();
  ref.singular = svd.singularValues();
  ref.d = (U * V.transpose()).determinant() < 0 ? -1 : 1;
  ref.rotation = U * Vector3L(1, 1, static_cast<long double>(ref.d)).asDiagonal() * V.transpose();
  const long double s1 = ref.singular(0), s2 = ref.singular(1), s3 = ref.singular(2);
  ref.optimum = s1 + s2 + ref.d * s3;
  const long double gap = s2 + ref.d * s3;
  ref.kappa = gap > 0 ? s1 / gap : std::numeric_limits<long double>::infinity();
  return ref;
}

long double rotation_angle(const Matrix3L& A, const Matrix3L& B) {
  // For rotations, ||A - B||_F^2 = 2 trace(I - A^T B) = 4 (1 - cos t) = 8 sin^2(t / 2).
  const long double x = (A - B).norm() / std::sqrt(8.0L);
  return 2 * std::asin(std::min(1.0L, x));
}

template <class T>
Errors measure(const Matrix3<T>& R, const Matrix3<T>& H, const Reference& ref) {
  Errors e;
  e.finite = R.allFinite();
  if (!e.finite) {
    const long double nan = std::numeric_limits<long double>::quiet_NaN();
    e.orthonormality = e.det_error = e.trace_loss = e.angle = nan;
    return e;
  }
  const Matrix3L Rl = R.template cast<long double>(), Hl = H.template cast<long double>();
  e.orthonormality = (Rl.transpose() * Rl - Matrix3L::Identity()).cwiseAbs().maxCoeff();
  e.det_error = std::abs(Rl.determinant() - 1);
  e.trace_loss = ref.norm > 0 ? (ref.optimum - (Rl.transpose() * Hl).trace()) / ref.norm : 0.0L;
  e.angle = rotation_angle(Rl, ref.rotation);
  return e;
}

template Errors measure<float>(const Matrix3<float>&, const Matrix3<float>&, const Reference&);
template Errors measure<double>(const Matrix3<double>&, const Matrix3<double>&, const Reference&);

Matrix3L axis_angle_rotation(const Vector3L& axis, long double angle) {
  Matrix3L K;
  K << 0, -axis(2), axis(1), axis(2), 0, -axis(0), -axis(1), axis(0), 0;
  // Rodrigues: I + sin(a) K + (1 - cos(a)) K^2, with 1 - cos(a) = 2 sin^2(a / 2) (no cancellation).
  const long double h = std::sin(angle / 2);
  return Matrix3L::Identity() + std::sin(angle) * K + 2 * h * h * (K * K);
}

// ---------------------------------------------------------------------------------------------------------
// Families
// ---------------------------------------------------------------------------------------------------------

namespace {

constexpr FamilyInfo kFamilies[] = {
    {Family::uniform, "uniform",
     "R uniform on SO(3); 3..300 points (log-uniform), weights uniform in (0, 1], no noise"},
    {Family::noise_1e_6, "noise_1e-6", "as uniform, Gaussian noise of 1e-6 of the point spread on q"},
    {Family::noise_1e_2, "noise_1e-2", "as uniform, noise 1e-2 of the point spread"},
    {Family::noise_1e_1, "noise_1e-1", "as uniform, noise 1e-1 of the point spread"},
    {Family::near_pi, "near_pi", "rotation angle uniform in [pi - 1e-3, pi], random axis, no noise"},
    {Family::exactly_pi, "exactly_pi", "half-turn about a random axis (exact in long double), no noise"},
    {Family::small_angle, "small_angle", "rotation angle uniform in [0, 1e-6], random axis, no noise"},
    {Family::three_points, "three_points", "exactly 3 points (H of rank <= 2), uniform rotation, no noise"},
    {Family::wide_weights, "wide_weights", "weights log-uniform in [1e-6, 1e6], uniform rotation, noise 1e-2"},
    {Family::collinear, "collinear", "collinear points: rank-1 H, the optimum is not unique"},
    {Family::coplanar, "coplanar", "coplanar points: rank-2 H, uniform rotation, no noise"},
    {Family::reflected, "reflected", "mirrored data q = R (I - 2 n n^T) p: det H < 0"},
    {Family::zero, "zero", "H = 0"},
    {Family::identity, "identity", "H = c I, c log-uniform in [1e-3, 1e3]"},
    {Family::exact_rotation, "exact_rotation", "H = R, R uniform on SO(3) (all singular values 1)"},
    {Family::repeated_sv, "repeated_sv",
     "H = U diag(s, s, t) V^T, U diag(s, t, t) V^T or U diag(s, s, s) V^T, det of either sign"},
    {Family::gaussian, "gaussian", "entries iid N(0, 1): generic H, det of either sign"},
    {Family::scaled, "scaled", "a uniform-family H times 10^u, u uniform in [-15, 15] (float), [-100, 100] (double)"},
    {Family::wide_exponents, "wide_exponents",
     "entries of random sign, significand and binary exponent over T's finite range, subnormals included"},
};

using PointsL = Eigen::Matrix<long double, Eigen::Dynamic, 3>;
using VectorL = Eigen::Matrix<long double, Eigen::Dynamic, 1>;

std::uint64_t case_state(Family family, std::uint64_t seed, std::uint64_t index) {
  std::uint64_t s = seed;
  std::uint64_t h = splitmix64(s);
  s = h ^ (static_cast<std::uint64_t>(family) + 1) * 0xD1B54A32D192ED03ull;
  h = splitmix64(s);
  s = h ^ index;
  return splitmix64(s);
}

/// Log-uniform number of points in [3, 300]: small sets (the degenerate-prone ones) are as frequent as
/// large ones per decade, and the mean stays near 65 so that 10^7 cases remain affordable.
int point_count(Rng& rng) {
  return std::clamp(static_cast<int>(std::floor(std::exp(rng.uniform(std::log(3.0L), std::log(301.0L))))), 3, 300);
}

/// n points p_i = Q diag(1, a2, a3) g_i + c (g_i standard normal): an anisotropic cloud, randomly turned
/// and offset. `dims` = 1 (a line), 2 (a plane) or 3.
PointsL cloud(Rng& rng, int n, int dims) {
  const Matrix3L Q = rng.rotation();
  const Vector3L a(1, dims >= 2 ? rng.uniform(0.2L, 1) : 0, dims >= 3 ? rng.uniform(0.2L, 1) : 0);
  const Vector3L c(5 * rng.gaussian(), 5 * rng.gaussian(), 5 * rng.gaussian());
  PointsL p(n, 3);
  for (int i = 0; i < n; ++i) {
    const Vector3L g(rng.gaussian(), rng.gaussian(), rng.gaussian());
    p.row(i) = (Q * a.cwiseProduct(g) + c).transpose();
  }
  return p;
}

struct PointCase {
  Matrix3L H;
  Matrix3L generator;
  int n;
};

/// Moves `p` by `R` (and a translation), adds Gaussian noise of `noise` times the spread of p, returns H.
PointCase moved_points(Rng& rng, const PointsL& p, const VectorL& w, const Matrix3L& R, long double noise) {
  const Eigen::Index n = p.rows();
  const Vector3L t(10 * rng.gaussian(), 10 * rng.gaussian(), 10 * rng.gaussian());
  PointsL q = (p * R.transpose()).rowwise() + t.transpose();
  if (noise > 0) {
    const Vector3L p_star = (p.transpose() * w) / w.sum();
    const long double spread =
        std::sqrt(((p.rowwise() - p_star.transpose()).rowwise().squaredNorm().transpose() * w)(0) / w.sum());
    for (Eigen::Index i = 0; i < n; ++i)
      for (int k = 0; k < 3; ++k) q(i, k) += noise * spread * rng.gaussian();
  }
  return {correlation_matrix(p, q, w), R, static_cast<int>(n)};
}

VectorL uniform_weights(Rng& rng, int n) {
  VectorL w(n);
  for (int i = 0; i < n; ++i) w(i) = 1 - rng.uniform();  // (0, 1]
  return w;
}

/// The point families: a cloud of `dims` dimensions moved by R with noise.
PointCase point_family(Rng& rng, Family family) {
  int n = point_count(rng);
  int dims = 3;
  long double noise = 0;
  Matrix3L R = rng.rotation();
  bool wide = false, mirror = false;
  switch (family) {
    case Family::noise_1e_6:
      noise = 1e-6L;
      break;
    case Family::noise_1e_2:
      noise = 1e-2L;
      break;
    case Family::noise_1e_1:
      noise = 1e-1L;
      break;
    case Family::near_pi:
      R = axis_angle_rotation(rng.unit_vector(), std::numbers::pi_v<long double> - rng.uniform(0, 1e-3L));
      break;
    case Family::exactly_pi:
      R = axis_angle_rotation(rng.unit_vector(), std::numbers::pi_v<long double>);
      break;
    case Family::small_angle:
      R = axis_angle_rotation(rng.unit_vector(), rng.uniform(0, 1e-6L));
      break;
    case Family::three_points:
      n = 3;
      break;
    case Family::wide_weights:
      wide = true;
      noise = 1e-2L;
      break;
    case Family::collinear:
      dims = 1;
      break;
    case Family::coplanar:
      dims = 2;
      break;
    case Family::reflected:
      mirror = true;
      break;
    default:
      break;
  }
  const PointsL p = cloud(rng, n, dims);
  VectorL w = uniform_weights(rng, n);
  if (wide)
    for (int i = 0; i < n; ++i) w(i) = std::pow(10.0L, rng.uniform(-6, 6));
  Matrix3L M = R;
  if (mirror) {
    const Vector3L m = rng.unit_vector();
    M = R * (Matrix3L::Identity() - 2 * m * m.transpose());
  }
  PointCase pc = moved_points(rng, p, w, M, noise);
  pc.generator = R;
  return pc;
}

template <class T>
Matrix3L wide_exponent_matrix(Rng& rng) {
  // Binary exponents from below the smallest normal (subnormals) to 2^(max_exponent - 3), so that
  // ||H||_F <= 3 * 2^(max_exponent - 2) stays finite.
  const int lo = std::numeric_limits<T>::min_exponent - std::numeric_limits<T>::digits / 2;
  const int hi = std::numeric_limits<T>::max_exponent - 3;
  Matrix3L H;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const long double m = rng.uniform(1, 2) * (rng.next() & 1 ? 1 : -1);
      H(i, j) = std::ldexp(m, rng.integer(lo, hi - 1));
    }
  // One entry in six is zero, so that sparse patterns (single entries, zero rows) come up too.
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (rng.integer(0, 5) == 0) H(i, j) = 0;
  return H;
}

}  // namespace

std::span<const FamilyInfo> all_families() { return kFamilies; }

std::string_view to_string(Family family) { return kFamilies[static_cast<int>(family)].name; }

Family family_from_string(std::string_view name) {
  for (const FamilyInfo& f : kFamilies)
    if (f.name == name) return f.family;
  throw std::invalid_argument("unknown case family '" + std::string(name) + "'");
}

Matrix3L correlation_matrix(const PointsL& p, const PointsL& q, const VectorL& w) {
  const long double sw = w.sum();
  const Vector3L p_star = (p.transpose() * w) / sw, q_star = (q.transpose() * w) / sw;
  Matrix3L H = Matrix3L::Zero();
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    H += w(i) * (q.row(i).transpose() - q_star) * (p.row(i).transpose() - p_star).transpose();
  return H;
}

template <class T>
Case<T> make_case(Family family, std::uint64_t seed, std::uint64_t index) {
  Case<T> c;
  c.family = family;
  c.seed = seed;
  c.index = index;
  Rng rng(case_state(family, seed, index));
  switch (family) {
    case Family::uniform:
    case Family::noise_1e_6:
    case Family::noise_1e_2:
    case Family::noise_1e_1:
    case Family::near_pi:
    case Family::exactly_pi:
    case Family::small_angle:
    case Family::three_points:
    case Family::wide_weights:
    case Family::collinear:
    case Family::coplanar:
    case Family::reflected: {
      const PointCase pc = point_family(rng, family);
      c.H_exact = pc.H;
      c.generator = pc.generator;
      c.points = pc.n;
      c.noise = family == Family::noise_1e_6     ? 1e-6L
                : family == Family::noise_1e_2   ? 1e-2L
                : family == Family::noise_1e_1   ? 1e-1L
                : family == Family::wide_weights ? 1e-2L
                                                 : 0.0L;
      break;
    }
    case Family::zero:
      c.H_exact.setZero();
      break;
    case Family::identity:
      c.H_exact = std::pow(10.0L, rng.uniform(-3, 3)) * Matrix3L::Identity();
      break;
    case Family::exact_rotation:
      c.generator = rng.rotation();
      c.H_exact = c.generator;
      break;
    case Family::repeated_sv: {
      const long double s = rng.uniform(0.1L, 1), t = rng.uniform(0.1L, 1);
      const int pattern = rng.integer(0, 2);
      const Vector3L sv = pattern == 0 ? Vector3L(s, s, t) : pattern == 1 ? Vector3L(s, t, t) : Vector3L(s, s, s);
      Matrix3L V = rng.rotation();
      if (rng.next() & 1) V.col(2) = -V.col(2);  // det H < 0
      c.H_exact = rng.rotation() * sv.asDiagonal() * V.transpose();
      break;
    }
    case Family::gaussian:
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) c.H_exact(i, j) = rng.gaussian();
      break;
    case Family::scaled: {
      const Case<T> base = make_case<T>(Family::uniform, seed, index);
      const long double range = std::is_same_v<T, float> ? 15 : 100;
      c.H_exact = std::pow(10.0L, rng.uniform(-range, range)) * base.H_exact;
      c.generator = base.generator;
      c.points = base.points;
      break;
    }
    case Family::wide_exponents:
      c.H_exact = wide_exponent_matrix<T>(rng);
      break;
  }
  c.H = c.H_exact.template cast<T>();
  return c;
}

template Case<float> make_case<float>(Family, std::uint64_t, std::uint64_t);
template Case<double> make_case<double>(Family, std::uint64_t, std::uint64_t);

template <class T>
std::string hex(const Matrix3<T>& H) {
  std::string s;
  char buf[64];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      std::snprintf(buf, sizeof buf, "%a%s", static_cast<double>(H(i, j)), i == 2 && j == 2 ? "" : ", ");
      s += buf;
    }
  return s;
}

template std::string hex<float>(const Matrix3<float>&);
template std::string hex<double>(const Matrix3<double>&);

template <class T>
std::string describe(const Case<T>& c) {
  return std::string(to_string(c.family)) + " seed=" + std::to_string(c.seed) + " index=" + std::to_string(c.index) +
         " points=" + std::to_string(c.points) + " H=[" + hex(c.H) + "]";
}

template std::string describe<float>(const Case<float>&);
template std::string describe<double>(const Case<double>&);

std::uint64_t env_u64(const char* name, std::uint64_t fallback) {
  const char* v = std::getenv(name);
  if (v == nullptr || *v == '\0') return fallback;
  char* end = nullptr;
  const unsigned long long x = std::strtoull(v, &end, 0);
  if (end == v || *end != '\0' || v[0] == '-')
    throw std::invalid_argument(std::string(name) + "='" + v + "' is not an unsigned integer");
  return x;
}

}  // namespace mlsdeform::testing
