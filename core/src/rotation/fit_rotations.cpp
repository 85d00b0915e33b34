#include "core/src/dispatch.hpp"
#include "core/src/parallel.hpp"

#include <mlsdeform/fit_rotations.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace mlsdeform {

namespace {

// Work is cut into chunks of this many matrices (a multiple of every lane width): large enough to amortise
// scheduling, small enough to balance two to a few dozen cores on 10^5+ fits.
constexpr std::size_t kChunk = 2048;

// An interleaved batch is fitted a tile at a time: the tile's H transposed into the kernels' 3 x 3 x kTile
// layout on the stack, fitted there, its rotations transposed back. 128 matrices keep both copies in L1
// (2 x 9 x 128 doubles: 18 KiB) and are a multiple of every lane width, so only a batch's last tile has a tail.
constexpr std::size_t kTile = 128;

/// Whether all of H[0, count) is finite, the chunks checked in parallel (a serial pass over a large batch
/// would cost as much as the fits themselves on a few cores), each by the active ISA's check (compiled for
/// the ISA: with baseline flags it cost a fifth of an AVX-512 fit).
template <class T>
bool all_finite(const T* H, std::size_t count, int threads, tbb::task_arena* arena) {
  constexpr std::size_t chunk = 9 * kChunk;
  const kernels::KernelTable& k = detail::active_kernels();
  bool (*const finite_range)(const T*, std::size_t) = [&] {
    if constexpr (std::is_same_v<T, float>)
      return k.all_finite_f;
    else
      return k.all_finite_d;
  }();
  std::atomic<bool> finite{true};
  detail::parallel_ranges((count + chunk - 1) / chunk, threads, arena, [&](std::size_t c0, std::size_t c1) {
    const std::size_t end = std::min(count, c1 * chunk);
    if (!finite_range(H + c0 * chunk, end - c0 * chunk)) finite.store(false, std::memory_order_relaxed);
  });
  return finite.load();
}

template <class T>
void validate(const T* H, const T* R, std::size_t n, int threads, tbb::task_arena* arena) {
  if (!H || !R) throw std::invalid_argument("fit_rotations: null pointer");
  if (all_finite(H, 9 * n, threads, arena)) return;
  for (std::size_t e = 0; e < 9; ++e)  // name the first culprit
    for (std::size_t i = 0; i < n; ++i)
      if (!std::isfinite(H[e * n + i]))
        throw std::invalid_argument("fit_rotations: H of matrix " + std::to_string(i) + ", entry (" +
                                    std::to_string(e / 3) + ", " + std::to_string(e % 3) + ") is NaN or infinite");
}

template <class T>
void validate_interleaved(const T* H, const T* R, std::size_t n, int threads, tbb::task_arena* arena) {
  if (!H || !R) throw std::invalid_argument("fit_rotations_interleaved: null pointer");
  if (all_finite(H, 9 * n, threads, arena)) return;
  for (std::size_t i = 0; i < 9 * n; ++i)  // name the first culprit, numpy's way: H[i, r, c]
    if (!std::isfinite(H[i]))
      throw std::invalid_argument("fit_rotations_interleaved: H[" + std::to_string(i / 9) + ", " +
                                  std::to_string(i % 9 / 3) + ", " + std::to_string(i % 3) + "] is NaN or infinite");
}

// A batch whose rotations take at least this many bytes has them written past the caches (planar: the kernel
// table's fit_axis_angle_stream, non-temporal stores where the ISA has them; interleaved: copy_streaming): larger than
// the caches a core can keep them in, they would be evicted before the caller reads them anyway, and a plain store
// first reads each line from memory (a third of the traffic). 10^6 fits streamed from memory, one core, AVX-512 (AMD
// EPYC Zen 5), plain -> non-temporal stores, alternated in one run: bench_rotation_fit's `fit` (this call, whose finite
// check reads H once more) float 7.5-8.1 -> 6.2-6.3 ns, double 15.4-16.6 -> 12.1-13.0 ns (hot, in L2: 4.6-4.9 and
// 9.0-9.3 either way); the kernel alone float 7.2-8.1 -> 5.3-5.8 ns, double 14.4-17.1 -> 10.9-12.3. Prefetching R
// as well undid a third of the gain. Fitting, then reading R back in order, float: the same time either way at
// 0.6 and 2.2 MB of R, 11.5-11.7 -> 9.9-10.9 ns at 9 MB, 12.1 -> 9.9-10.2 ns at 36 MB.
constexpr std::size_t kStreamBytes = std::size_t(8) << 20;

/// The in-lane kernel of `method` in the active table, or nullptr for the methods fitted one matrix at a time
/// (horn_matrix, kanatani, svd); `stream`: axis_angle's kernel that writes past the caches.
template <class T>
kernels::FitRotationsFn<T> lane_kernel(RotationMethod method, bool stream = false) {
  const kernels::KernelTable& k = detail::active_kernels();
  if constexpr (std::is_same_v<T, float>) {
    if (method == RotationMethod::axis_angle) return stream ? k.fit_axis_angle_stream_f : k.fit_axis_angle_f;
    if (method == RotationMethod::horn_quaternion) return k.fit_horn_f;
  } else {
    if (method == RotationMethod::axis_angle) return stream ? k.fit_axis_angle_stream_d : k.fit_axis_angle_d;
    if (method == RotationMethod::horn_quaternion) return k.fit_horn_d;
  }
  return nullptr;
}

/// dst[0, count) = src[0, count), the 64-byte lines of dst that it covers whole written by non-temporal stores
/// (SSE2: write-combined, not read first, not kept in the caches), the rest by plain ones; with a plain copy
/// where SSE2 is missing (WebAssembly). The caller fences (fence_streaming) before its results are published.
/// Not the kernels' store_streaming: core/ is built with baseline flags, and four 16-byte stores fill a line's
/// write-combining buffer as one 64-byte store does.
template <class T>
void copy_streaming(const T* src, T* dst, std::size_t count) {
#if defined(__SSE2__)
  const std::size_t misaligned = reinterpret_cast<std::uintptr_t>(dst) % 64;
  if (misaligned % sizeof(T) == 0) {
    const std::size_t head = std::min(count, misaligned ? (64 - misaligned) / sizeof(T) : 0);
    const std::size_t lines = (count - head) * sizeof(T) / 64;
    std::copy(src, src + head, dst);
    const char* s = reinterpret_cast<const char*>(src + head);
    char* d = reinterpret_cast<char*>(dst + head);
    for (std::size_t l = 0; l < lines; ++l, s += 64, d += 64)
      for (int k = 0; k < 4; ++k)
        _mm_stream_si128(reinterpret_cast<__m128i*>(d) + k, _mm_loadu_si128(reinterpret_cast<const __m128i*>(s) + k));
    const std::size_t done = head + lines * 64 / sizeof(T);
    std::copy(src + done, src + count, dst + done);
    return;
  }
#endif
  std::copy(src, src + count, dst);
}

/// Orders copy_streaming's stores before the stores that follow (sfence), where it streamed.
inline void fence_streaming() {
#if defined(__SSE2__)
  _mm_sfence();
#endif
}

/// Matrices [begin, end) of an interleaved batch, tile by tile through `fit` (which fits matrices [j0, j1) of a
/// 3 x 3 x kTile tile). Each tile of H is copied out before its rotations are written, so R may be H. The
/// matrices up to `ahead` (>= end) are this thread's next ones: their lines are prefetched. `stream`: the
/// rotations go to R by copy_streaming (the caller fences).
template <class T, class Fit>
void fit_interleaved_range(const T* H, T* R, std::size_t begin, std::size_t end, std::size_t ahead, bool stream,
                           const Fit& fit) {
  // A tile's fits run on L1 alone: left to the hardware prefetcher, the next tile's H and R then came from
  // memory while the core waited (streamed double fits 40-50% slower than the planar layout's, whose kernel
  // reads its 9 streams while it computes). So the tile is fitted kStep matrices at a time, and between steps
  // a share of the next tile's cache lines of H (to read) and R (to write) is prefetched: 0-20% then.
  // A multiple of every lane width, and a whole tile of the axis/angle kernel (fit_range_axis_angle: four
  // batches side by side, 64 floats with AVX-512), which 16 at a time would fit one batch at a time.
  constexpr std::size_t kStep = 64;
  constexpr std::size_t line = 64 / sizeof(T), lines_per_step = 9 * kTile / line / (kTile / kStep);
  static_assert(9 * kTile % (line * (kTile / kStep)) == 0);
  alignas(64) T h[9 * kTile], r[9 * kTile];
  for (std::size_t first = begin; first < end; first += kTile) {
    const std::size_t count = std::min(kTile, end - first);
    const T* in = H + 9 * first;
    for (std::size_t i = 0; i < count; ++i)
      for (std::size_t e = 0; e < 9; ++e) h[e * kTile + i] = in[9 * i + e];
    const bool next = first + 2 * kTile <= ahead;  // a whole next tile for this thread
    for (std::size_t j = 0; j < count; j += kStep) {
      if (next) {
        const std::size_t at = 9 * (first + kTile) + lines_per_step * line * (j / kStep);
        for (std::size_t k = 0; k < lines_per_step; ++k) {
          __builtin_prefetch(H + at + k * line);
          if (!stream) __builtin_prefetch(R + at + k * line, 1);  // streamed: never read R's lines
        }
      }
      fit(static_cast<const T*>(h), static_cast<T*>(r), j, std::min(count, j + kStep));
    }
    T* out = R + 9 * first;
    if (!stream) {
      for (std::size_t i = 0; i < count; ++i)
        for (std::size_t e = 0; e < 9; ++e) out[9 * i + e] = r[e * kTile + i];
      continue;
    }
    alignas(64) T o[9 * kTile];  // the tile's rotations in R's layout, then copied past the caches
    for (std::size_t i = 0; i < count; ++i)
      for (std::size_t e = 0; e < 9; ++e) o[9 * i + e] = r[e * kTile + i];
    copy_streaming(o, out, 9 * count);
  }
}

}  // namespace

template <class T>
void fit_rotations(const T* H, T* R, std::size_t n, RotationMethod method, int threads, BatchStats* stats) {
  if (n == 0) return;
  const auto arena = detail::make_arena(threads);
  validate(H, R, n, threads, arena.get());
  const kernels::FitRotationsFn<T> kernel = lane_kernel<T>(method, 9 * n * sizeof(T) >= kStreamBytes);
  auto range = [&](std::size_t begin, std::size_t end, BatchStats* st) {
    if (kernel) return kernel(H, R, n, begin, end, st);
    detail::fit_rotations_one_at_a_time(H, R, n, begin, end, method);
  };
  std::atomic<std::size_t> careful_lanes{0};
  detail::parallel_ranges((n + kChunk - 1) / kChunk, threads, arena.get(), [&](std::size_t c0, std::size_t c1) {
    BatchStats st;
    range(c0 * kChunk, std::min(n, c1 * kChunk), &st);
    careful_lanes += st.careful_lanes;
  });
  if (stats) stats->careful_lanes += careful_lanes;
}

template <class T>
void fit_rotations_interleaved(const T* H, T* R, std::size_t n, RotationMethod method, int threads, BatchStats* stats,
                               const CancelCheck& cancel) {
  if (n == 0) return;
  const auto arena = detail::make_arena(threads);
  validate_interleaved(H, R, n, threads, arena.get());
  const bool stream = 9 * n * sizeof(T) >= kStreamBytes;
  const kernels::FitRotationsFn<T> kernel = lane_kernel<T>(method);
  auto tile = [&](const T* h, T* r, std::size_t j0, std::size_t j1, BatchStats* st) {
    if (kernel) return kernel(h, r, kTile, j0, j1, st);
    detail::fit_rotations_one_at_a_time(h, r, kTile, j0, j1, method);
  };
  std::atomic<std::size_t> careful_lanes{0};
  detail::parallel_ranges((n + kChunk - 1) / kChunk, threads, arena.get(), [&](std::size_t c0, std::size_t c1) {
    BatchStats st;
    for (std::size_t c = c0; c < c1; ++c) {  // the caller's check before each chunk
      detail::throw_if_cancelled(cancel);
      fit_interleaved_range(H, R, c * kChunk, std::min(n, (c + 1) * kChunk), std::min(n, c1 * kChunk), stream,
                            [&](const T* h, T* r, std::size_t j0, std::size_t j1) { tile(h, r, j0, j1, &st); });
      if (stream) fence_streaming();  // each chunk's rotations ordered before a cancel's throw or the join
    }
    careful_lanes += st.careful_lanes;
  });
  if (stats) stats->careful_lanes += careful_lanes;
}

template void fit_rotations<float>(const float*, float*, std::size_t, RotationMethod, int, BatchStats*);
template void fit_rotations<double>(const double*, double*, std::size_t, RotationMethod, int, BatchStats*);
template void fit_rotations_interleaved<float>(const float*, float*, std::size_t, RotationMethod, int, BatchStats*,
                                               const CancelCheck&);
template void fit_rotations_interleaved<double>(const double*, double*, std::size_t, RotationMethod, int, BatchStats*,
                                                const CancelCheck&);

}  // namespace mlsdeform
