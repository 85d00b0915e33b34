// Through the program: normals at vertices that are handles. A motion of every handle (a group rotation, an
// affine map) must turn every normal by it, the normals of the vertices on point handles and on segment handles
// (ends and interior) too, whatever the weight storage (the table, or on-the-fly weights under
// --weight-budget 0, which serve point handles only), the backend, the precision and the segment weight. The oracle is
// the motion itself: R n, or A^-T n renormalised, at every vertex.
#include "tests/cli/cli_test_util.hpp"
#include "tests/support/catch.hpp"

#include "core/files/mesh.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <string>
#include <vector>

using namespace mlsdeform;
using namespace mlsdeform::files;
using cli_test::ScratchDir;
using cli_test::write_text;

namespace {

std::string text(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

/// The bound on |n' - M n| for a unit n: the handles' targets are the motion of their rest positions,
/// rounded once to the precision (group targets are computed in double; explicit ones are written with 17
/// digits), so every fit is the motion to a few hundred eps of the precision times the conditioning of these
/// well-spread handles (tests/test_frames.cpp and test_frames_affine.cpp bound the fit, on handles and off
/// them); the normal moves by at most twice the fit's error, and is rounded to the output type once. 1e-4
/// (float) and 1e-9 (double) are far above that and far below the distance of a normal left unturned, or
/// turned by another vertex's frame, from the turned one (each test checks that distance is over 0.1).
double tolerance(const std::string& precision) { return precision == "float" ? 1e-4 : 1e-9; }

/// The largest distance of a normal of `out` (OBJ: of each face corner; PLY: nx ny nz of each vertex) from
/// `want` of its vertex, and that vertex.
struct Worst {
  double error = 0;
  std::size_t vertex = 0;
};
Worst worst_normal(const Mesh& out, const std::vector<Eigen::Vector3d>& want) {
  Worst w;
  auto see = [&w](double e, std::size_t v) {
    if (e > w.error) w = {e, v};
  };
  if (out.extras.ply) {
    const PlyElement& v = out.extras.ply->vertices();
    const int nx = v.find("nx");
    REQUIRE(nx >= 0);
    for (std::size_t i = 0; i < want.size(); ++i) {
      const Eigen::Vector3d got(v.get(i, std::size_t(nx)), v.get(i, std::size_t(nx + 1)),
                                v.get(i, std::size_t(nx + 2)));
      see((got - want[i]).norm(), i);
    }
    return w;
  }
  const ObjExtras& x = *out.extras.obj;
  REQUIRE(x.corner_normals.size() == out.face_indices.size());
  for (std::size_t c = 0; c < x.corner_normals.size(); ++c) {
    const Eigen::Vector3d got(&x.normals[3 * std::size_t(x.corner_normals[c])]);
    see((got - want[out.face_indices[c]]).norm(), out.face_indices[c]);
  }
  return w;
}

}  // namespace

TEST_CASE("a group rotation of point handles on vertices turns every OBJ normal, the handles' own too",
          "[cli][attributes][handles]") {
  // A 12 x 12 saddle sheet (its four handles do not lie in a plane) with one vn per vertex, four point handles
  // on vertices, all in one group turned 37 degrees.
  ScratchDir dir;
  const int n = 12;
  std::mt19937_64 g(44);
  std::normal_distribution<double> normal;
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -1, 0.6).normalized();
  const Eigen::Matrix3d R0 = Eigen::AngleAxisd(37 * std::numbers::pi / 180, axis).toRotationMatrix();
  const std::vector<int> handles{1 * n + 1, 1 * n + 10, 10 * n + 1, 10 * n + 10};
  std::string v, vn, f;
  std::vector<Eigen::Vector3d> normals;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = i / double(n - 1), y = j / double(n - 1);
      v += "v " + text(x) + " " + text(y) + " " + text(1.2 * (x - 0.5) * (y - 0.5)) + "\n";
      Eigen::Vector3d m(normal(g), normal(g), normal(g));
      if (std::find(handles.begin(), handles.end(), j * n + i) != handles.end())
        m = axis.cross(Eigen::Vector3d(normal(g), normal(g), normal(g)));  // off the axis: R0 turns it
      normals.push_back(m.normalized());
      vn += "vn " + text(m.x()) + " " + text(m.y()) + " " + text(m.z()) + "\n";
    }
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      f += "f";
      for (const int k : {j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i})
        f.append(" ").append(std::to_string(k + 1)).append("//").append(std::to_string(k + 1));
      f += "\n";
    }
  write_text(dir / "sheet.obj", v + vn + f);
  std::string json = "{\"points\": [";
  for (const int h : handles) json += (h == handles[0] ? "{\"vertex\": " : ", {\"vertex\": ") + std::to_string(h) + "}";
  json += "], \"groups\": [{\"points\": [0, 1, 2, 3], \"rotate\": {\"axis\": [0.3, -1, 0.6], \"degrees\": 37}}]}";
  write_text(dir / "h.json", json);
  std::vector<Eigen::Vector3d> want;
  for (const Eigen::Vector3d& m : normals) want.push_back(R0 * m);
  for (const int h : handles) REQUIRE((want[std::size_t(h)] - normals[std::size_t(h)]).norm() > 0.1);
  for (const std::string precision : {"float", "double"})
    for (const std::string transform : {"rigid", "similarity"})
      for (const bool on_the_fly : {false, true})
        for (const std::string backend : {"simd", "scalar"}) {
          INFO(precision << ", " << transform << ", " << (on_the_fly ? "--weight-budget 0" : "default storage") << ", "
                         << backend);
          std::vector<std::string> extra{"-f", "-q", "--precision", precision, "-t", transform, "--backend", backend};
          if (on_the_fly) extra.insert(extra.end(), {"--weight-budget", "0"});
          const auto r = cli_test::deform(dir / "sheet.obj", dir / "h.json", dir / "out.obj", extra);
          INFO(r.err);
          REQUIRE(r.exit_code == 0);
          CHECK(r.err.empty());
          const Mesh out = read_mesh(dir / "out.obj");
          CHECK(out.extras.obj->normals.size() == 3 * std::size_t(n * n));
          const Worst w = worst_normal(out, want);
          INFO("worst at vertex " << w.vertex);
          CHECK(w.error <= tolerance(precision));
        }
}

TEST_CASE("a motion of point and segment handles on vertices turns every normal of a point cloud",
          "[cli][attributes][handles]") {
  // Eight vertices with normals: four point handles (0-3, spanning 3D), a segment handle from vertex 4 to
  // vertex 5 with vertex 6 at its midpoint (on the segment, inside it), and vertex 7 on no handle. Every
  // handle moves by one motion: a quarter turn about x (a group: exact), or an affine shear (the targets
  // given). Vertices 4-6 have no fit of their own to any other handle than the segment's, and the points
  // next to it must not take the segment's frame.
  ScratchDir dir;
  const std::vector<Eigen::Vector3d> p{{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0, 0, 2},
                                       {0, 2, 2}, {2, 2, 2}, {1, 2, 2}, {1, 0.5, 0.75}};
  std::mt19937_64 g(45);
  std::normal_distribution<double> normal;
  std::vector<Eigen::Vector3d> normals;
  std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 8\nproperty double x\nproperty double y\nproperty double z\n"
      "property double nx\nproperty double ny\nproperty double nz\nend_header\n";
  for (const Eigen::Vector3d& q : p) {
    // Mostly across x, so that the quarter turn about x moves every normal by more than 1.
    const Eigen::Vector3d m = Eigen::Vector3d(0.3 * normal(g), 1 + 0.2 * normal(g), 1 + 0.2 * normal(g)).normalized();
    normals.push_back(m);
    ply += text(q.x()) + " " + text(q.y()) + " " + text(q.z()) + " " + text(m.x()) + " " + text(m.y()) + " " +
           text(m.z()) + "\n";
  }
  write_text(dir / "cloud.ply", ply);
  const std::string handles =
      "\"points\": [{\"vertex\": 0}, {\"vertex\": 1}, {\"vertex\": 2}, {\"vertex\": 3}], \"segments\": [{\"vertices\": "
      "[4, 5]}]";
  write_text(dir / "turn.json", "{" + handles +
                                    ", \"groups\": [{\"points\": [0, 1, 2, 3], \"segments\": [0], \"rotate\": "
                                    "{\"axis\": [1, 0, 0], \"degrees\": 90}}]}");
  Eigen::Matrix3d A;
  A << 1, 0.5, 0, 0, 1, 0.25, 0, 0, 1.5;  // a shear and a stretch: x -> A x + t
  const Eigen::Vector3d t(0.25, -1, 0.5);
  auto target = [&](int i) {
    const Eigen::Vector3d q = A * p[std::size_t(i)] + t;
    std::string xyz = "[";
    for (int c = 0; c < 3; ++c) xyz += text(q[c]) + (c < 2 ? ", " : "]");
    return xyz;
  };
  std::string shear = "{\"points\": [";
  for (int i = 0; i < 4; ++i)
    shear += (i ? ", {\"vertex\": " : "{\"vertex\": ") + std::to_string(i) + ", \"target\": " + target(i) + "}";
  shear += "], \"segments\": [{\"vertices\": [4, 5], \"target\": [" + target(4) + ", " + target(5) + "]}]}";
  write_text(dir / "shear.json", shear);
  const Eigen::Matrix3d R0 = Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  std::vector<Eigen::Vector3d> turned, sheared;
  for (const Eigen::Vector3d& m : normals) {
    turned.push_back(R0 * m);
    sheared.push_back((A.inverse().transpose() * m).normalized());
    REQUIRE((turned.back() - m).norm() > 0.1);
    REQUIRE((sheared.back() - m).norm() > 0.1);
  }
  // Segment handles are served by the precomputed table alone (on-the-fly weights take point handles only).
  for (const std::string motion : {"turn", "shear"})
    for (const std::string precision : {"float", "double"})
      for (const std::string weight : {"constant", "exact"})
        for (const std::string backend : {"simd", "scalar"}) {
          INFO(motion << ", " << precision << ", --segment-weight " << weight << ", " << backend);
          const auto r = cli_test::deform(dir / "cloud.ply", dir / (motion + ".json"), dir / "out.ply",
                                          {"-f", "-q", "--precision", precision, "--segment-weight", weight, "-t",
                                           motion == "turn" ? "rigid" : "affine", "--backend", backend});
          INFO(r.err);
          REQUIRE(r.exit_code == 0);
          CHECK(r.err.empty());
          const Worst w = worst_normal(read_mesh(dir / "out.ply"), motion == "turn" ? turned : sheared);
          INFO("worst at vertex " << w.vertex);
          CHECK(w.error <= tolerance(precision));
        }
}
