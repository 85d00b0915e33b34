// The splats' motion (mlsdeform/splats.hpp): validation of every input first (nothing is written on bad input),
// then each splat on its own, in double, rounded once to T.
#include "core/src/parallel.hpp"
#include "core/src/splats/covariance.hpp"
#include "core/src/splats/sh_rotation.hpp"

#include <mlsdeform/splats.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace mlsdeform {

namespace {

// Splats per parallel task: a splat costs about 2,000 flops (its SH rotation), so 512 amortise scheduling.
constexpr std::size_t kChunk = 512;

[[noreturn]] void fail(const char* function, std::size_t i, const std::string& what) {
  throw std::invalid_argument(std::string(function) + ": splat " + std::to_string(i) + ": " + what);
}

template <class T>
bool finite(const T* x, int count) {
  for (int j = 0; j < count; ++j)
    if (!std::isfinite(x[j])) return false;
  return true;
}

/// The checks both motions share: the splat arrays' values.
template <class T>
void validate_splat(const char* function, const SplatArrays<T>& s, std::size_t i, int sh_count) {
  if (s.rotations) {
    const T* q = s.rotations + 4 * i;
    if (!finite(q, 4)) fail(function, i, "rotation (rot_*) is NaN or infinite");
    if (q[0] == 0 && q[1] == 0 && q[2] == 0 && q[3] == 0) fail(function, i, "rotation (rot_*) is zero");
  }
  if (s.log_scales && !finite(s.log_scales + 3 * i, 3)) fail(function, i, "log scale (scale_*) is NaN or infinite");
  if (s.sh_rest) {
    const T* c = s.sh_rest + std::size_t(sh_count) * i;
    if (!finite(c, sh_count)) fail(function, i, "SH coefficient (f_rest_*) is NaN or infinite");
    // A rotated coefficient is bounded by its band's norm (<= sqrt(7) max|c|) and the intermediates by a few
    // times that: within max(T) / 64 nothing overflows.
    for (int j = 0; j < sh_count; ++j)
      if (std::abs(c[j]) > std::numeric_limits<T>::max() / 64)
        fail(function, i, "SH coefficient (f_rest_*) " + std::to_string(double(c[j])) + " is too large to rotate");
  }
}

template <class T>
int checked_sh_count(const char* function, const SplatArrays<T>& s) {
  if (s.sh_degree < 0 || s.sh_degree > 3)
    throw std::invalid_argument(std::string(function) + ": sh_degree " + std::to_string(s.sh_degree) +
                                " is not 0, 1, 2 or 3");
  return splat_sh_rest_count(s.sh_degree);
}

/// The unit quaternion's length tolerance: a rotation fitted or normalised in T is off by a few epsilon; one
/// off by more than sqrt(epsilon) is not rounding but another quantity (unnormalised, or not a quaternion).
template <class T>
double unit_tolerance() {
  return std::sqrt(double(std::numeric_limits<T>::epsilon()));
}

template <class T>
void validate_rotate(const SplatArrays<T>& s, std::size_t n, const T* quaternions, const T* scales) {
  constexpr const char* f = "rotate_splats";
  const int sh_count = checked_sh_count(f, s);
  if (n > 0 && !quaternions) throw std::invalid_argument("rotate_splats: quaternions is null");
  for (std::size_t i = 0; i < n; ++i) {
    const T* q = quaternions + 4 * i;
    if (!finite(q, 4)) fail(f, i, "transform quaternion is NaN or infinite");
    const double length =
        std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3]);
    if (!(std::abs(length - 1) <= unit_tolerance<T>()))
      fail(f, i, "transform quaternion is not a unit quaternion (length " + std::to_string(length) + ")");
    if (scales && !(std::isfinite(scales[i]) && scales[i] > 0))
      fail(f, i, "scale " + std::to_string(double(scales[i])) + " is not finite and positive");
    validate_splat(f, s, i, sh_count);
  }
}

template <class T>
void validate_affine(const SplatArrays<T>& s, std::size_t n, const T* linear) {
  constexpr const char* f = "transform_splats_affine";
  const int sh_count = checked_sh_count(f, s);
  if (n > 0 && !linear) throw std::invalid_argument("transform_splats_affine: linear is null");
  if (!s.rotations != !s.log_scales)
    throw std::invalid_argument(
        "transform_splats_affine: rotations and log_scales are both needed (or neither): "
        "the covariance is decomposed again into both");
  for (std::size_t i = 0; i < n; ++i) {
    const T* m = linear + 9 * i;
    if (!finite(m, 9)) fail(f, i, "linear part is NaN or infinite");
    if (detail::determinant(detail::to_double(m)) == 0) fail(f, i, "linear part is singular (determinant 0)");
    // Sigma' = A A^T with |A_ij| <= max|M| exp(max log scale): within 1e150 it stays finite in double.
    if (s.log_scales) {
      double largest = 0, extent = 0;
      for (int j = 0; j < 9; ++j) largest = std::max(largest, std::abs(double(m[j])));
      for (int k = 0; k < 3; ++k) extent = std::max(extent, double(s.log_scales[3 * i + std::size_t(k)]));
      if (std::isfinite(extent) && !(largest * std::exp(extent) <= 1e150))
        fail(f, i, "linear part times the splat's extent overflows (max |M| exp(scale) > 1e150)");
    }
    validate_splat(f, s, i, sh_count);
  }
}

template <class T>
void store_quaternion(T* out, const std::array<double, 4>& q) {
  const double length = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  for (int j = 0; j < 4; ++j) out[j] = T(q[std::size_t(j)] / length);
}

template <class T>
std::array<double, 4> load_quaternion(const T* q) {
  return {double(q[0]), double(q[1]), double(q[2]), double(q[3])};
}

template <class T>
void rotate_one(const SplatArrays<T>& s, std::size_t i, const T* quaternions, const T* scales, int sh_count) {
  const T* t = quaternions + 4 * i;
  const bool turns = !(std::abs(t[0]) == 1 && t[1] == 0 && t[2] == 0 && t[3] == 0);
  const bool grows = scales && scales[i] != 1;
  if (!turns && !grows) return;  // the identity keeps every bit
  const std::array<double, 4> q_r = detail::normalised(load_quaternion(t));
  if (turns && s.rotations)
    store_quaternion(s.rotations + 4 * i, detail::product(q_r, load_quaternion(s.rotations + 4 * i)));
  if (grows && s.log_scales) {
    const double offset = std::log(double(scales[i]));
    for (int j = 0; j < 3; ++j) s.log_scales[3 * i + j] = T(double(s.log_scales[3 * i + j]) + offset);
  }
  if (turns && s.sh_rest) {
    const detail::Matrix3 R = detail::rotation_matrix(q_r);
    detail::rotate_sh(s.sh_rest + std::size_t(sh_count) * i, s.sh_degree, R.data(), false);
  }
}

template <class T>
void affine_one(const SplatArrays<T>& s, std::size_t i, const T* linear, int sh_count) {
  const T* m = linear + 9 * i;
  bool identity = true;
  for (int j = 0; j < 9; ++j) identity = identity && m[j] == (j % 4 == 0 ? 1 : 0);
  if (identity) return;
  const detail::Matrix3 M = detail::to_double(m);
  if (s.rotations) {
    const detail::Decomposed d = detail::transform_covariance(
        M, load_quaternion(s.rotations + 4 * i),
        {double(s.log_scales[3 * i]), double(s.log_scales[3 * i + 1]), double(s.log_scales[3 * i + 2])});
    store_quaternion(s.rotations + 4 * i, d.rotation);
    for (int j = 0; j < 3; ++j) s.log_scales[3 * i + j] = T(d.log_scales[std::size_t(j)]);
  }
  if (s.sh_rest) {
    const detail::Polar p = detail::polar_rotation(M);
    detail::rotate_sh(s.sh_rest + std::size_t(sh_count) * i, s.sh_degree, p.rotation.data(), p.mirror);
  }
}

template <class F>
void for_each_splat(std::size_t n, int threads, const F& f) {
  const auto arena = detail::make_arena(threads);
  detail::parallel_ranges((n + kChunk - 1) / kChunk, threads, arena.get(), [&](std::size_t c0, std::size_t c1) {
    const std::size_t end = std::min(n, c1 * kChunk);
    for (std::size_t i = c0 * kChunk; i < end; ++i) f(i);
  });
}

}  // namespace

int splat_sh_rest_count(int sh_degree) {
  if (sh_degree < 0 || sh_degree > 3)
    throw std::invalid_argument("splat_sh_rest_count: degree " + std::to_string(sh_degree) + " is not 0, 1, 2 or 3");
  return 3 * ((sh_degree + 1) * (sh_degree + 1) - 1);
}

int splat_sh_degree_of(int count) {
  for (int degree = 0; degree <= 3; ++degree)
    if (splat_sh_rest_count(degree) == count) return degree;
  return -1;
}

template <class T>
void rotate_splats(const SplatArrays<T>& splats, std::size_t n, const T* quaternions, const T* scales, int threads) {
  validate_rotate(splats, n, quaternions, scales);
  const int sh_count = splat_sh_rest_count(splats.sh_degree);
  for_each_splat(n, threads, [&](std::size_t i) { rotate_one(splats, i, quaternions, scales, sh_count); });
}

template <class T>
void transform_splats_affine(const SplatArrays<T>& splats, std::size_t n, const T* linear, int threads) {
  validate_affine(splats, n, linear);
  const int sh_count = splat_sh_rest_count(splats.sh_degree);
  for_each_splat(n, threads, [&](std::size_t i) { affine_one(splats, i, linear, sh_count); });
}

template void rotate_splats<float>(const SplatArrays<float>&, std::size_t, const float*, const float*, int);
template void rotate_splats<double>(const SplatArrays<double>&, std::size_t, const double*, const double*, int);
template void transform_splats_affine<float>(const SplatArrays<float>&, std::size_t, const float*, int);
template void transform_splats_affine<double>(const SplatArrays<double>&, std::size_t, const double*, int);

}  // namespace mlsdeform
