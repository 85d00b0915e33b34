// Deformation cases of the tests and benchmarks: rest vertices, rest handles and (where the generator moves
// them) moved handles, with the generators that make them and small helpers on points and handles. A case is
// one deformation of a point set; a scene (tools/cli/scenes.hpp) is the program's: a mesh with its handles'
// targets frame by frame.
//   random_case        vertices and handles uniform in [-1, 1]^3 (std::mt19937_64; the deformer tests)
//   twisted_cube_case  vertices in [-1, 1]^3, handles among them, moved by a twist about z (the SIMD and
//                      on-the-fly tests)
//   twisted_mesh_case  handles picked among a mesh's vertices, twisted and bent about its long axis (the
//                      deformation benchmarks)
#pragma once

#include "tests/support/random.hpp"

#include <mlsdeform/deformer.hpp>  // Handles

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <limits>
#include <random>
#include <string>

namespace mlsdeform::testing {

/// One deformation: `moved` is empty where the test moves the handles itself. `name` labels it in output.
template <class T>
struct DeformCase {
  Points<T> vertices;
  Handles<T> rest, moved;
  std::string name;
};

/// n vertices, k point handles and s segments, all uniform in [-1, 1]^3 (drawn in that order); no moved
/// handles.
template <class T>
DeformCase<T> random_case(std::mt19937_64& g, Eigen::Index n, Eigen::Index k, Eigen::Index s = 0) {
  DeformCase<T> sc;
  sc.vertices = random_points<T>(g, n);
  sc.rest.points = random_points<T>(g, k);
  sc.rest.segment_a = random_points<T>(g, s);
  sc.rest.segment_b = random_points<T>(g, s);
  return sc;
}

/// Random vertices in the cube [-1, 1]^3; k point handles (on the line x = (0.1, -0.2, 1) z if `collinear`),
/// vertex i put exactly on handle i; s segments a -> a + 0.5 u (u in the cube); everything moved by a twist
/// about z of angle * (z + 1) / 2, plus `noise` times a vector in the cube per moved point (no draw when
/// noise is 0). std::mt19937_64(seed), uniform in [-1, 1): a pure function of its arguments.
template <class T>
DeformCase<T> twisted_cube_case(Eigen::Index n, int k, int s, bool collinear, double angle, double noise,
                                std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  DeformCase<T> sc;
  sc.vertices.resize(n, 3);
  for (Eigen::Index i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) sc.vertices(i, c) = T(u(rng));
  auto twist = [&](const Eigen::Vector3d& p) {
    const double t = angle * (p.z() + 1) / 2;
    Eigen::Vector3d q = Eigen::AngleAxisd(t, Eigen::Vector3d::UnitZ()) * p;
    if (noise != 0) q += noise * Eigen::Vector3d(u(rng), u(rng), u(rng));
    return q;
  };
  sc.rest.points.resize(k, 3);
  sc.moved.points.resize(k, 3);
  for (int i = 0; i < k; ++i) {
    Eigen::Vector3d p(u(rng), u(rng), u(rng));
    if (collinear) p = Eigen::Vector3d(0.1, -0.2, 1.0) * p.z();
    sc.rest.points.row(i) = p.template cast<T>().transpose();
    sc.moved.points.row(i) = twist(p).template cast<T>().transpose();
    if (i < n) sc.vertices.row(i) = sc.rest.points.row(i);  // a vertex exactly on each handle
  }
  for (auto* h : {&sc.rest, &sc.moved}) {
    h->segment_a.resize(s, 3);
    h->segment_b.resize(s, 3);
  }
  for (int i = 0; i < s; ++i) {
    const Eigen::Vector3d a(u(rng), u(rng), u(rng)), b = a + 0.5 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    sc.rest.segment_a.row(i) = a.template cast<T>().transpose();
    sc.rest.segment_b.row(i) = b.template cast<T>().transpose();
    sc.moved.segment_a.row(i) = twist(a).template cast<T>().transpose();
    sc.moved.segment_b.row(i) = twist(b).template cast<T>().transpose();
  }
  return sc;
}

/// The moved handles of a benchmark frame: a twist about the model's longest axis of up to 90 degrees
/// end to end (the paper's Fig. 3) plus a bend of a tenth of the length, so that every vertex gets a
/// different, large rotation.
Points<double> twist(const Points<double>& rest_vertices, const Points<double>& handles);

/// `count` distinct vertices as point handles (random_subset with `seed`), moved by twist(): what a user
/// clicking on the mesh and dragging produces.
DeformCase<double> twisted_mesh_case(std::string name, Points<double> vertices, Eigen::Index handle_count,
                                     std::uint64_t seed);

/// The same handles in another precision (each coordinate rounded once).
template <class T, class U>
Handles<T> cast_handles(const Handles<U>& h) {
  return {h.points.template cast<T>(), h.segment_a.template cast<T>(), h.segment_b.template cast<T>()};
}

/// Point handles at the rows of p.
template <class T>
Handles<T> point_handles(const Points<double>& p) {
  Handles<T> h;
  h.points = p.cast<T>();
  return h;
}

/// x rounded to E and back to double. Through a volatile: GCC 12.2 at -O2 (SLP vectorizer) was seen to drop
/// a double -> float -> double round trip written as an expression (wrong code; -fno-tree-slp-vectorize
/// avoids it), which made "the same float-rounded geometry in double" silently not the same.
template <class E>
double rounded_to(double x) {
  volatile E y = static_cast<E>(x);
  return static_cast<double>(y);
}

/// Points rounded to E, returned in double (row by row through rounded_to).
template <class E>
Points<double> rounded_points(const Points<double>& p) {
  Points<double> r(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (Eigen::Index c = 0; c < 3; ++c) r(i, c) = rounded_to<E>(p(i, c));
  return r;
}

/// Applies x -> M x + t to every row (in double, rounded once to T).
template <class T>
Points<T> transformed(const Points<T>& p, const Eigen::Matrix3d& M, const Eigen::Vector3d& t) {
  Points<T> q(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    q.row(i) = (M * p.row(i).transpose().template cast<double>() + t).template cast<T>().transpose();
  return q;
}

template <class T>
Handles<T> transformed(const Handles<T>& h, const Eigen::Matrix3d& M, const Eigen::Vector3d& t) {
  Handles<T> q;
  q.points = transformed(h.points, M, t);
  q.segment_a = transformed(h.segment_a, M, t);
  q.segment_b = transformed(h.segment_b, M, t);
  return q;
}

/// Bounding-box diagonal of the rest vertices and handles (the scene size l of the reference's bound).
template <class T>
double scene_size(const Points<T>& v, const Handles<T>& h) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  auto add = [&](const Points<T>& p) {
    for (Eigen::Index i = 0; i < p.rows(); ++i) {
      lo = lo.cwiseMin(p.row(i).transpose().template cast<double>());
      hi = hi.cwiseMax(p.row(i).transpose().template cast<double>());
    }
  };
  add(v);
  add(h.points);
  add(h.segment_a);
  add(h.segment_b);
  return (hi - lo).norm();
}

}  // namespace mlsdeform::testing
