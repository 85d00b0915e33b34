// bench_quality's CGAL peer: Surface_mesh_deformation with ORIGINAL_ARAP (Sorkine & Alexa 2007, cotangent
// weights with negative ones clamped to zero: the energy mlsdeform's ArapRefiner minimises). Compiled only
// where CMake finds CGAL (MLSDEFORM_HAVE_CGAL); CGAL is GPL and stays in this program, never in the library.
#pragma once

#include "tests/support/meshes.hpp"

#include <Eigen/Core>

#include <memory>
#include <span>

namespace bench {

class CgalArap {
 public:
  /// The whole mesh is the region of interest, `control` its control vertices. Builds the Surface_mesh;
  /// CGAL factorises its system in the first deform().
  CgalArap(const mlsdeform::testing::PointsD& rest, const mlsdeform::Triangles& triangles,
           std::span<const Eigen::Index> control);
  ~CgalArap();

  /// One frame from the rest pose: reset() (positions back to rest, rotations to identity), control[k] set to
  /// targets.row(k), deform(iterations, tolerance) (CGAL stops early when the energy changes by less than
  /// `tolerance` relative between iterations; 0 never), the positions copied into `out`.
  void deform(const mlsdeform::testing::PointsD& targets, unsigned iterations, double tolerance,
              mlsdeform::testing::PointsD& out);

  /// The iterations deform(max_iterations, tolerance) runs: the first k whose deform(k, 0) result equals it
  /// bitwise (the energy test changes nothing else), or 0 when none does.
  unsigned iterations_run(const mlsdeform::testing::PointsD& targets, unsigned max_iterations, double tolerance);

  /// Faces CGAL's Surface_mesh refused (non-manifold); they take no part in CGAL's deformation.
  Eigen::Index refused_faces() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace bench
