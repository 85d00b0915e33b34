// cotangent_one_rings (one_rings.hpp).
#include "core/src/arap/one_rings.hpp"

#include "core/src/huge_pages.hpp"

#include <Eigen/Geometry>  // cross

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <utility>

namespace mlsdeform::detail {

namespace {

using Vec3d = Eigen::Vector3d;

/// cot of the angle at c in the triangle (a, b, c), or 0 for a degenerate triangle (the sine below
/// 2^-40 of |u| |v|: the cotangent would be rounding noise, and huge).
double cotangent(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d u = a - c, v = b - c;
  const double cross = u.cross(v).norm(), scale = u.norm() * v.norm();
  if (!(cross > std::ldexp(scale, -40))) return 0;
  return u.dot(v) / cross;
}

}  // namespace

OneRings cotangent_one_rings(const Eigen::Matrix<double, Eigen::Dynamic, 3>& P, const Triangles& triangles, int threads,
                             tbb::task_arena* arena) {
  const auto n = std::size_t(P.rows());
  OneRings r;
  // Half the cotangent opposite each triangle edge, as (larger vertex, weight), bucketed by the smaller one.
  using Half = std::pair<Eigen::Index, double>;
  std::vector<std::size_t> first(n + 1, 0);
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    for (int k = 0; k < 3; ++k)
      if (triangles(f, k) < 0 || triangles(f, k) >= P.rows())
        throw std::invalid_argument("ArapRefiner: triangle " + std::to_string(f) + " has vertex index " +
                                    std::to_string(triangles(f, k)) + ", outside [0, " + std::to_string(n) + ")");
    for (int k = 0; k < 3; ++k)
      if (triangles(f, k) != triangles(f, (k + 1) % 3))  // a repeated corner: no edge
        ++first[std::size_t(std::min(triangles(f, k), triangles(f, (k + 1) % 3))) + 1];
  }
  for (std::size_t i = 0; i < n; ++i) first[i + 1] += first[i];
  std::vector<Half> halves;
  assign_huge(halves, first[n], {}, threads, arena);
  {
    std::vector<std::size_t> fill(first.begin(), first.end() - 1);
    for (Eigen::Index f = 0; f < triangles.rows(); ++f)
      for (int k = 0; k < 3; ++k) {
        const Eigen::Index a = triangles(f, k), b = triangles(f, (k + 1) % 3), c = triangles(f, (k + 2) % 3);
        if (a == b) continue;
        halves[fill[std::size_t(std::min(a, b))]++] = {
            std::max(a, b), a == c || b == c ? 0.0 : 0.5 * cotangent(P.row(a), P.row(b), P.row(c))};
      }
  }
  // Per undirected edge (i < j), the sum of its halves in ascending order of (j, half): merged in place.
  std::vector<std::size_t> merged_end(n);
  std::size_t edges = 0;
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto b = halves.begin() + std::ptrdiff_t(first[i]), e = halves.begin() + std::ptrdiff_t(first[i + 1]);
    std::sort(b, e);
    auto out = b;
    for (auto h = b; h != e; ++h)
      if (out != b && (out - 1)->first == h->first)
        (out - 1)->second += h->second;
      else
        *out++ = *h;
    merged_end[i] = first[i] + std::size_t(out - b);
    for (auto h = b; h != out; ++h) {
      if (h->second < 0) ++r.clamped, h->second = 0;
      sum += h->second;
    }
    edges += std::size_t(out - b);
  }
  const double floor = edges == 0 || sum == 0 ? 1.0 : 1e-6 * sum / double(edges);

  // CSR one-rings: both directions of every edge, each ring ascending.
  r.start.assign(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t h = first[i]; h < merged_end[i]; ++h) {
      ++r.start[i + 1];
      ++r.start[std::size_t(halves[h].first) + 1];
    }
  for (std::size_t i = 0; i < n; ++i) r.start[i + 1] += r.start[i];
  std::vector<Half> ring;
  assign_huge(ring, std::size_t(r.start[n]), {}, threads, arena);
  std::vector<std::size_t> fill(r.start.begin(), r.start.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t h = first[i]; h < merged_end[i]; ++h) {
      const double w = halves[h].second + floor;
      ring[fill[i]++] = {halves[h].first, w};
      ring[fill[std::size_t(halves[h].first)]++] = {Eigen::Index(i), w};
    }
  assign_huge(r.nbr, ring.size(), {}, threads, arena);
  assign_huge(r.w, ring.size(), {}, threads, arena);
  for (std::size_t i = 0; i < n; ++i) {
    const auto b = ring.begin() + std::ptrdiff_t(r.start[i]), e = ring.begin() + std::ptrdiff_t(r.start[i + 1]);
    std::sort(b, e);  // neighbours are distinct: by neighbour
    for (auto h = b; h != e; ++h)
      r.nbr[std::size_t(h - ring.begin())] = h->first, r.w[std::size_t(h - ring.begin())] = h->second;
  }
  return r;
}

Eigen::SparseMatrix<double> reduced_laplacian(const OneRingsView& rings, const std::vector<Eigen::Index>& row,
                                              const std::vector<Eigen::Index>& free_vertices, int threads,
                                              tbb::task_arena* arena) {
  // Written by columns directly (L is symmetric: column row[i] holds row i's entries), in place of triplets and
  // their two sorting passes (spot_loop3: 1.0 -> 0.2 s of the set-up). Rows ascend within each column: a
  // ring's neighbours ascend, and so do their rows (row[] numbers the free vertices in ascending order); the
  // diagonal goes in between. No entry repeats, so nothing is summed that the triplets did not sum.
  const auto nf = Eigen::Index(free_vertices.size());
  Eigen::SparseMatrix<double> L(nf, nf);
  std::size_t entries = 0;
  for (const Eigen::Index i : free_vertices) {
    ++entries;
    for (Eigen::Index e = rings.start[std::size_t(i)]; e < rings.start[std::size_t(i) + 1]; ++e)
      entries += row[std::size_t(rings.nbr[std::size_t(e)])] >= 0;
  }
  resize_nonzeros_huge(L, entries, threads, arena);  // allocated, not written: advised before the loop writes them
  int* outer = L.outerIndexPtr();
  int* inner = L.innerIndexPtr();
  double* value = L.valuePtr();
  std::size_t p = 0;
  for (Eigen::Index f = 0; f < nf; ++f) {
    const auto i = std::size_t(free_vertices[std::size_t(f)]);
    outer[f] = int(p);
    double diag = 0;
    std::size_t diag_at = 0;
    bool placed = false;
    for (Eigen::Index e = rings.start[i]; e < rings.start[i + 1]; ++e) {
      diag += rings.w[std::size_t(e)];
      const Eigen::Index rj = row[std::size_t(rings.nbr[std::size_t(e)])];
      if (rj < 0) continue;
      if (!placed && rj > f) diag_at = p++, placed = true;
      inner[p] = int(rj), value[p++] = -rings.w[std::size_t(e)];
    }
    if (!placed) diag_at = p++;
    inner[diag_at] = int(f), value[diag_at] = diag;
  }
  outer[nf] = int(p);
  return L;
}

}  // namespace mlsdeform::detail
