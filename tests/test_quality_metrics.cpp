// The shape-quality measures of the quality benchmark (tests/support/quality.hpp) and the mesh helpers they
// need: the OBJ and PLY triangle readers and the triangulated box surface.
#include "tests/support/meshes.hpp"
#include "tests/support/quality.hpp"

#include "tests/support/catch.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>

using namespace mlsdeform::testing;
using mlsdeform::Triangles;

namespace {

// A temporary file holding `text`, removed at scope exit.
struct TempFile {
  std::string path;
  explicit TempFile(const std::string& text)
      : path((std::filesystem::temp_directory_path() /
              ("mlsdeform_test_quality_" + std::to_string(reinterpret_cast<std::uintptr_t>(this)) + ".obj"))
                 .string()) {
    std::ofstream(path) << text;
  }
  ~TempFile() { std::remove(path.c_str()); }
};

PointsD grid_points(int n) {
  PointsD p(n * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) p.row(i * n + j) << j, i, 0.0;
  return p;
}

// (n - 1)^2 squares, each cut along the diagonal from its corner of smallest coordinates, counter-clockwise
// seen from +z.
Triangles grid_triangles(int n) {
  Triangles t(2 * (n - 1) * (n - 1), 3);
  int f = 0;
  for (int i = 0; i + 1 < n; ++i)
    for (int j = 0; j + 1 < n; ++j) {
      const int a = i * n + j, b = a + 1, c = a + n + 1, d = a + n;
      t.row(f++) << a, b, c;
      t.row(f++) << a, c, d;
    }
  return t;
}

}  // namespace

TEST_CASE("read_obj_triangles fans polygons and resolves index forms", "[quality]") {
  const TempFile f(
      "# comment\r\nv 0 0 0\r\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n"
      "f 1 2 3 4\nf 1/1/1 2//1 -1/1\nv 2 0 0\nf -5 -4 -1\n");
  const Triangles t = read_obj_triangles(f.path);
  REQUIRE(t.rows() == 4);
  CHECK(t.row(0) == Eigen::RowVector3i(0, 1, 2));
  CHECK(t.row(1) == Eigen::RowVector3i(0, 2, 3));
  CHECK(t.row(2) == Eigen::RowVector3i(0, 1, 3));
  CHECK(t.row(3) == Eigen::RowVector3i(0, 1, 4));
  CHECK(read_obj_vertices(f.path).rows() == 5);
  CHECK_THROWS_AS(read_obj_triangles(TempFile("v 0 0 0\nv 1 0 0\nf 1 2 3\n").path), std::runtime_error);
  CHECK_THROWS_AS(read_obj_triangles(TempFile("v 0 0 0\nv 1 0 0\nf 1 2\n").path), std::runtime_error);
  CHECK_THROWS_AS(read_obj_triangles(TempFile("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 0 1 2\n").path), std::runtime_error);
}

TEST_CASE("read_ply_vertices reads the faces, fanning polygons, and refuses bad indices", "[quality]") {
  // A binary little-endian PLY: 4 vertices (x, y, z float and a uchar the reader skips), a triangle and a quad.
  const auto ply = [](std::int32_t last_index) {
    std::string s =
        "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
        "property float z\nproperty uchar flag\nelement face 2\nproperty list uchar int vertex_indices\n"
        "end_header\n";
    const auto put = [&](const auto& v) { s.append(reinterpret_cast<const char*>(&v), sizeof v); };
    for (int i = 0; i < 4; ++i) {
      put(float(i)), put(float(2 * i)), put(float(-i));
      s.push_back('\x7f');
    }
    s.push_back('\x03');
    for (const std::int32_t c : {0, 1, 2}) put(c);
    s.push_back('\x04');
    for (const std::int32_t c : {0, 2, 1, last_index}) put(c);
    return s;
  };
  const TempFile good(ply(3));
  Triangles t;
  const PointsD p = read_ply_vertices(good.path, &t);
  REQUIRE(p.rows() == 4);
  CHECK(p.row(3) == Eigen::RowVector3d(3, 6, -3));
  REQUIRE(t.rows() == 3);
  CHECK(t.row(0) == Eigen::RowVector3i(0, 1, 2));
  CHECK(t.row(1) == Eigen::RowVector3i(0, 2, 1));
  CHECK(t.row(2) == Eigen::RowVector3i(0, 1, 3));
  CHECK(read_ply_vertices(good.path).rows() == 4);  // without faces: the face element is not read
  const TempFile bad(ply(4));
  CHECK_THROWS_WITH(read_ply_vertices(bad.path, &t), Catch::Matchers::ContainsSubstring("index out of range"));
  std::string cut = ply(3);
  cut.resize(cut.size() - 2);
  const TempFile truncated(cut);
  CHECK_THROWS_WITH(read_ply_vertices(truncated.path, &t), Catch::Matchers::ContainsSubstring("truncated face data"));
}

TEST_CASE("box_surface_triangles is a closed surface with outward normals", "[quality]") {
  const int a = 3, b = 2, c = 5;
  const PointsD p = box_surface(a, b, c);
  const Triangles t = box_surface_triangles(a, b, c);
  CHECK(t.rows() == 4 * (a * b + b * c + c * a));
  CHECK(t.minCoeff() >= 0);
  CHECK(t.maxCoeff() < p.rows());
  // Closed and consistently oriented: every directed edge once, and its reverse once.
  std::map<std::pair<int, int>, int> directed;
  for (Eigen::Index f = 0; f < t.rows(); ++f)
    for (int k = 0; k < 3; ++k) ++directed[{t(f, k), t(f, (k + 1) % 3)}];
  for (const auto& [e, count] : directed) {
    CHECK(count == 1);
    CHECK(directed.count({e.second, e.first}) == 1);
  }
  // Outward: the divergence theorem gives the box's volume, positive (exact in double: small integers).
  double six_volume = 0;
  for (Eigen::Index f = 0; f < t.rows(); ++f) six_volume += p.row(t(f, 0)).dot(p.row(t(f, 1)).cross(p.row(t(f, 2))));
  CHECK(six_volume == 6.0 * a * b * c);
}

TEST_CASE("quantile interpolates between ranks", "[quality]") {
  CHECK(quantile({5, 1, 3, 2, 4}, 0.5) == 3);
  CHECK(quantile({5, 1, 3, 2, 4}, 0.0) == 1);
  CHECK(quantile({5, 1, 3, 2, 4}, 1.0) == 5);
  CHECK(quantile({1, 2}, 0.25) == 1.25);
  CHECK_THROWS_AS(quantile({}, 0.5), std::invalid_argument);
}

TEST_CASE("shape_quality of rigid motions, scalings and a fold", "[quality]") {
  const PointsD p = box_surface(4, 3, 6);
  const Triangles t = box_surface_triangles(4, 3, 6);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(2.0, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();

  SECTION("a rigid motion is rigid, keeps lengths and flips nothing") {
    PointsD x = (p * R.transpose()).rowwise() + Eigen::RowVector3d(3, -1, 2);
    const ShapeQuality q = shape_quality(p, x, t);
    REQUIRE(q.rigidity.size() == std::size_t(p.rows()));
    // Coordinates up to ~10, so the rotated edges carry errors of a few eps times 10 and the fitted R a few
    // eps: relative residuals far below 1e-12.
    CHECK(quantile(q.rigidity, 1.0) < 1e-12);
    CHECK(quantile(q.edge_ratio, 0.0) == Catch::Approx(1).margin(1e-12));
    CHECK(quantile(q.edge_ratio, 1.0) == Catch::Approx(1).margin(1e-12));
    CHECK(q.flipped == 0);
    CHECK(q.triangles == t.rows());
  }
  SECTION("a uniform scale by s has rigidity |s - 1| everywhere and edge ratio s") {
    const PointsD x = 1.5 * p * R.transpose();
    const ShapeQuality q = shape_quality(p, x, t);
    CHECK(quantile(q.rigidity, 0.0) == Catch::Approx(0.5).epsilon(1e-12));
    CHECK(quantile(q.rigidity, 1.0) == Catch::Approx(0.5).epsilon(1e-12));
    CHECK(quantile(q.edge_ratio, 0.0) == Catch::Approx(1.5).epsilon(1e-12));
    CHECK(quantile(q.edge_ratio, 1.0) == Catch::Approx(1.5).epsilon(1e-12));
    CHECK(q.flipped == 0);
  }
  SECTION("turning the surface inside out (x -> -x at every vertex) flips triangles at the box's edges") {
    // A flat ring cannot tell a mirror image from a half turn (quality.hpp), but the rings that wrap a box
    // edge are not flat: their best rotation leaves those triangles facing inwards.
    PointsD x = p;
    x.col(0) *= -1;
    CHECK(shape_quality(p, x, t).flipped > 0);
  }
  SECTION("a vertex pushed across its neighbours folds exactly the triangles that turned over") {
    const int n = 7;
    const PointsD g = grid_points(n);
    const Triangles gt = grid_triangles(n);
    PointsD x = g;
    x.row(3 * n + 3) << 4.6, 3.2, 0;  // the centre vertex (3, 3) past its neighbour (4, 3)
    Eigen::Index turned = 0;          // in-plane signed area: negative means folded over
    for (Eigen::Index f = 0; f < gt.rows(); ++f) {
      const Eigen::Vector3d a = x.row(gt(f, 0)), b = x.row(gt(f, 1)), c = x.row(gt(f, 2));
      turned += (b - a).cross(c - a).z() < 0;
    }
    REQUIRE(turned > 0);
    const ShapeQuality q = shape_quality(g, x, gt);
    CHECK(q.flipped == turned);
  }
}

TEST_CASE("dihedral_change: 0 under rigid motions, the fold angle across a folded line", "[quality]") {
  const PointsD p = box_surface(4, 3, 6);
  const Triangles t = box_surface_triangles(4, 3, 6);
  // A closed surface: every edge is interior.
  CHECK(dihedral_change(p, p, t).size() == unique_edges(t).size());
  const Eigen::Matrix3d R = Eigen::AngleAxisd(2.0, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  const PointsD x = (p * R.transpose()).rowwise() + Eigen::RowVector3d(3, -1, 2);
  // Normals of unit-cell triangles at coordinates up to ~10 carry errors of a few eps times 10; atan2 keeps
  // the angle as accurate: far below 1e-9 degrees.
  for (double d : dihedral_change(p, x, t)) CHECK(d < 1e-9);

  // A grid folded by 60 degrees along its middle column x = 3: the edges on that line change by 60 degrees,
  // all others by 0.
  const int n = 7;
  const PointsD g = grid_points(n);
  const Triangles gt = grid_triangles(n);
  PointsD f = g;
  for (Eigen::Index i = 0; i < g.rows(); ++i)
    if (g(i, 0) > 3) f.row(i) << 3 + (g(i, 0) - 3) * 0.5, g(i, 1), (g(i, 0) - 3) * std::sqrt(0.75);
  const std::vector<double> d = dihedral_change(g, f, gt);
  const auto on_fold = std::count_if(d.begin(), d.end(), [](double a) { return std::abs(a - 60) < 1e-9; });
  const auto flat = std::count_if(d.begin(), d.end(), [](double a) { return a < 1e-9; });
  CHECK(on_fold == n - 1);  // the n - 1 grid edges along the fold line
  CHECK(std::size_t(on_fold + flat) == d.size());
}
