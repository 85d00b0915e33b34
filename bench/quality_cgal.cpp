// See quality_cgal.hpp.
#include "bench/quality_cgal.hpp"

#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_deformation.h>

#include <vector>

namespace bench {

using Kernel = CGAL::Simple_cartesian<double>;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;
using Deformation = CGAL::Surface_mesh_deformation<Mesh, CGAL::Default, CGAL::Default, CGAL::ORIGINAL_ARAP>;
using mlsdeform::testing::PointsD;

struct CgalArap::Impl {
  Mesh mesh;
  std::vector<Mesh::Vertex_index> vertex;
  std::vector<Mesh::Vertex_index> control;
  Eigen::Index refused = 0;
  std::unique_ptr<Deformation> deformation;

  void start(const PointsD& targets) {
    deformation->reset();
    for (std::size_t k = 0; k < control.size(); ++k) {
      const auto r = static_cast<Eigen::Index>(k);
      deformation->set_target_position(control[k], Kernel::Point_3(targets(r, 0), targets(r, 1), targets(r, 2)));
    }
  }
  void read(PointsD& out) const {
    out.resize(static_cast<Eigen::Index>(vertex.size()), 3);
    for (std::size_t i = 0; i < vertex.size(); ++i) {
      const auto& p = mesh.point(vertex[i]);
      out.row(static_cast<Eigen::Index>(i)) << p.x(), p.y(), p.z();
    }
  }
};

CgalArap::CgalArap(const PointsD& rest, const mlsdeform::Triangles& triangles, std::span<const Eigen::Index> control)
    : impl_(std::make_unique<Impl>()) {
  auto& m = *impl_;
  for (Eigen::Index i = 0; i < rest.rows(); ++i)
    m.vertex.push_back(m.mesh.add_vertex(Kernel::Point_3(rest(i, 0), rest(i, 1), rest(i, 2))));
  for (Eigen::Index f = 0; f < triangles.rows(); ++f)
    if (m.mesh.add_face(m.vertex[static_cast<std::size_t>(triangles(f, 0))],
                        m.vertex[static_cast<std::size_t>(triangles(f, 1))],
                        m.vertex[static_cast<std::size_t>(triangles(f, 2))]) == Mesh::null_face())
      ++m.refused;
  m.deformation = std::make_unique<Deformation>(m.mesh);
  m.deformation->insert_roi_vertices(m.mesh.vertices().begin(), m.mesh.vertices().end());
  for (const Eigen::Index i : control) {
    m.control.push_back(m.vertex[static_cast<std::size_t>(i)]);
    m.deformation->insert_control_vertex(m.control.back());
  }
}

CgalArap::~CgalArap() = default;

void CgalArap::deform(const PointsD& targets, unsigned iterations, double tolerance, PointsD& out) {
  impl_->start(targets);
  impl_->deformation->deform(iterations, tolerance);
  impl_->read(out);
}

unsigned CgalArap::iterations_run(const PointsD& targets, unsigned max_iterations, double tolerance) {
  PointsD converged, x;
  deform(targets, max_iterations, tolerance, converged);
  impl_->start(targets);
  // deform(1, 0) k times continues from the solution and rotations it left: the same steps as deform(k, 0).
  for (unsigned k = 1; k <= max_iterations; ++k) {
    impl_->deformation->deform(1, 0);
    impl_->read(x);
    if (x == converged) return k;
  }
  return 0;
}

Eigen::Index CgalArap::refused_faces() const { return impl_->refused; }

}  // namespace bench
