#include "core/src/all_finite.hpp"
#include "core/src/dispatch.hpp"
#include "core/src/parallel.hpp"

#include <mlsdeform/fit_rotations.hpp>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace mlsdeform {

namespace {

// Work is cut into chunks of this many matrices (a multiple of every lane width): large enough to amortise
// scheduling, small enough to balance two to a few dozen cores on 10^5+ fits.
constexpr std::size_t kChunk = 2048;

template <class T>
void validate(const T* H, const T* R, std::size_t n) {
  if (!H || !R) throw std::invalid_argument("fit_rotations: null pointer");
  if (detail::all_finite(H, 9 * n)) return;
  for (std::size_t e = 0; e < 9; ++e)  // name the first culprit
    for (std::size_t i = 0; i < n; ++i)
      if (!std::isfinite(H[e * n + i]))
        throw std::invalid_argument("fit_rotations: H of matrix " + std::to_string(i) + ", entry (" +
                                    std::to_string(e / 3) + ", " + std::to_string(e % 3) + ") is NaN or infinite");
}

/// The in-lane kernel of `method` in the active table, or nullptr for the methods fitted one matrix at a time
/// (horn_matrix, kanatani, svd).
template <class T>
kernels::FitRotationsFn<T> lane_kernel(RotationMethod method) {
  const kernels::KernelTable& k = detail::active_kernels();
  if constexpr (std::is_same_v<T, float>) {
    if (method == RotationMethod::axis_angle) return k.fit_axis_angle_f;
    if (method == RotationMethod::horn_quaternion) return k.fit_horn_f;
  } else {
    if (method == RotationMethod::axis_angle) return k.fit_axis_angle_d;
    if (method == RotationMethod::horn_quaternion) return k.fit_horn_d;
  }
  return nullptr;
}

}  // namespace

template <class T>
void fit_rotations(const T* H, T* R, std::size_t n, RotationMethod method, int threads, BatchStats* stats) {
  if (n == 0) return;
  validate(H, R, n);
  const kernels::FitRotationsFn<T> kernel = lane_kernel<T>(method);
  auto range = [&](std::size_t begin, std::size_t end, BatchStats* st) {
    if (kernel) return kernel(H, R, n, begin, end, st);
    detail::fit_rotations_one_at_a_time(H, R, n, begin, end, method);
  };
  const auto arena = detail::make_arena(threads);
  std::atomic<std::size_t> careful_lanes{0};
  detail::parallel_ranges((n + kChunk - 1) / kChunk, threads, arena.get(), [&](std::size_t c0, std::size_t c1) {
    BatchStats st;
    range(c0 * kChunk, std::min(n, c1 * kChunk), &st);
    careful_lanes += st.careful_lanes;
  });
  if (stats) stats->careful_lanes += careful_lanes;
}

template void fit_rotations<float>(const float*, float*, std::size_t, RotationMethod, int, BatchStats*);
template void fit_rotations<double>(const double*, double*, std::size_t, RotationMethod, int, BatchStats*);

}  // namespace mlsdeform
