// The deformed positions' finiteness check (Deformer::Impl::run): each thread checks the blocks it has just
// written, with the kernel table's all_finite, and the session reports the smallest vertex that overflowed.
#pragma once

#include "kernels/kernel_table.hpp"

#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace mlsdeform::detail {

/// The vertices' deformed positions must be finite: the moved handles may map a vertex beyond the range of T
/// (extrapolation far from the handles, or targets near the largest coordinate), which is reported rather
/// than returned. kAllFinite, or the smallest vertex with a non-finite coordinate.
inline constexpr std::size_t kAllFinite = std::size_t(-1);

/// The smallest of vertices [v0, v1) of out (vertex v, coordinate c at out[c * cstride + v * vstride]) with a
/// non-finite coordinate, or kAllFinite: the ISA's check over each contiguous run, and a scan only on failure.
template <class T>
std::size_t first_non_finite(const T* out, std::size_t v0, std::size_t v1, std::size_t vstride, std::size_t cstride,
                             const kernels::KernelTable& k) {
  const auto all_finite = [&k](const T* p, std::size_t count) {
    if constexpr (std::is_same_v<T, float>)
      return k.all_finite_f(p, count);
    else
      return k.all_finite_d(p, count);
  };
  const bool fine = vstride == 3 ? all_finite(out + 3 * v0, 3 * (v1 - v0))
                                 : all_finite(out + v0, v1 - v0) && all_finite(out + cstride + v0, v1 - v0) &&
                                       all_finite(out + 2 * cstride + v0, v1 - v0);
  if (fine) return kAllFinite;
  for (std::size_t v = v0; v < v1; ++v)
    for (std::size_t c = 0; c < 3; ++c)
      if (!std::isfinite(out[c * cstride + v * vstride])) return v;
  return kAllFinite;  // not reached: the check found one
}

/// The error for a vertex whose deformed position is not finite (first_non_finite).
template <class T>
std::invalid_argument overflow_error(std::size_t vertex) {
  return std::invalid_argument("Deformer: vertex " + std::to_string(vertex) + "'s deformed position overflows " +
                               (sizeof(T) == 4 ? "float" : "double") +
                               ": the moved handles map it beyond the range of the type");
}

}  // namespace mlsdeform::detail
