// Through the program: a rigid (or similarity) motion of every handle turns every input normal by exactly
// that rotation, to the fit's bound, in a point-cloud PLY (real normals kept, transformed: not zeros) and in a
// flat-shaded OBJ (vn split per vertex); every other attribute passes bit for bit.
#include "tests/cli/cli_test_util.hpp"
#include "tests/support/accuracy_bounds.hpp"
#include "tests/support/deform_cases.hpp"
#include "tests/support/mls_reference.hpp"

#include "core/files/mesh.hpp"

#include "tests/support/catch.hpp"

#include <charconv>
#include <numbers>
#include <random>

using namespace mlsdeform;
using namespace mlsdeform::files;
using cli_test::ScratchDir;
using cli_test::write_text;

namespace {

std::string text(float v) {
  char b[32];
  return std::string(b, std::to_chars(b, b + 32, v).ptr);
}

/// The handles file: point handles at `rest` (not on vertices: each vertex's fit has data), moved to `moved`.
std::string handles_json(const Handles<float>& rest, const Handles<float>& moved) {
  std::string j = "{\"points\": [";
  for (Eigen::Index i = 0; i < rest.points.rows(); ++i) {
    j += std::string(i ? ", " : "") + "{\"rest\": [" + text(rest.points(i, 0)) + ", " + text(rest.points(i, 1)) + ", " +
         text(rest.points(i, 2)) + "], \"target\": [" + text(moved.points(i, 0)) + ", " + text(moved.points(i, 1)) +
         ", " + text(moved.points(i, 2)) + "]}";
  }
  return j + "]}";
}

/// The bound on |n' - R0 n| for a unit n at vertex v: the fit's |dR|_F (as test_frames.cpp derives it from
/// mls_reference.hpp: 2 (|dH|_F + 16 eps |H|_F) / gap plus R's departure from orthonormality) moves L^-T n by
/// at most |dR|_F to first order ((R0 + dR)^-T = R0 - R0 dR^T R0 + O(dR^2)), and renormalising at most
/// doubles that; the program computes in double and rounds each component to float once (sqrt(3) eps / 2 on
/// the vector). A similarity's scale s cancels in the renormalisation (its error divides by s >= 1).
double normal_bound(const testing::DirectVertex& dv) {
  const double eps = std::numeric_limits<float>::epsilon();
  const double tol_R = 2 * (dv.dH_unit + 16 * dv.norm_H) * eps / dv.gap + 1.5 * double(testing::c_o) * eps;
  return 2 * tol_R + std::sqrt(3.0) * eps / 2;
}

}  // namespace

TEST_CASE("a rigid motion of every handle turns every PLY normal by that rotation", "[cli][attributes]") {
  ScratchDir dir;
  std::mt19937_64 g(17);
  const testing::DeformCase<float> c = testing::random_case<float>(g, 200, 9);
  std::normal_distribution<float> normal;
  std::vector<Eigen::Vector3f> normals;
  std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 200\nproperty float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\nproperty uchar label\nend_header\n";
  for (Eigen::Index i = 0; i < 200; ++i) {
    const Eigen::Vector3f n = Eigen::Vector3f(normal(g), normal(g), normal(g)).normalized();
    normals.push_back(n);
    ply += text(c.vertices(i, 0)) + " " + text(c.vertices(i, 1)) + " " + text(c.vertices(i, 2)) + " " + text(n.x()) +
           " " + text(n.y()) + " " + text(n.z()) + " " + std::to_string(i % 256) + "\n";
  }
  write_text(dir / "cloud.ply", ply);
  const double l = testing::scene_size(c.vertices, c.rest);
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -1, 0.6).normalized(), shift(0.4, -0.2, 0.9);
  for (const Transform tr : {Transform::rigid, Transform::similarity})
    for (const double angle : {0.3, 2.0, std::numbers::pi - 1e-3}) {
      const char* name = tr == Transform::rigid ? "rigid" : "similarity";
      INFO(name << ", angle " << angle);
      const double s = tr == Transform::similarity ? 1.7 : 1.0;
      const Eigen::Matrix3d R0 = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
      const Handles<float> moved = testing::transformed(c.rest, s * R0, shift);
      write_text(dir / "h.json", handles_json(c.rest, moved));
      const auto r = cli_test::deform(dir / "cloud.ply", dir / "h.json", dir / "out.ply", {"-f", "-t", name});
      INFO(r.out << r.err);
      REQUIRE(r.exit_code == 0);
      CHECK(r.out.find("transformed normals (nx ny nz)") != std::string::npos);
      const Mesh m = read_mesh(dir / "out.ply");
      const PlyElement& v = m.extras.ply->vertices();
      Options o;
      o.transform = tr;
      double worst = 0;
      for (Eigen::Index i = 0; i < 200; ++i) {
        const testing::DirectVertex dv =
            testing::direct_vertex(c.vertices.row(i).cast<double>().transpose(), c.rest, moved, o, l);
        REQUIRE((!dv.snapped && dv.well_posed));
        const Eigen::Vector3d want = R0 * normals[std::size_t(i)].cast<double>();
        const Eigen::Vector3d got(v.get(std::size_t(i), 3), v.get(std::size_t(i), 4), v.get(std::size_t(i), 5));
        worst = std::max(worst, (got - want).norm() / normal_bound(dv));
        CHECK(v.get(std::size_t(i), 6) == double(i % 256));  // the label, as read
      }
      INFO("worst deviation / bound " << worst);
      CHECK(worst <= 1);
    }
}

TEST_CASE("a rigid motion turns a flat-shaded OBJ's normals, one vn per corner's vertex", "[cli][attributes]") {
  ScratchDir dir;
  write_text(dir / "cube.obj",
             "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
             "vt 0 0\nvn 0 0 -1\nvn 0 0 1\nvn 0 -1 0\nvn 1 0 0\nvn 0 1 0\nvn -1 0 0\nusemtl red\n"
             "f 1/1/1 4/1/1 3/1/1 2/1/1\nf 5//2 6//2 7//2 8//2\nf 1//3 2//3 6//3 5//3\n"
             "f 2//4 3//4 7//4 6//4\nf 3//5 4//5 8//5 7//5\nf 4//6 1//6 5//6 8//6\n");
  Handles<float> rest;
  rest.points.resize(5, 3);
  rest.points << 0.2f, 0.3f, 0.1f, 0.9f, 0.1f, 0.7f, 0.4f, 0.8f, 0.6f, 0.1f, 0.6f, 0.9f, 0.7f, 0.5f, 0.3f;
  const Eigen::Matrix3d R0 = Eigen::AngleAxisd(2.5, Eigen::Vector3d(1, 2, -0.5).normalized()).toRotationMatrix();
  const Handles<float> moved = testing::transformed(rest, R0, Eigen::Vector3d(1, 0, 0));
  write_text(dir / "h.json", handles_json(rest, moved));
  const auto r = cli_test::deform(dir / "cube.obj", dir / "h.json", dir / "out.obj");
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  const Mesh in = read_mesh(dir / "cube.obj"), out = read_mesh(dir / "out.obj");
  const ObjExtras &a = *in.extras.obj, &b = *out.extras.obj;
  CHECK(b.normals.size() == 3 * 24);  // 6 face normals, each at 4 vertices
  REQUIRE(b.corner_normals.size() == a.corner_normals.size());
  Points<float> cube = in.vertices;
  const double l = testing::scene_size(cube, rest);
  Options o;
  for (std::size_t k = 0; k < a.corner_normals.size(); ++k) {
    const testing::DirectVertex dv =
        testing::direct_vertex(cube.row(in.face_indices[k]).cast<double>().transpose(), rest, moved, o, l);
    const Eigen::Vector3d want = R0 * Eigen::Vector3d(&a.normals[3 * a.corner_normals[k]]);
    const Eigen::Vector3d got(&b.normals[3 * b.corner_normals[k]]);
    // The file's text of each float is read as double (the nearest to the decimal, within eps_f / 2 of it).
    CHECK((got - want).norm() <= normal_bound(dv) + std::sqrt(3.0) * std::numeric_limits<float>::epsilon() / 2);
  }
  // Everything else as read: the materials and the texture coordinate, and the corners' v/vt text.
  CHECK(cli_test::read_text(dir / "out.obj").find("\nmtllib m.mtl\nv ") != std::string::npos);
  CHECK(cli_test::read_text(dir / "out.obj").find("\nvt 0 0\nvn ") != std::string::npos);
  CHECK(cli_test::read_text(dir / "out.obj").find("\nusemtl red\nf 1/1/1 4/1/2 3/1/3 2/1/4\n") != std::string::npos);
}

TEST_CASE("normals at handle vertices turn with a rigid motion of the handles", "[cli][attributes]") {
  // Handles on vertices 0, 1, 3 and 4 of a cube of eight (each with all its neighbours on handles), a
  // point-cloud copy with the same handles, and the cube with every vertex a handle: the library's frame at a
  // vertex on a handle is the fit's limit there, so every normal turns, the handles' own too.
  ScratchDir dir;
  const std::string v = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";
  std::string vn, f;
  for (int i = 0; i < 8; ++i)
    vn += "vn " + std::to_string(i & 1 ? 1 : -1) + " " + std::to_string(i & 2 ? 1 : -1) + " 0.5\n";
  for (const char* face : {"1 4 3 2", "5 6 7 8", "1 2 6 5", "2 3 7 6", "3 4 8 7", "4 1 5 8"}) {
    f += "f";
    std::string s = face;
    for (std::size_t at = 0; at < s.size(); at += 2) f += std::string(" ") + s[at] + "//" + s[at];
    f += "\n";
  }
  write_text(dir / "cube.obj", v + vn + f);
  std::string cloud =
      "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\nend_header\n";
  for (int i = 0; i < 8; ++i)  // "x y z" of v line i, then vn i
    cloud += v.substr(std::size_t(8 * i + 2), 5) + " " + std::to_string(i & 1 ? 1 : -1) + " " +
             std::to_string(i & 2 ? 1 : -1) + " 0.5\n";
  write_text(dir / "cloud.ply", cloud);
  const Eigen::Matrix3d R0 = Eigen::AngleAxisd(1.2, Eigen::Vector3d(0.2, 1, 0.3).normalized()).toRotationMatrix();
  std::string handles = "{\"points\": [";
  const double corners[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  for (int i : {0, 1, 3, 4}) {
    const Eigen::Vector3d p(corners[i][0], corners[i][1], corners[i][2]), q = R0 * p;
    handles += std::string(i ? ", " : "") + "{\"vertex\": " + std::to_string(i) + ", \"target\": [" +
               text(float(q.x())) + ", " + text(float(q.y())) + ", " + text(float(q.z())) + "]}";
  }
  write_text(dir / "h.json", handles + "]}");
  for (const std::string mesh : {"cube.obj", "cloud.ply"}) {
    INFO(mesh);
    const std::string result = mesh == "cube.obj" ? "out.obj" : "out.ply";
    const auto r = cli_test::deform(dir / mesh, dir / "h.json", dir / result, {"-f", "-q"});
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    CHECK(r.err.empty());
    const Mesh in = read_mesh(dir / mesh), out = read_mesh(dir / result);
    if (in.extras.ply) {
      for (std::size_t i = 0; i < 8; ++i) {
        const PlyElement &a = in.extras.ply->vertices(), &b = out.extras.ply->vertices();
        const Eigen::Vector3d want = R0 * Eigen::Vector3d(a.get(i, 3), a.get(i, 4), a.get(i, 5)).normalized();
        CHECK((Eigen::Vector3d(b.get(i, 3), b.get(i, 4), b.get(i, 5)) - want).norm() < 1e-4);
      }
      continue;
    }
    const ObjExtras &a = *in.extras.obj, &b = *out.extras.obj;
    REQUIRE(a.corner_normals.size() == 24);
    // The handles' targets are floats of an exact rotation: every fit is R0 to a few hundred eps of float
    // (the four handles span 3D; test_frames.cpp bounds the fit), so 1e-4 tells a rotated normal from one
    // left as read (apart by |R0 n - n| >= 0.1 for these normals and this angle).
    for (std::size_t k = 0; k < a.corner_normals.size(); ++k) {
      const Eigen::Vector3d want = R0 * Eigen::Vector3d(&a.normals[3 * a.corner_normals[k]]).normalized();
      CHECK((Eigen::Vector3d(&b.normals[3 * b.corner_normals[k]]) - want).norm() < 1e-4);
    }
  }
  std::string all = "{\"points\": [";
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d q = R0 * Eigen::Vector3d(corners[i][0], corners[i][1], corners[i][2]);
    all += std::string(i ? ", " : "") + "{\"vertex\": " + std::to_string(i) + ", \"target\": [" + text(float(q.x())) +
           ", " + text(float(q.y())) + ", " + text(float(q.z())) + "]}";
  }
  write_text(dir / "all.json", all + "]}");
  const auto r = cli_test::deform(dir / "cube.obj", dir / "all.json", dir / "out.obj", {"-f", "-q"});
  REQUIRE(r.exit_code == 0);
  CHECK(r.err.empty());
  const Mesh in = read_mesh(dir / "cube.obj"), out = read_mesh(dir / "out.obj");
  const ObjExtras &a = *in.extras.obj, &b = *out.extras.obj;
  for (std::size_t k = 0; k < a.corner_normals.size(); ++k) {
    const Eigen::Vector3d want = R0 * Eigen::Vector3d(&a.normals[3 * a.corner_normals[k]]).normalized();
    CHECK((Eigen::Vector3d(&b.normals[3 * b.corner_normals[k]]) - want).norm() < 1e-4);
  }
}
