// Frames (mlsdeform/frames.hpp): the session's checks and moves of a FramesOut (core/src/frames.hpp), and the
// public helpers that carry normals and tangents through per-vertex linear parts.
#include "core/src/frames.hpp"

#include "kernels/deformer/stages.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace mlsdeform {

namespace {

/// Scales v (3 values) to unit length, first by a power of two to its largest component (exact), so that
/// neither the squares overflow nor underflow; false, v unchanged, where v is zero or not finite.
template <class T>
bool normalise3(T* v) {
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(v[i])) return false;  // NaN too (std::max would pass over it)
  const T m = std::max({std::abs(v[0]), std::abs(v[1]), std::abs(v[2])});
  if (!(m > T(0))) return false;
  const int e = std::ilogb(m);
  T s[3];
  for (int i = 0; i < 3; ++i) s[i] = std::ldexp(v[i], -e);
  const T len = std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
  for (int i = 0; i < 3; ++i) v[i] = s[i] / len;
  return true;
}

/// L (row-major) times 2^-e, e the exponent of its largest entry: cof(L) and det(L) then neither overflow nor
/// underflow, and both only change by positive powers of two (directions and signs kept). False where L is
/// zero or not finite.
template <class T>
bool scaled_linear(const T* linear, T (&L)[9]) {
  T m = 0;
  for (int i = 0; i < 9; ++i) {
    if (!std::isfinite(linear[i])) return false;  // NaN too (std::max would pass over it)
    m = std::max(m, std::abs(linear[i]));
  }
  if (!(m > T(0))) return false;
  const int e = std::ilogb(m);
  for (int i = 0; i < 9; ++i) L[i] = std::ldexp(linear[i], -e);
  return true;
}

/// True where L (row-major) is exactly the identity: the vertex did not move (outside a region, at rest), and its
/// normal or tangent is kept as it is, bit for bit (not renormalised).
template <class T>
bool is_identity(const T* L) {
  for (int i = 0; i < 9; ++i)
    if (L[i] != T(i % 4 == 0 ? 1 : 0)) return false;
  return true;
}

template <class T>
void cross(const T* a, const T* b, T* c) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}

/// Throws unless linear has 9 n values and data / out `width` n each, and data's first three of each row are
/// finite.
template <class T>
void check_carried(const char* fn, std::span<const T> linear, std::span<const T> data, std::span<T> out,
                   std::size_t width) {
  const std::size_t n = data.size() / width;
  const std::string what = width == 3 ? "normals" : "tangents";
  if (data.size() != width * n || out.size() != data.size() || linear.size() != 9 * n)
    throw std::invalid_argument(std::string(fn) + ": " + what + " have " + std::to_string(data.size()) +
                                " values, out " + std::to_string(out.size()) + " and linear " +
                                std::to_string(linear.size()) + ": expected " + std::to_string(width) +
                                " per vertex in both and 9 in linear");
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t c = 0; c < width; ++c)
      if (!std::isfinite(data[width * i + c]))
        throw std::invalid_argument(std::string(fn) + ": " + what + " row " + std::to_string(i) + " is not finite");
}

}  // namespace

template <class T>
void transform_normals(std::span<const T> linear, std::span<const T> normals, std::span<T> out) {
  check_carried("transform_normals", linear, normals, out, 3);
  const std::size_t n = normals.size() / 3;
  for (std::size_t i = 0; i < n; ++i) {
    const T nin[3] = {normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]};
    if (is_identity(linear.data() + 9 * i)) {
      for (int r = 0; r < 3; ++r) out[3 * i + std::size_t(r)] = nin[r];
      continue;
    }
    T v[3] = {nin[0], nin[1], nin[2]}, L[9];
    if (scaled_linear(linear.data() + 9 * i, L)) {
      // cof(L) has the rows b x c, c x a, a x b of L's rows a, b, c; det L = a . (b x c).
      T cof[9];
      cross(L + 3, L + 6, cof);
      cross(L + 6, L, cof + 3);
      cross(L, L + 3, cof + 6);
      const T det = L[0] * cof[0] + L[1] * cof[1] + L[2] * cof[2];
      const T sign = det < T(0) ? T(-1) : T(1);
      for (int r = 0; r < 3; ++r)
        v[r] = sign * (cof[3 * r] * nin[0] + cof[3 * r + 1] * nin[1] + cof[3 * r + 2] * nin[2]);
    }
    if (!normalise3(v)) {
      for (int r = 0; r < 3; ++r) v[r] = nin[r];
      normalise3(v);  // a zero normal stays zero
    }
    for (int r = 0; r < 3; ++r) out[3 * i + std::size_t(r)] = v[r];
  }
}

template <class T>
void transform_tangents(std::span<const T> linear, std::span<const T> tangents, std::span<T> out) {
  check_carried("transform_tangents", linear, tangents, out, 4);
  const std::size_t n = tangents.size() / 4;
  for (std::size_t i = 0; i < n; ++i) {
    const T tin[4] = {tangents[4 * i], tangents[4 * i + 1], tangents[4 * i + 2], tangents[4 * i + 3]};
    if (is_identity(linear.data() + 9 * i)) {
      for (int r = 0; r < 4; ++r) out[4 * i + std::size_t(r)] = tin[r];
      continue;
    }
    T v[3] = {tin[0], tin[1], tin[2]}, L[9];
    T w = tin[3];
    if (scaled_linear(linear.data() + 9 * i, L)) {
      for (int r = 0; r < 3; ++r) v[r] = L[3 * r] * tin[0] + L[3 * r + 1] * tin[1] + L[3 * r + 2] * tin[2];
      T bc[3];
      cross(L + 3, L + 6, bc);
      if (L[0] * bc[0] + L[1] * bc[1] + L[2] * bc[2] < T(0)) w = -w;
    }
    if (!normalise3(v)) {
      for (int r = 0; r < 3; ++r) v[r] = tin[r];
      normalise3(v);
      w = tin[3];
    }
    for (int r = 0; r < 3; ++r) out[4 * i + std::size_t(r)] = v[r];
    out[4 * i + 3] = w;
  }
}

template void transform_normals<float>(std::span<const float>, std::span<const float>, std::span<float>);
template void transform_normals<double>(std::span<const double>, std::span<const double>, std::span<double>);
template void transform_tangents<float>(std::span<const float>, std::span<const float>, std::span<float>);
template void transform_tangents<double>(std::span<const double>, std::span<const double>, std::span<double>);

namespace detail {

template <class T>
void check_frames(const FramesOut<T>& frames, std::size_t n, Transform transform, bool affine_frames) {
  const auto check = [&](std::span<T> s, std::size_t width, const char* name, bool affine_has_it = false) {
    if (s.empty()) return;
    if (s.size() != width * n)
      throw std::invalid_argument(std::string("Deformer: frames.") + name + " has " + std::to_string(s.size()) +
                                  " values but the model's " + std::to_string(n) + " vertices need " +
                                  std::to_string(width * n) + " (" + std::to_string(width) + " per vertex)");
    if (transform == Transform::affine && !affine_has_it)
      throw std::invalid_argument(std::string("Deformer: frames.") + name +
                                  " is not available for Transform::affine (an affine session computes no "
                                  "rotation: frames.linear gives its matrix, whose polar decomposition is the "
                                  "caller's choice)");
  };
  check(frames.quaternions, 4, "quaternions");
  check(frames.rotations, 9, "rotations");
  check(frames.scales, 1, "scales");
  check(frames.linear, 9, "linear", true);
  if (!frames.linear.empty() && transform == Transform::affine && !affine_frames)
    throw std::invalid_argument(
        "Deformer: frames.linear of a Transform::affine session needs "
        "Options::affine_frames = true when it is built (the affine fit's matrix takes a "
        "table 3 times alpha's, kept only on request)");
}

template <class T>
void scatter_frames(const FramesOut<T>& frames, const std::vector<Eigen::Index>& inside) {
  const auto scatter = [&](std::span<T> s, std::size_t width, const T* identity) {
    if (s.empty()) return;
    const std::size_t n = s.size() / width;
    std::size_t next = n;  // rows from `next` on are done
    for (std::size_t r = inside.size(); r-- > 0;) {
      const auto v = std::size_t(inside[r]);
      for (std::size_t row = v + 1; row < next; ++row) std::copy(identity, identity + width, s.data() + row * width);
      if (v != r) std::copy(s.data() + r * width, s.data() + (r + 1) * width, s.data() + v * width);
      next = v;
    }
    for (std::size_t row = 0; row < next; ++row) std::copy(identity, identity + width, s.data() + row * width);
  };
  const T q[4] = {1, 0, 0, 0}, R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, one[1] = {1};
  scatter(frames.quaternions, 4, q);
  scatter(frames.rotations, 9, R);
  scatter(frames.scales, 1, one);
  scatter(frames.linear, 9, R);
}

template <class T>
void write_rotations(const FramesOut<T>& frames, ArapRefiner<T>& refiner, std::vector<T>& scratch) {
  const std::span<T> R = !frames.rotations.empty() ? frames.rotations
                         : !frames.linear.empty()  ? frames.linear
                                                   : std::span<T>(scratch);
  refiner.rotations(R);
  const std::size_t n = R.size() / 9;
  if (!frames.linear.empty() && frames.linear.data() != R.data()) std::copy(R.begin(), R.end(), frames.linear.begin());
  std::fill(frames.scales.begin(), frames.scales.end(), T(1));
  if (frames.quaternions.empty()) return;
  for (std::size_t i = 0; i < n; ++i) {
    T r[9], q[4];
    std::copy(R.data() + 9 * i, R.data() + 9 * i + 9, r);
    kernels::rotation_quaternion(r, q);
    std::copy(q, q + 4, frames.quaternions.data() + 4 * i);
  }
}

template void check_frames(const FramesOut<float>&, std::size_t, Transform, bool);
template void check_frames(const FramesOut<double>&, std::size_t, Transform, bool);
template void scatter_frames(const FramesOut<float>&, const std::vector<Eigen::Index>&);
template void scatter_frames(const FramesOut<double>&, const std::vector<Eigen::Index>&);
template void write_rotations(const FramesOut<float>&, ArapRefiner<float>&, std::vector<float>&);
template void write_rotations(const FramesOut<double>&, ArapRefiner<double>&, std::vector<double>&);

}  // namespace detail

}  // namespace mlsdeform
