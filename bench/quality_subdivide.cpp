// bench_quality: Loop subdivision (Loop 1987, with Warren's vertex weights), to make the 10^5-vertex human
// of the ARAP section from the bundled 6,890-vertex one. Old vertices keep their indices (so the handles
// stay on the same vertices), each edge adds one vertex after them, each triangle becomes four.
#include "bench/quality.hpp"

#include <algorithm>
#include <cstdint>
#include <unordered_map>

namespace bench::quality {

namespace {

struct Edge {
  int a, b, opposite[2] = {-1, -1}, faces = 0;
};

}  // namespace

void loop_subdivide(PointsD& v, Triangles& f) {
  const Eigen::Index n = v.rows();
  std::unordered_map<std::int64_t, int> index;
  std::vector<Edge> edges;
  Triangles edge_of(f.rows(), 3);  // the edge of side (k, k + 1) of each triangle
  for (Eigen::Index t = 0; t < f.rows(); ++t)
    for (int k = 0; k < 3; ++k) {
      const int a = std::min(f(t, k), f(t, (k + 1) % 3)), b = std::max(f(t, k), f(t, (k + 1) % 3));
      const auto [it, added] = index.try_emplace(std::int64_t(a) * n + b, int(edges.size()));
      if (added) edges.push_back({a, b});
      Edge& e = edges[std::size_t(it->second)];
      if (e.faces < 2) e.opposite[e.faces] = f(t, (k + 2) % 3);
      ++e.faces;
      edge_of(t, k) = it->second;
    }
  PointsD out(n + Eigen::Index(edges.size()), 3);
  // Edge points: 3/8 of each end and 1/8 of each opposite vertex inside; the midpoint on a boundary (or a
  // non-manifold) edge.
  std::vector<std::vector<int>> ring(static_cast<std::size_t>(n)), boundary(static_cast<std::size_t>(n));
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const Edge& e = edges[k];
    const Eigen::Index r = n + Eigen::Index(k);
    if (e.faces == 2)
      out.row(r) = 0.375 * (v.row(e.a) + v.row(e.b)) + 0.125 * (v.row(e.opposite[0]) + v.row(e.opposite[1]));
    else
      out.row(r) = 0.5 * (v.row(e.a) + v.row(e.b));
    ring[std::size_t(e.a)].push_back(e.b), ring[std::size_t(e.b)].push_back(e.a);
    if (e.faces != 2) boundary[std::size_t(e.a)].push_back(e.b), boundary[std::size_t(e.b)].push_back(e.a);
  }
  // Vertex points: inside, (1 - k beta) v + beta sum of the k neighbours, beta = 3 / (8k) (3/16 for k = 3);
  // on a boundary, 3/4 v + 1/8 of its two boundary neighbours; a vertex with other boundary counts stays.
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& nb = ring[std::size_t(i)];
    const auto& bd = boundary[std::size_t(i)];
    if (bd.empty() && nb.size() >= 3) {
      const double k = double(nb.size()), beta = nb.size() == 3 ? 3.0 / 16 : 3.0 / (8 * k);
      out.row(i) = (1 - k * beta) * v.row(i);
      for (const int j : nb) out.row(i) += beta * v.row(j);
    } else if (bd.size() == 2) {
      out.row(i) = 0.75 * v.row(i) + 0.125 * (v.row(bd[0]) + v.row(bd[1]));
    } else {
      out.row(i) = v.row(i);
    }
  }
  Triangles g(4 * f.rows(), 3);
  for (Eigen::Index t = 0; t < f.rows(); ++t) {
    const int a = f(t, 0), b = f(t, 1), c = f(t, 2);
    const int ab = int(n) + edge_of(t, 0), bc = int(n) + edge_of(t, 1), ca = int(n) + edge_of(t, 2);
    g.row(4 * t) << a, ab, ca;
    g.row(4 * t + 1) << b, bc, ab;
    g.row(4 * t + 2) << c, ca, bc;
    g.row(4 * t + 3) << ab, bc, ca;
  }
  v = std::move(out);
  f = std::move(g);
}

}  // namespace bench::quality
