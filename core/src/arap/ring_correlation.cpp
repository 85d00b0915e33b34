// The ARAP local step's one-ring sums, scalar reference, and the padded layout its SIMD twin reads
// (ring_correlation.hpp).
#include "core/src/arap/ring_correlation.hpp"

#include "core/src/huge_pages.hpp"

#include <algorithm>
#include <cmath>

namespace mlsdeform::detail {

std::size_t PaddedRings::memory_bytes() const {
  return slot_begin.size() * sizeof(std::size_t) + (self.size() + slot_x.size()) * sizeof(std::int64_t) +
         (slot_a.size() + slot_w.size()) * sizeof(double);
}

PaddedRings pad_one_rings(std::span<const Eigen::Index> start, std::span<const Eigen::Index> nbr,
                          std::span<const double> w, std::span<const double> we, int threads, tbb::task_arena* arena) {
  constexpr std::size_t L = kernels::kLanes;
  const std::size_t n = start.empty() ? 0 : start.size() - 1, blocks = (n + L - 1) / L;
  PaddedRings r;
  r.slot_begin.assign(blocks + 1, 0);
  for (std::size_t b = 0; b < blocks; ++b) {
    Eigen::Index valence = 0;
    for (std::size_t i = b * L; i < std::min(n, (b + 1) * L); ++i) valence = std::max(valence, start[i + 1] - start[i]);
    r.slot_begin[b + 1] = r.slot_begin[b] + std::size_t(valence);
  }
  const std::size_t slots = r.slot_begin[blocks];
  assign_huge(r.self, blocks * L, std::int64_t(0), threads, arena);
  assign_huge(r.slot_x, slots * L, std::int64_t(0), threads, arena);
  assign_huge(r.slot_a, 3 * slots * L, 0.0, threads, arena);  // padding: weight 0
  assign_huge(r.slot_w, slots * L, 0.0, threads, arena);
  for (std::size_t b = 0; b < blocks; ++b)
    for (std::size_t l = 0; l < L; ++l) {
      // A lane past n stands for the block's first vertex; its results are not stored.
      const std::size_t i = b * L + l < n ? b * L + l : b * L;
      r.self[b * L + l] = std::int64_t(3 * i);
      const std::size_t valence = b * L + l < n ? std::size_t(start[i + 1] - start[i]) : 0;
      for (std::size_t s = r.slot_begin[b], k = 0; s < r.slot_begin[b + 1]; ++s, ++k) {
        if (k >= valence) {
          r.slot_x[s * L + l] = std::int64_t(3 * i);  // x_i - x_i = 0
          continue;
        }
        const std::size_t e = std::size_t(start[i]) + k;
        r.slot_x[s * L + l] = std::int64_t(3 * std::size_t(nbr[e]));
        for (std::size_t c = 0; c < 3; ++c) r.slot_a[(3 * s + c) * L + l] = we[3 * e + c];
        r.slot_w[s * L + l] = w[e];
      }
    }
  return r;
}

template <class T>
void ring_correlation(const kernels::RingFrame<T>& fr, std::size_t block_begin, std::size_t block_end) {
  const std::size_t n = fr.n;
  const std::size_t i0 = block_begin * kernels::kLanes, i1 = std::min(n, block_end * kernels::kLanes);
  for (std::size_t i = i0; i < i1; ++i) {
    // Nine named sums: an array here is packed into pairs and shuffled by the compiler, slower than the plain
    // scalar code.
    double s0 = 0, s1 = 0, s2 = 0, s3 = 0, s4 = 0, s5 = 0, s6 = 0, s7 = 0, s8 = 0;
    double dd = 0;  // sum_j w_ij |x_i - x_j|^2, for the energy
    const double* xi = fr.x + 3 * i;
    for (Eigen::Index e = fr.start[i]; e < fr.start[i + 1]; ++e) {
      const double* xj = fr.x + 3 * fr.nbr[e];
      const double* a = fr.we + 3 * e;
      const double d0 = xi[0] - xj[0], d1 = xi[1] - xj[1], d2 = xi[2] - xj[2];
      s0 += d0 * a[0], s1 += d0 * a[1], s2 += d0 * a[2];
      s3 += d1 * a[0], s4 += d1 * a[1], s5 += d1 * a[2];
      s6 += d2 * a[0], s7 += d2 * a[1], s8 += d2 * a[2];
      if (fr.ring) dd += fr.w[e] * (d0 * d0 + d1 * d1 + d2 * d2);  // not on the plain path
    }
    double s[9] = {s0, s1, s2, s3, s4, s5, s6, s7, s8};
    if (fr.ring) {
      std::copy(s, s + 9, fr.ring + 10 * i);
      fr.ring[10 * i + 9] = dd;
    }
    double m = 0;
    for (const double x : s) m = std::max(m, std::abs(x));
    if (m > 0) {
      const int k = std::ilogb(m);
      // 2^-k is a double for k >= -1023; below, two factors.
      if (k < -1000) {
        for (double& x : s) x *= 0x1p1000;
        m *= 0x1p1000;
      }
      const double to_unit = std::ldexp(1.0, -std::ilogb(m));
      for (double& x : s) x *= to_unit;
    }
    for (std::size_t k = 0; k < 9; ++k) fr.H[k * n + i] = T(s[k]);
  }
}

template void ring_correlation<float>(const kernels::RingFrame<float>&, std::size_t, std::size_t);
template void ring_correlation<double>(const kernels::RingFrame<double>&, std::size_t, std::size_t);

template <class T>
void ring_rhs(const kernels::RingFrame<T>& fr, std::size_t block_begin, std::size_t block_end) {
  const std::size_t i0 = block_begin * kernels::kLanes, i1 = std::min(fr.n, block_end * kernels::kLanes);
  const auto rotate_add = [](const T* Rt, const double* a, double(&b)[3]) {  // Rt: R^T, row-major
    for (int r = 0; r < 3; ++r)
      b[r] += 0.5 * (double(Rt[r]) * a[0] + double(Rt[3 + r]) * a[1] + double(Rt[6 + r]) * a[2]);
  };
  for (std::size_t i = i0; i < i1; ++i) {
    double b[3] = {0, 0, 0};
    rotate_add(fr.R + 9 * i, fr.c + 3 * i, b);
    for (std::ptrdiff_t e = fr.start[i]; e < fr.start[i + 1]; ++e)
      rotate_add(fr.R + 9 * std::size_t(fr.nbr[e]), fr.we + 3 * e, b);
    std::copy(b, b + 3, fr.b + 3 * i);
  }
}

template void ring_rhs<float>(const kernels::RingFrame<float>&, std::size_t, std::size_t);
template void ring_rhs<double>(const kernels::RingFrame<double>&, std::size_t, std::size_t);

}  // namespace mlsdeform::detail
