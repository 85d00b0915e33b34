// The precomputed path against the direct per-vertex evaluation (weighted centroids, H, fit_rotation with
// RotationMethod::svd; test_deformer_common.hpp) on real meshes twisted by up to 180 degrees, and every
// rotation method against svd on the same frames. Prints the largest deviations. The bundled human comes from
// data/; spot from ../shared/data/meshes, skipped with a warning when that folder is absent.
#include "tests/test_deformer_common.hpp"

#include <cstdio>
#include <iostream>

using namespace deformer_test;

namespace {

/// A twisted mesh: k handles on mesh vertices (farthest-point sampling, deterministic), each turned about
/// the mesh's longest principal axis by theta times its relative position along that axis.
struct TwistCase {
  Points<double> vertices;
  Handles<double> rest;
  Vec3d centre, axis;
  double lo = 0, hi = 0;
  Handles<double> twisted(double theta) const {
    Handles<double> q = rest;
    for (Eigen::Index i = 0; i < rest.points.rows(); ++i) {
      const Vec3d p = rest.points.row(i).transpose();
      const double f = ((p - centre).dot(axis) - lo) / (hi - lo);
      q.points.row(i) = (centre + rotation_about(axis, theta * f) * (p - centre)).transpose();
    }
    return q;
  }
};

/// The mesh file: the bundled human from data/, the others from the shared meshes ("" when ../shared is
/// absent, as in a checkout of the repository alone: tests/support/meshes.hpp).
std::string mesh_path(const std::string& mesh) {
  return mesh == "human_man.obj" ? bundled_mesh(mesh) : shared_mesh(mesh);
}

TwistCase make_case(const std::string& mesh, Eigen::Index k) {
  TwistCase c;
  c.vertices = read_obj_vertices(mesh_path(mesh));
  REQUIRE(c.vertices.rows() > 1000);
  c.centre = c.vertices.colwise().mean().transpose();
  const Points<double> centred = c.vertices.rowwise() - c.centre.transpose();
  const Eigen::SelfAdjointEigenSolver<Mat3d> es(centred.transpose() * centred);
  c.axis = es.eigenvectors().col(2);
  const Eigen::VectorXd along = centred * c.axis;
  c.lo = along.minCoeff();
  c.hi = along.maxCoeff();
  // Farthest-point sampling from the lowest vertex along the axis.
  std::vector<Eigen::Index> chosen;
  Eigen::Index first;
  along.minCoeff(&first);
  chosen.push_back(first);
  Eigen::VectorXd dist = (c.vertices.rowwise() - c.vertices.row(first)).rowwise().norm();
  while (Eigen::Index(chosen.size()) < k) {
    Eigen::Index next;
    dist.maxCoeff(&next);
    chosen.push_back(next);
    dist = dist.cwiseMin((c.vertices.rowwise() - c.vertices.row(next)).rowwise().norm());
  }
  c.rest.points.resize(k, 3);
  for (Eigen::Index i = 0; i < k; ++i) c.rest.points.row(i) = c.vertices.row(chosen[i]);
  return c;
}

}  // namespace

TEMPLATE_TEST_CASE("precomputed path agrees with the direct evaluation on real meshes with large twists",
                   "[deformer][mesh]", float, double) {
  using T = TestType;
  double largest = 0, largest_relative = 0;
  for (const char* mesh : {"spot.obj", "human_man.obj"}) {
    if (mesh_path(mesh).empty()) {
      WARN(mesh << " skipped: ../shared/data/meshes is not beside the source tree");
      continue;
    }
    const TwistCase tc = make_case(mesh, 16);
    const Points<T> vertices = tc.vertices.cast<T>();
    const Handles<T> rest = cast_handles<T>(tc.rest);
    const double size = scene_size(vertices, rest);
    for (double u : {2.0, 4.0})
      for (Transform tr : all_transforms)
        for (RotationMethod method : {RotationMethod::svd, RotationMethod::axis_angle}) {
          if (tr == Transform::affine && method != RotationMethod::svd) continue;  // no rotation fit
          Options o;
          o.transform = tr;
          o.weight_exponent = u;
          o.method = method;
          const Deformer<T> def(vertices, rest, o);
          for (double degrees : {30.0, 90.0, 180.0}) {
            const Handles<T> moved = cast_handles<T>(tc.twisted(degrees * M_PI / 180));
            Points<T> out;
            def.deform(moved, out);
            const Comparison c = compare_with_direct(out, vertices, rest, moved, o);
            char line[320];
            std::snprintf(line, sizeof line,
                          "[mesh] %-13s %-6s u=%g %-10s %-10s twist %3.0f deg: max |path - direct| = %.3g "
                          "(%.3g of the model size), max deviation/bound = %.3g; %ld checked, %ld snapped, %ld "
                          "ill-posed",
                          mesh, type_name<T>(), u, name(tr), tr == Transform::affine ? "-" : to_string(method).data(),
                          degrees, c.max_dev, c.max_dev / size, c.max_ratio, long(c.checked), long(c.snapped),
                          long(c.ill_posed));
            std::cout << line << "\n";
            INFO(line);
            CHECK(c.failures == 0);
            // The bound skips only vertices where the rotation is not unique to the precision of T.
            CHECK(c.ill_posed <= c.checked / 100);
            largest = std::max(largest, c.max_dev);
            largest_relative = std::max(largest_relative, c.max_dev / size);
          }
        }
  }
  std::cout << "[mesh] " << type_name<T>() << ": largest deviation " << largest << " (" << largest_relative
            << " of the model size)\n";
}

TEMPLATE_TEST_CASE("every rotation method gives the same deformation", "[deformer][mesh]", float, double) {
  using T = TestType;
  const TwistCase tc = make_case("human_man.obj", 16);
  const Points<T> vertices = tc.vertices.cast<T>();
  const Handles<T> rest = cast_handles<T>(tc.rest);
  const double size = scene_size(vertices, rest);
  const double eps = std::numeric_limits<T>::epsilon();
  for (Transform tr : {Transform::rigid, Transform::similarity}) {
    for (double degrees : {90.0, 180.0}) {
      const Handles<T> moved = cast_handles<T>(tc.twisted(degrees * M_PI / 180));
      Options o;
      o.transform = tr;
      o.method = RotationMethod::svd;
      Points<T> ref;
      Deformer<T>(vertices, rest, o).deform(moved, ref);
      for (RotationMethod method : all_rotation_methods) {
        o.method = method;
        Points<T> out;
        Deformer<T>(vertices, rest, o).deform(moved, out);
        // Both runs see the same H bitwise (same table, same accumulation); only the fits differ. Each fit's
        // backward error is <= 16 eps |H|_F, so |R_m - R_svd|_F <= 2 (16 + 16) eps |H|_F / gap; mu moves
        // only at second order (trace(R^T H) is stationary at the optimum) plus the rounding of the trace,
        // 16 eps |H|_F / D; the final q* + mu R vhat rounds twice, 8 eps (|q*| + mu |vhat|) each.
        double worst = 0, worst_ratio = 0;
        long skipped = 0, failures = 0;
        for (Eigen::Index i = 0; i < vertices.rows(); ++i) {
          const DirectVertex d =
              direct_vertex(vertices.row(i).transpose().template cast<double>(), rest, moved, o, size);
          const double dev = (out.row(i) - ref.row(i)).template cast<double>().norm();
          if (d.snapped) {
            if (dev != 0) ++failures;
            continue;
          }
          if (!d.well_posed || eps * d.dH_unit >= d.gap / 2) {
            ++skipped;
            continue;
          }
          const double dR = 2 * 32 * eps * d.norm_H / d.gap;
          const double dmu = tr == Transform::similarity ? (d.norm_H * dR * dR + 16 * eps * d.norm_H) / d.D : 0;
          const double bound =
              d.mu * dR * d.vhat_norm + dmu * d.vhat_norm + 16 * eps * (d.q_star_norm + d.mu * d.vhat_norm);
          worst = std::max(worst, dev);
          worst_ratio = std::max(worst_ratio, dev / bound);
          if (dev > bound) ++failures;
        }
        char line[256];
        std::snprintf(line, sizeof line,
                      "[methods] %-6s %-10s twist %3.0f deg: %-15s vs svd: max difference %.3g (%.3g of the size), "
                      "max difference/bound %.3g, %ld ill-posed skipped",
                      type_name<T>(), name(tr), degrees, to_string(method).data(), worst, worst / size, worst_ratio,
                      skipped);
        std::cout << line << "\n";
        INFO(line);
        CHECK(failures == 0);
      }
    }
  }
}
