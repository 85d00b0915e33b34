// Input normals carried through each vertex's linear part (transform_normals, core/files/attributes_ops.cpp):
// n' = L^-T n renormalised, against a long-double reference; OBJ normals split per vertex where corners of
// vertices with different linear parts share one; what the program drops is named, and --strict-attributes
// refuses it.
#include "tests/cli/cube_fixture.hpp"

#include "core/files/file_io.hpp"
#include "core/files/mesh.hpp"

#include <Eigen/Dense>
#include "tests/support/catch.hpp"

#include <cmath>
#include <cstring>
#include <random>

using namespace mlsdeform;
using namespace mlsdeform::files;
using cli_test::ScratchDir;
using cli_test::write_text;

namespace {

using Mat = Eigen::Matrix<long double, 3, 3>;
using Vec = Eigen::Matrix<long double, 3, 1>;

// The reference: L^-T n / |L^-T n| in long double, from the float matrix as stored.
Vec reference(const float* l, const double* n) {
  Mat m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = l[3 * r + c];
  const Vec v = m.inverse().transpose() * Vec(n[0], n[1], n[2]);
  return v / v.norm();
}

// transform_normals computes in double: the cofactors (two products and a difference, each rounded once: at
// most 3 u of entries of magnitude <= 1 for the well-conditioned L used here), their product with a unit
// vector (three terms and two sums: <= 12 u), and the renormalisation (a square root, a division and the
// scaling: <= 4 u relative): under 16 u per component; 32 u leaves room for the reference's own rounding and
// for L^-T's norm of up to 2 in the similarity and affine cases (u = 2^-53).
const double kTolerance = 32 * std::ldexp(1.0, -53);

// Linear parts: rotations about different axes, a similarity (2 R), an affine map with det < 0, by vertex.
std::vector<float> linear_parts(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> angle(-3.1f, 3.1f);
  std::vector<float> l(9 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f axis = Eigen::Vector3f::Random().normalized();
    Eigen::Matrix3f m = Eigen::AngleAxisf(angle(rng), axis).toRotationMatrix();
    if (i % 3 == 1) m *= 2.0f;
    if (i % 3 == 2) m = m * Eigen::Vector3f(1.0f, -1.5f, 0.75f).asDiagonal();  // det < 0, non-uniform
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) l[9 * i + std::size_t(3 * r + c)] = m(r, c);
  }
  return l;
}

const char* cube_with_normals =
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
    "vn 0 0 -1\nvn 0 0 1\nvn 0 -1 0\nvn 1 0 0\nvn 0 1 0\nvn -1 0 0\n"
    "f 1//1 4//1 3//1 2//1\nf 5//2 6//2 7//2 8//2\nf 1//3 2//3 6//3 5//3\n"
    "f 2//4 3//4 7//4 6//4\nf 3//5 4//5 8//5 7//5\nf 4//6 1//6 5//6 8//6\n";

}  // namespace

TEST_CASE("OBJ normals: each corner's normal is its vertex's L^-T n, split per vertex", "[cli][attributes]") {
  ScratchDir dir;
  write_text(dir / "cube.obj", cube_with_normals);
  const Mesh rest = read_mesh(dir / "cube.obj");
  const std::uint64_t seed = std::random_device{}();
  INFO("seed " << seed);
  const std::vector<float> l = linear_parts(8, seed);
  Mesh m = rest;
  transform_normals(m, l.data());
  const ObjExtras& x = *m.extras.obj;
  CHECK(x.normals_rewritten);
  // Every vertex is in 3 faces with 3 different normals: 24 (vn, vertex) pairs, 24 normals.
  CHECK(x.normals.size() == 3 * 24);
  for (std::size_t c = 0; c < m.face_indices.size(); ++c) {
    const std::size_t v = m.face_indices[c], k = rest.extras.obj->corner_normals[c];
    const Vec want = reference(&l[9 * v], &rest.extras.obj->normals[3 * k]);
    for (int r = 0; r < 3; ++r)
      CHECK(std::fabs(double(x.normals[3 * x.corner_normals[c] + std::size_t(r)] - want(r))) <= kTolerance);
  }
  // Written and read back: the corners name the normals written, as floats (the mesh's type: the shortest
  // text of each float, which reads back to that float).
  write_mesh(m, dir / "out.obj", {true});
  const Mesh back = read_mesh(dir / "out.obj");
  REQUIRE(back.extras.obj->corner_normals.size() == m.face_indices.size());
  for (std::size_t c = 0; c < m.face_indices.size(); ++c)
    for (int r = 0; r < 3; ++r)
      CHECK(float(back.extras.obj->normals[3 * back.extras.obj->corner_normals[c] + std::size_t(r)]) ==
            float(x.normals[3 * x.corner_normals[c] + std::size_t(r)]));
  CHECK(back.face_indices == rest.face_indices);
}

TEST_CASE("OBJ normals: one vn shared by the corners of one vertex stays one", "[cli][attributes]") {
  ScratchDir dir;
  // Every corner of vertex i names vn i (smooth shading): 8 pairs, 8 normals, whatever the linear parts.
  std::string smooth = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";
  for (int i = 0; i < 8; ++i) smooth += "vn " + std::to_string(i & 1 ? 1 : -1) + " 1 0\n";
  smooth += "f 1//1 4//4 3//3 2//2\nf 5//5 6//6 7//7 8//8\nf 1//1 2//2 6//6 5//5\n";
  write_text(dir / "smooth.obj", smooth);
  Mesh m = read_mesh(dir / "smooth.obj");
  const std::vector<float> l = linear_parts(8, 7);
  transform_normals(m, l.data());
  CHECK(m.extras.obj->normals.size() == 3 * 8);
}

TEST_CASE("PLY normals: nx ny nz become L^-T n, renormalised; degenerate L keeps n", "[cli][attributes]") {
  ScratchDir dir;
  const std::uint64_t seed = std::random_device{}();
  INFO("seed " << seed);
  std::mt19937_64 rng(seed);
  const std::size_t n = 30;
  std::string ply = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(n) +
                    "\nproperty float x\nproperty float y\nproperty float z\nproperty double nx\nproperty double ny\n"
                    "property double nz\nproperty uchar red\nend_header\n";
  std::normal_distribution<double> g;
  std::vector<double> normals;
  for (std::size_t i = 0; i < n; ++i) {
    const double v[3] = {g(rng), g(rng), g(rng)};
    normals.insert(normals.end(), v, v + 3);
    ply += "0 0 " + std::to_string(i) + " " + std::to_string(v[0]) + " " + std::to_string(v[1]) + " " +
           std::to_string(v[2]) + " 9\n";
  }
  write_text(dir / "cloud.ply", ply);
  const Mesh rest = read_mesh(dir / "cloud.ply");
  for (std::size_t i = 0; i < n; ++i)  // the normals as read (std::to_string rounded them to 6 decimals)
    for (int c = 0; c < 3; ++c)
      normals[3 * i + std::size_t(c)] = rest.extras.ply->vertices().get(i, std::size_t(3 + c));
  std::vector<float> l = linear_parts(n, seed);
  std::fill(l.begin(), l.begin() + 9, 0.0f);                      // vertex 0: L = 0, no direction to give
  for (int k : {0, 1, 2, 3, 4, 5}) l[9 + std::size_t(k)] = 0.0f;  // vertex 1: rank 1
  l[9 + 6] = 1.0f;
  Mesh m = rest;
  transform_normals(m, l.data());
  const PlyElement& v = m.extras.ply->vertices();
  for (std::size_t i = 0; i < n; ++i) {
    INFO("vertex " << i);
    const double* n0 = &normals[3 * i];
    Vec want;
    if (i < 2)  // kept, unit length
      want = Vec(n0[0], n0[1], n0[2]).normalized();
    else
      want = reference(&l[9 * i], n0);
    for (int c = 0; c < 3; ++c) CHECK(std::fabs(double(v.get(i, std::size_t(3 + c)) - want(c))) <= kTolerance);
    CHECK(v.get(i, 6) == 9);  // the colour passes through
  }
}

TEST_CASE("attributes another format cannot keep are named; --strict-attributes refuses them", "[cli][attributes]") {
  const std::string cube_ply =
      "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
      "property uchar red\nelement face 6\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0 1\n1 0 0 2\n1 1 0 3\n0 1 0 4\n0 0 1 5\n1 0 1 6\n1 1 1 7\n0 1 1 8\n"
      "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n";
  cli_test::Fixture f;
  write_text(f.in + "/cube.ply", cube_ply);
  const auto kept = cli_test::deform(f.in + "/cube.ply", f.in + "/shear.json", f.out + "/a.ply");
  CHECK(kept.exit_code == 0);
  CHECK(kept.err.empty());
  CHECK(kept.out.find("attributes: kept vertex properties red\n") != std::string::npos);
  const auto dropped = cli_test::deform(f.in + "/cube.ply", f.in + "/shear.json", f.out + "/b.obj", {"-q"});
  CHECK(dropped.exit_code == 0);
  CHECK(dropped.err == "mlsdeform: dropped from " + f.in + "/cube.ply: vertex properties red\n");
  cli_test::Fixture g;  // its output folder stays empty
  write_text(g.in + "/cube.ply", cube_ply);
  cli_test::require_bad_input(
      g,
      {"deform", "-m", g.in + "/cube.ply", "-H", g.in + "/shear.json", "-o", g.out + "/c.obj", "--strict-attributes"},
      g.in + "/cube.ply: the output " + g.out + "/c.obj cannot keep: vertex properties red (--strict-attributes)");
}

TEST_CASE("normals computed on request: area-weighted, in place of the input's or added", "[cli][attributes]") {
  cli_test::Fixture f;
  // The cube has no normals: none are written by default, one per vertex on request (OBJ: f v//vn).
  const auto plain = cli_test::deform(f.in + "/cube.obj", f.in + "/shear.json", f.out + "/a.obj", {"-q"});
  REQUIRE(plain.exit_code == 0);
  CHECK(cli_test::read_text(f.out + "/a.obj").find("\nvn ") == std::string::npos);
  const auto computed =
      cli_test::deform(f.in + "/cube.obj", f.in + "/shear.json", f.out + "/b.obj", {"-q", "--normals", "computed"});
  REQUIRE(computed.exit_code == 0);
  const Mesh b = read_mesh(f.out + "/b.obj");
  CHECK(b.extras.obj->normals.size() == 3 * 8);
  CHECK(cli_test::read_text(f.out + "/b.obj").find("\nf 1//1 4//4 3//3 2//2\n") != std::string::npos);
  // A PLY with colours and no normals gets three new properties after its own, the colours kept.
  write_text(f.in + "/c.ply",
             "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
             "property uchar red\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
             "0 0 0 1\n1 0 0 2\n1 1 0 3\n0 1 0 4\n3 0 1 2\n3 0 2 3\n");
  write_text(f.in + "/still.json", R"({"points": [{"vertex": 0}, {"vertex": 2}]})");
  const auto ply = cli_test::deform(f.in + "/c.ply", f.in + "/still.json", f.out + "/c.ply",
                                    {"-q", "--normals", "computed", "--ply-ascii"});
  REQUIRE(ply.exit_code == 0);
  const std::string text = cli_test::read_text(f.out + "/c.ply");
  CHECK(text.find("property uchar red\nproperty float nx\nproperty float ny\nproperty float nz\n") !=
        std::string::npos);
  CHECK(text.find("\n0 0 0 1 0 0 1\n") != std::string::npos);  // the unit normal of the square in z = 0
}

TEST_CASE("normals computed on a file without faces are refused, the input's not written over", "[cli][attributes]") {
  // A point cloud has no faces to take normals from: every computed normal would be 0 0 0.
  cli_test::Fixture f;
  write_text(f.in + "/cloud.ply",
             "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
             "property float nx\nproperty float ny\nproperty float nz\nend_header\n"
             "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n0 0 1 1 0 0\n");
  write_text(f.in + "/cloud.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n");
  write_text(f.in + "/still.json", R"({"points": [{"vertex": 0}, {"vertex": 3, "offset": [0.1, 0, 0]}]})");
  for (const std::string mesh : {"cloud.ply", "cloud.obj"}) {
    INFO(mesh);
    cli_test::require_bad_input(f,
                                {"deform", "-m", f.in + "/" + mesh, "-H", f.in + "/still.json", "-o",
                                 f.out + "/out." + mesh.substr(6), "--normals", "computed"},
                                f.in + "/" + mesh +
                                    ": --normals computed needs a surface, and the mesh has no faces (a point "
                                    "cloud?); --normals input carries the file's own normals through the deformation");
  }
  // Without the option the cloud's own normals are carried through.
  const auto r = cli_test::deform(f.in + "/cloud.ply", f.in + "/still.json", f.out + "/a.ply", {"-q"});
  CHECK(r.exit_code == 0);
}

TEST_CASE("normals where the frame is exactly the identity are written as read, bit for bit", "[cli][attributes]") {
  // A strip of 2 x 10 vertices with a region on its right end (x >= 6), turned there by its handles; the left
  // end's frames are the identity (Options::region), so its normals, of length 3 and with more digits than a
  // float holds, stay as the file has them: PLY's values in their types, OBJ's vn lines as their text.
  ScratchDir dir;
  const char* vn_text[3] = {"vn 0 0 3", "vn 0.12345678901234567890 -0.5 2", "vn -0 4 0.5"};
  std::string obj, ply_float, ply_double;
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 20\nproperty float x\nproperty float y\nproperty float z\n"
      "property T nx\nproperty T ny\nproperty T nz\nelement face 9\nproperty list uchar int vertex_indices\n"
      "end_header\n";
  std::string body, faces, obj_v, obj_vn, obj_f;
  for (int k = 0; k < 20; ++k) {
    const int x = k % 10, y = k / 10;
    const std::string v = std::to_string(x) + " " + std::to_string(y) + " " + std::to_string(x % 2);
    const std::string n = std::string(vn_text[k % 3]).substr(3);
    body += v + " " + n + "\n";
    obj_v += "v " + v + "\n";
    obj_vn += std::string(vn_text[k % 3]) + "\n";
  }
  for (int x = 0; x + 1 < 10; ++x) {
    faces += "4 " + std::to_string(x) + " " + std::to_string(x + 1) + " " + std::to_string(x + 11) + " " +
             std::to_string(x + 10) + "\n";
    obj_f += "f";
    for (const int k : {x, x + 1, x + 11, x + 10})
      obj_f.append(" ").append(std::to_string(k + 1)).append("//").append(std::to_string(k + 1));
    obj_f += "\n";
  }
  for (const char* type : {"float", "double"}) {
    std::string h = header;
    for (std::size_t at; (at = h.find("property T ")) != std::string::npos;) h.replace(at + 9, 1, type);
    write_text(dir / (std::string("strip_") + type + ".ply"), h + body + faces);
  }
  write_text(dir / "strip.obj", obj_v + obj_vn + obj_f);
  write_text(dir / "h.json",
             R"({"points": [{"vertex": 8}, {"vertex": 9}, {"vertex": 18}, {"vertex": 19}, {"vertex": 6}],
                 "groups": [{"points": [0, 1, 2, 3, 4], "rotate": {"axis": [1, 1, 0], "degrees": 30}}],
                 "region": [6, 7, 8, 9, 16, 17, 18, 19]})");
  auto outside = [](std::size_t k) { return k % 10 < 6; };
  // Of the region's vertices, those off the handles (the handles' own frames are held by
  // test_cli_handle_frames.cpp): turned, so renormalised.
  auto turned = [](std::size_t k) { return k == 7 || k == 16 || k == 17; };
  for (const std::string precision : {"float", "double"})
    for (const std::string mesh : {"strip_float.ply", "strip_double.ply", "strip.obj"}) {
      INFO(precision << ", " << mesh);
      const std::string out = dir / ("out" + mesh.substr(mesh.find('.')));
      const auto r = cli_test::deform(dir / mesh, dir / "h.json", out, {"-f", "-q", "--precision", precision});
      INFO(r.err);
      REQUIRE(r.exit_code == 0);
      const Mesh a = read_mesh(dir / mesh), b = read_mesh(out);
      if (a.extras.ply) {
        const PlyElement &va = a.extras.ply->vertices(), &vb = b.extras.ply->vertices();
        for (std::size_t k = 0; k < 20; ++k) {
          INFO("vertex " << k);
          const Eigen::Vector3d na(va.get(k, 3), va.get(k, 4), va.get(k, 5)),
              nb(vb.get(k, 3), vb.get(k, 4), vb.get(k, 5));
          if (outside(k))
            CHECK(std::memcmp(na.data(), nb.data(), sizeof na) == 0);  // -0 stays -0
          else if (turned(k))
            CHECK(std::fabs(nb.norm() - 1) < 1e-6);
        }
        continue;
      }
      // OBJ: each corner's vn line, as text.
      auto vn_lines = [](const std::string& t) {
        std::vector<std::string> lines;
        for (std::size_t at = 0; at < t.size();) {
          const std::size_t nl = t.find('\n', at);
          if (t.compare(at, 3, "vn ") == 0) lines.push_back(t.substr(at, nl - at));
          at = nl + 1;
        }
        return lines;
      };
      const std::vector<std::string> la = vn_lines(cli_test::read_text(dir / mesh)),
                                     lb = vn_lines(cli_test::read_text(out));
      const ObjExtras &xa = *a.extras.obj, &xb = *b.extras.obj;
      REQUIRE(xb.corner_normals.size() == xa.corner_normals.size());
      for (std::size_t c = 0; c < xa.corner_normals.size(); ++c) {
        const std::size_t k = a.face_indices[c];
        INFO("corner " << c << ", vertex " << k);
        if (outside(k))
          CHECK(lb.at(xb.corner_normals[c]) == la.at(xa.corner_normals[c]));
        else if (turned(k))
          CHECK(std::fabs(Eigen::Vector3d(&xb.normals[3 * xb.corner_normals[c]]).norm() - 1) < 1e-6);
      }
    }
}

TEST_CASE("an affine fit turns normals by its matrix's inverse transpose", "[cli][attributes]") {
  // A 3 x 3 x 3 grid whose 8 corners (vertices 0-7, the cube fixture's order) are the shear fixture's handles:
  // every handle moves by x -> A x, A = [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]], which the affine fit reproduces,
  // so every vertex's linear part is A (the 8 on handles: the fit's limit there) and every
  // normal becomes A^-T n, renormalised.
  cli_test::Fixture f;
  std::vector<Eigen::Vector3d> points, normals;
  for (int i = 0; i < 8; ++i)  // the fixture's corners: 0 0 0, 1 0 0, 1 1 0, 0 1 0, then z = 1
    points.emplace_back(i % 4 == 1 || i % 4 == 2 ? 1 : 0, i % 4 >= 2 ? 1 : 0, i >= 4 ? 1 : 0);
  for (int z = 0; z < 3; ++z)
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 3; ++x)
        if (x == 1 || y == 1 || z == 1) points.emplace_back(0.5 * x, 0.5 * y, 0.5 * z);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g;
  std::string ply = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(points.size()) +
                    "\nproperty double x\nproperty double y\nproperty double z\nproperty double nx\n"
                    "property double ny\nproperty double nz\nend_header\n";
  for (const Eigen::Vector3d& p : points) {
    normals.emplace_back(g(rng), g(rng), g(rng));
    char line[256];
    std::snprintf(line, sizeof line, "%.17g %.17g %.17g %.17g %.17g %.17g\n", p[0], p[1], p[2], normals.back()[0],
                  normals.back()[1], normals.back()[2]);
    ply += line;
  }
  write_text(f.in + "/grid.ply", ply);
  const auto r =
      cli_test::deform(f.in + "/grid.ply", f.in + "/shear.json", f.out + "/a.ply",
                       {"-q", "-t", "affine", "--precision", "double", "--ply-ascii", "--strict-attributes"});
  REQUIRE(r.exit_code == 0);
  CHECK(r.err.empty());
  const Mesh out = read_mesh(f.out + "/a.ply");
  const PlyElement& v = out.extras.ply->vertices();
  Eigen::Matrix3d A = Eigen::Matrix3d::Identity();
  A(0, 1) = 0.5;
  // The double fit's L is A to a few hundred eps here ((2J + 2) eps + 16 kappa(G) eps of sum_j |q_j - c| |B_j|,
  // tests/test_frames_affine.cpp; kappa(G) and that sum are under 100 on this grid: below 1e-11); the normal
  // moves by at most 2 |A^-1| |dL| (|A^-1| < 1.3), then kTolerance's rounding of the transform and reference.
  const double tol = 2 * 1.3 * 1e-11 + kTolerance;
  for (std::size_t i = 0; i < points.size(); ++i) {
    INFO("vertex " << i);
    const Eigen::Vector3d want = (A.inverse().transpose() * normals[i]).normalized();
    for (int c = 0; c < 3; ++c) CHECK(std::fabs(double(v.get(i, std::size_t(3 + c))) - want(c)) <= tol);
  }
  // The program asks for the fit's matrix table (Options::affine_frames) only when it carries normals through L:
  // a budget of 4 KiB holds alpha (27 vertices padded to 32 x 8 handles x 8 bytes: 2 KiB) but not alpha and B_j
  // (8 KiB). Into OFF the normals are dropped and the deformation fits; into PLY they are carried, refused.
  const std::vector<std::string> budget{"-q", "-t", "affine", "--precision", "double", "--weight-budget", "0.00390625"};
  const auto off = cli_test::deform(f.in + "/grid.ply", f.in + "/shear.json", f.out + "/b.off", budget);
  CHECK(off.exit_code == 0);
  const auto carried = cli_test::deform(f.in + "/grid.ply", f.in + "/shear.json", f.out + "/b.ply", budget);
  CHECK(carried.exit_code == 2);
  CHECK(carried.err.find("precompute_budget_bytes") != std::string::npos);
}
