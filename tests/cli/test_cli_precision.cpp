// `--precision double` through the program: coordinates are read, deformed and written as doubles (the
// shortest text that reads back to the same double; binary PLY `double` properties), from 1e-300 to 1e300 and
// beyond float's range; a float PLY stays float unless --output-type says otherwise; the handles file's
// numbers are doubles. Float precision keeps reading and writing floats exactly as it did.
//
// Most cases make every vertex a point handle that stays where it is: such a vertex is put exactly on its
// target (the library's snapping), so the output must equal the input bit for bit, and any rounding on the way
// (reading, resolving handles, writing) shows.
#include "tests/cli/cli_test_util.hpp"
#include "tests/support/accuracy_bounds.hpp"

#include "tools/cli/mesh.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Eigenvalues>

#include <sys/stat.h>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

using namespace mlsdeform;
using namespace mlsdeform::cli;
using cli_test::ScratchDir;
using cli_test::write_text;

namespace {

const std::string program = MLSDEFORM_CLI;

template <class R>
std::string shortest(R v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// The spacing of doubles at |x|.
double ulp(double x) { return std::nextafter(std::abs(x), std::numeric_limits<double>::infinity()) - std::abs(x); }

using Rows = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

// Three faces on 8 vertices (a triangle, a quad and a triangle sharing an edge with it).
const std::vector<std::vector<int>> kFaces{{0, 1, 2}, {3, 4, 5, 6}, {5, 6, 7}};

std::string obj_text(const Rows& v) {
  std::string s = "# test\n";
  for (Eigen::Index i = 0; i < v.rows(); ++i)
    s += "v " + shortest(v(i, 0)) + " " + shortest(v(i, 1)) + " " + shortest(v(i, 2)) + "\n";
  for (const auto& f : kFaces) {
    s += "f";
    for (int c : f) s.append(" ").append(std::to_string(c + 1));
    s += "\n";
  }
  return s;
}

std::string off_text(const Rows& v) {
  std::string s = "OFF\n" + std::to_string(v.rows()) + " " + std::to_string(kFaces.size()) + " 0\n";
  for (Eigen::Index i = 0; i < v.rows(); ++i)
    s += shortest(v(i, 0)) + " " + shortest(v(i, 1)) + " " + shortest(v(i, 2)) + "\n";
  for (const auto& f : kFaces) {
    s += std::to_string(f.size());
    for (int c : f) s.append(" ").append(std::to_string(c));
    s += "\n";
  }
  return s;
}

// A PLY file with `type` ("float" or "double") x, y, z, written by hand (not by the program's writer).
std::string ply_text(const Rows& v, bool binary, const std::string& type) {
  std::string s = "ply\nformat " + std::string(binary ? "binary_little_endian" : "ascii") + " 1.0\nelement vertex " +
                  std::to_string(v.rows()) + "\nproperty " + type + " x\nproperty " + type + " y\nproperty " + type +
                  " z\nelement face " + std::to_string(kFaces.size()) +
                  "\nproperty list uchar int vertex_indices\nend_header\n";
  static_assert(std::endian::native == std::endian::little);
  for (Eigen::Index i = 0; i < v.rows(); ++i)
    for (int k = 0; k < 3; ++k) {
      if (binary && type == "double") {
        s.append(reinterpret_cast<const char*>(&v(i, k)), 8);
      } else if (binary) {
        const float f = float(v(i, k));
        s.append(reinterpret_cast<const char*>(&f), 4);
      } else {
        s.append(k ? " " : "").append(type == "double" ? shortest(v(i, k)) : shortest(float(v(i, k))));
        if (k == 2) s += "\n";
      }
    }
  for (const auto& f : kFaces) {
    if (binary) {
      s.push_back(char(f.size()));
      for (int c : f) s.append(reinterpret_cast<const char*>(&c), 4);
    } else {
      s += std::to_string(f.size());
      for (int c : f) s.append(" ").append(std::to_string(c));
      s += "\n";
    }
  }
  return s;
}

// Every vertex a point handle that stays at rest.
std::string all_handles(Eigen::Index n) {
  std::string s = R"({"points": [)";
  for (Eigen::Index i = 0; i < n; ++i) s += (i ? ", " : "") + std::string(R"({"vertex": )") + std::to_string(i) + "}";
  return s + "]}";
}

// 8 coordinates triples with full 53-bit mantissas and random signs, of magnitude about 10^e.
Rows random_points(std::mt19937_64& rng, int e) {
  Rows v(8, 3);
  std::uniform_real_distribution<double> mantissa(1.0, 10.0);
  for (Eigen::Index i = 0; i < v.rows(); ++i)
    for (int k = 0; k < 3; ++k) v(i, k) = (rng() & 1 ? -1 : 1) * mantissa(rng) * std::pow(10.0, e);
  return v;
}

// The `v` lines of an OBJ text.
std::vector<std::string> v_lines(const std::string& obj) {
  std::vector<std::string> lines;
  std::size_t i = 0;
  while (i < obj.size()) {
    const std::size_t j = std::min(obj.find('\n', i), obj.size());
    if (obj.compare(i, 2, "v ") == 0) lines.push_back(obj.substr(i, j - i));
    i = j + 1;
  }
  return lines;
}

void require_bitwise(const Rows& expected, const PointsRowMajor<double>& actual) {
  REQUIRE(actual.rows() == expected.rows());
  for (Eigen::Index i = 0; i < expected.rows(); ++i)
    for (int k = 0; k < 3; ++k) {
      INFO("vertex " << i << " coordinate " << k << ": expected " << shortest(expected(i, k)) << ", got "
                     << shortest(actual(i, k)));
      REQUIRE(std::bit_cast<std::uint64_t>(actual(i, k)) == std::bit_cast<std::uint64_t>(expected(i, k)));
    }
}

cli_test::Result deform(const std::vector<std::string>& args) {
  std::vector<std::string> all{"deform", "-q", "--force"};
  all.insert(all.end(), args.begin(), args.end());
  return cli_test::run(program, all);
}

}  // namespace

TEST_CASE("double precision: coordinates from 1e-300 to 1e300 go through the program bit for bit", "[cli][precision]") {
  ScratchDir dir;
  const std::uint64_t seed = std::random_device{}();
  INFO("seed " << seed);
  std::mt19937_64 rng(seed);
  write_text(dir / "h.json", all_handles(8));
  std::vector<std::pair<std::string, Rows>> sets;
  for (int e : {-300, -200, -100, -46, -38, -1, 0, 1, 38, 39, 100, 200, 300})
    sets.emplace_back("1e" + std::to_string(e), random_points(rng, e));
  Rows edges = random_points(rng, -308);  // subnormals, the smallest normal, the largest finite double
  edges.row(0) << std::numeric_limits<double>::denorm_min(), -2.5e-320, std::numeric_limits<double>::min();
  edges.row(1) << 1e-310, -std::numeric_limits<double>::min(), 0.0;
  sets.emplace_back("subnormal", edges);

  for (const auto& [name, v] : sets) {
    INFO("coordinates " << name);
    // OBJ in, OBJ out: the same shortest texts.
    write_text(dir / "in.obj", obj_text(v));
    auto r = deform({"-m", dir / "in.obj", "-H", dir / "h.json", "-o", dir / "out.obj", "--precision", "double"});
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    CHECK(v_lines(cli_test::read_text(dir / "out.obj")) == v_lines(obj_text(v)));
    require_bitwise(v, read_mesh<double>(dir / "out.obj").vertices);
    // OFF, ASCII PLY and binary PLY, each into its own format and into the others.
    write_text(dir / "in.off", off_text(v));
    write_text(dir / "in_ascii.ply", ply_text(v, false, "double"));
    write_text(dir / "in_binary.ply", ply_text(v, true, "double"));
    for (const char* in : {"in.off", "in_ascii.ply", "in_binary.ply"})
      for (const char* out : {"out.off", "out.ply", "out.ply.gz", "out.obj"})
        for (const bool ascii : {false, true}) {
          INFO(in << " -> " << out << (ascii ? " --ply-ascii" : ""));
          std::vector<std::string> args{"-m", dir / in, "-H", dir / "h.json", "-o", dir / out, "--precision", "double"};
          if (ascii) args.push_back("--ply-ascii");
          r = deform(args);
          INFO(r.err);
          REQUIRE(r.exit_code == 0);
          const auto m = read_mesh<double>(dir / out);
          require_bitwise(v, m.vertices);
          if (std::string(out).find("ply") != std::string::npos) CHECK(m.stored_type == CoordinateType::float64);
        }
  }
}

TEST_CASE("literals beyond float's range are refused in float with a reason and read in double",
          "[cli][precision][errors]") {
  ScratchDir dir;
  // Each vertex its own first coordinate, 1e39 or more from the others: every vertex is a handle that stays, and
  // the library puts a vertex on its handle's target exactly. (The deformer computes in a frame scaled to the
  // scene, here 2^-136: a target coordinate below 2^-1022 times that, about 1e-267, would be rounded to the
  // frame's subnormal spacing (docs/api.md), so the tiny literals stay above it; the whole double range is
  // read and written bit for bit by the round-trip tests above.)
  Rows v(8, 3);
  v << 1e39, 1e-46, -3.5e38, 2e39, -1e-45, 2.5e-210, 3e39, 0.1, 0.2, 4e39, 7e-200, -2e-50,  //
      5e39, 1, 1.0000000000000002, 6e39, 5e-47, 1e-40, -1e39, 3e38, 4e-220, -4e40, 1.2345678901234568e17, -3e38;
  write_text(dir / "in.obj", obj_text(v));
  write_text(dir / "h.json", all_handles(8));
  auto r = deform({"-m", dir / "in.obj", "-H", dir / "h.json", "-o", dir / "out.obj"});
  CHECK(r.exit_code == 2);
  CHECK(r.err == "mlsdeform: error: " + dir / "in.obj" +
                     ": line 2: number out of the range of float: '1e+39' (--precision double reads it)\n");
  CHECK(!std::filesystem::exists(dir / "out.obj"));
  // The literals as a user types them, not only as to_chars writes them.
  write_text(dir / "typed.obj",
             "v 1e39 1e-46 0\nv 1E-46 -1e39 1\nv 0 1 0\nv 1 1 1\nv 2 0 0\nv 0 2 0\nv 0 0 2\nv 3 3 3\n");
  r = deform({"-m", dir / "typed.obj", "-H", dir / "h.json", "-o", dir / "typed_out.obj"});
  CHECK(r.exit_code == 2);
  CHECK(r.err == "mlsdeform: error: " + dir / "typed.obj" +
                     ": line 1: number out of the range of float: '1e39' (--precision double reads it)\n");
  r = deform({"-m", dir / "typed.obj", "-H", dir / "h.json", "-o", dir / "typed_out.obj", "--precision", "double"});
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(v_lines(cli_test::read_text(dir / "typed_out.obj"))[0] == "v 1e+39 1e-46 0");
  CHECK(v_lines(cli_test::read_text(dir / "typed_out.obj"))[1] == "v 1e-46 -1e+39 1");

  r = deform({"-m", dir / "in.obj", "-H", dir / "h.json", "-o", dir / "out.obj", "--precision", "double"});
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(v_lines(cli_test::read_text(dir / "out.obj")) == v_lines(obj_text(v)));
  // A float output cannot hold 1e39: refused (exit 2, nothing written), never written as inf.
  r = deform({"-m", dir / "in.obj", "-H", dir / "h.json", "-o", dir / "f.ply", "--precision", "double", "--output-type",
              "float"});
  CHECK(r.exit_code == 2);
  CHECK(r.err == "mlsdeform: error: " + dir / "h.json" +
                     ": vertex 0's deformed position overflows float, the output's coordinate type "
                     "(--output-type double writes it)\n");
  CHECK(!std::filesystem::exists(dir / "f.ply"));
  // Beyond double's range, in double: refused as such.
  write_text(dir / "huge.obj", "v 1e309 0 0\nv 0 1 0\nv 0 0 1\n");
  r = deform({"-m", dir / "huge.obj", "-H", dir / "h.json", "-o", dir / "huge_out.obj", "--precision", "double"});
  CHECK(r.exit_code == 2);
  CHECK(r.err == "mlsdeform: error: " + dir / "huge.obj" + ": line 1: number out of the range of double: '1e309'\n");
}

TEST_CASE("a survey-grade OBJ: double keeps every digit and float rounds as it always did", "[cli][precision]") {
  ScratchDir dir;
  const std::uint64_t seed = std::random_device{}();
  INFO("seed " << seed);
  std::mt19937_64 rng(seed);
  // Easting, northing and height in metres to the millimetre: 10 significant digits, more than a float's 7.
  auto mm = [&](double base, double spread) {
    return std::round((base + std::uniform_real_distribution<double>(0, spread)(rng)) * 1000) / 1000;
  };
  Rows v(8, 3);
  for (Eigen::Index i = 0; i < v.rows(); ++i) v.row(i) << mm(5000000, 10), mm(4000000, 10), mm(100, 3);
  v.row(0) << 5000000.123, 4000000.456, 100.789;
  write_text(dir / "survey.obj", obj_text(v));
  write_text(dir / "h.json", all_handles(8));

  auto r = deform({"-m", dir / "survey.obj", "-H", dir / "h.json", "-o", dir / "d.obj", "--precision", "double"});
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(v_lines(cli_test::read_text(dir / "d.obj"))[0] == "v 5000000.123 4000000.456 100.789");
  CHECK(v_lines(cli_test::read_text(dir / "d.obj")) == v_lines(obj_text(v)));

  // Float precision is what it was: each coordinate the float nearest the file's text (here 0.123 m off).
  r = deform({"-m", dir / "survey.obj", "-H", dir / "h.json", "-o", dir / "f.obj"});
  REQUIRE(r.exit_code == 0);
  const Mesh f = read_mesh(dir / "f.obj");
  for (Eigen::Index i = 0; i < v.rows(); ++i)
    for (int k = 0; k < 3; ++k) {
      float nearest = 0;
      const std::string text = shortest(v(i, k));
      std::from_chars(text.data(), text.data() + text.size(), nearest);
      CHECK(f.vertices(i, k) == nearest);
    }
  CHECK(double(f.vertices(0, 0)) == 5000000.0);
}

TEST_CASE("a survey-grade lattice moved by nothing: handles exact and the rest within the rounding bound",
          "[cli][precision]") {
  // A 5 x 5 x 5 lattice near (5e6, 4e6, 100) with its 8 corners as handles at rest: the exact MLS result is
  // every vertex where it was (q_j = p_j: q* = p*, and R = I maximises trace(R^T H) for H = sum w phat phat^T,
  // symmetric positive semi-definite). The computed one differs by
  //   - the rotation's angle error, at most tol_angle(kappa) (tests/support/accuracy_bounds.hpp; kappa =
  //     s1 / (s2 + s3) of this H), which moves the vertex by at most that times |v - p*|;
  //   - q* = sum_j omega_j q_j summed in world coordinates: k products and k - 1 additions of terms up to
  //     max_j |q_j| (omega_j >= 0, sum 1), plus the rounding of omega_j itself (a few eps each): at most
  //     (k + 8) eps max_j |q_j,c| per coordinate c, and a half ulp for q* + R vhat;
  //   - vhat and p* in the deformer's local frame (coordinates up to the bounding-box diagonal): 16 eps diag.
  // Float precision, for scale: floats near 5e6 are 0.5 apart, 10^8 times this bound.
  ScratchDir dir;
  Rows v(125, 3);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> jitter(-0.5, 0.5);
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j)
      for (int k = 0; k < 5; ++k)
        v.row(25 * i + 5 * j + k) << std::round((5000000 + 2.5 * i + jitter(rng)) * 1000) / 1000,
            std::round((4000000 + 2.5 * j + jitter(rng)) * 1000) / 1000,
            std::round((100 + 0.75 * k + 0.2 * jitter(rng)) * 1000) / 1000;
  std::string obj;
  for (Eigen::Index i = 0; i < v.rows(); ++i)
    obj += "v " + shortest(v(i, 0)) + " " + shortest(v(i, 1)) + " " + shortest(v(i, 2)) + "\n";
  write_text(dir / "lattice.obj", obj);
  std::vector<int> corners;
  std::string json = R"({"points": [)";
  for (int i : {0, 4})
    for (int j : {0, 4})
      for (int k : {0, 4}) {
        corners.push_back(25 * i + 5 * j + k);
        json += (corners.size() > 1 ? ", " : "") + std::string(R"({"vertex": )") + std::to_string(corners.back()) + "}";
      }
  write_text(dir / "h.json", json + "]}");
  const auto r =
      deform({"-m", dir / "lattice.obj", "-H", dir / "h.json", "-o", dir / "out.obj", "--precision", "double"});
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const auto out = read_mesh<double>(dir / "out.obj").vertices;

  constexpr double eps = std::numeric_limits<double>::epsilon();
  const double k = double(corners.size());
  const Eigen::RowVector3d lo = v.colwise().minCoeff(), hi = v.colwise().maxCoeff();
  const double diag = (hi - lo).norm();
  Eigen::RowVector3d q_max = Eigen::RowVector3d::Zero();
  for (int c : corners) q_max = q_max.cwiseMax(v.row(c).cwiseAbs());
  for (Eigen::Index i = 0; i < v.rows(); ++i) {
    INFO("vertex " << i);
    if (std::find(corners.begin(), corners.end(), int(i)) != corners.end()) {
      CHECK(out.row(i) == v.row(i));  // put exactly on its target
      continue;
    }
    // The weights w_j = |p_j - v|^-2 (u = 2), p*, and H's singular values (its eigenvalues: H is PSD).
    Eigen::RowVector3d p_star = Eigen::RowVector3d::Zero();
    double w_sum = 0;
    std::vector<double> w;
    for (int c : corners) {
      w.push_back(1 / (v.row(c) - v.row(i)).squaredNorm());
      w_sum += w.back();
      p_star += w.back() * v.row(c);
    }
    p_star /= w_sum;
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    for (std::size_t j = 0; j < corners.size(); ++j) {
      const Eigen::Vector3d ph = (v.row(corners[j]) - p_star).transpose();
      H += w[j] * ph * ph.transpose();
    }
    const Eigen::Vector3d s = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(H).eigenvalues();  // ascending
    const double kappa = s[2] / (s[1] + s[0]);
    const double angle = double(testing::tol_angle<double>(kappa, testing::c_b_uniform));
    for (int c = 0; c < 3; ++c) {
      const double bound =
          angle * (v.row(i) - p_star).norm() + (k + 8) * eps * q_max[c] + 0.5 * ulp(v(i, c)) + 16 * eps * diag;
      const double error = std::abs(out(i, c) - v(i, c));
      INFO("coordinate " << c << ": error " << error << ", bound " << bound << ", kappa " << kappa);
      CHECK(error <= bound);
    }
  }
}

TEST_CASE("the output's coordinate type follows the input PLY unless --output-type chooses", "[cli][precision]") {
  ScratchDir dir;
  std::mt19937_64 rng(11);
  const Rows v = random_points(rng, 0);
  write_text(dir / "h.json", all_handles(8));
  write_text(dir / "f.ply", ply_text(v, true, "float"));
  write_text(dir / "d.ply", ply_text(v, true, "double"));
  write_text(dir / "in.obj", obj_text(v));
  Rows v_float = v.cast<float>().cast<double>();
  struct Case {
    const char* in;
    std::vector<std::string> options;
    CoordinateType expected;
    const Rows* values;
  };
  const std::vector<Case> cases{
      {"f.ply", {"--precision", "double"}, CoordinateType::float32, &v_float},
      {"d.ply", {"--precision", "double"}, CoordinateType::float64, &v},
      {"in.obj", {"--precision", "double"}, CoordinateType::float64, &v},
      {"d.ply", {}, CoordinateType::float32, &v_float},  // float precision writes floats, as it always did
      {"in.obj", {}, CoordinateType::float32, &v_float},
      {"f.ply", {"--precision", "double", "--output-type", "double"}, CoordinateType::float64, &v_float},
      {"d.ply", {"--precision", "double", "--output-type", "float"}, CoordinateType::float32, &v_float},
      {"in.obj", {"--output-type", "double"}, CoordinateType::float64, &v_float},  // floats, widened exactly
      {"d.ply", {"--precision", "double", "--output-type", "auto"}, CoordinateType::float64, &v},
  };
  for (const Case& c : cases) {
    for (const bool ascii : {false, true}) {
      std::vector<std::string> args{"-m", dir / c.in, "-H", dir / "h.json", "-o", dir / "out.ply"};
      args.insert(args.end(), c.options.begin(), c.options.end());
      if (ascii) args.push_back("--ply-ascii");
      INFO(Catch::Detail::stringify(args));
      const auto r = deform(args);
      INFO(r.err);
      REQUIRE(r.exit_code == 0);
      const std::string type = c.expected == CoordinateType::float32 ? "float" : "double";
      const std::string text = cli_test::read_text(dir / "out.ply");
      CHECK(text.find("property " + type + " x\nproperty " + type + " y\nproperty " + type + " z\nproperty " + type +
                      " nx\n") != std::string::npos);
      const auto m = read_mesh<double>(dir / "out.ply");
      CHECK(m.stored_type == c.expected);
      require_bitwise(*c.values, m.vertices);
    }
  }
  // OBJ output with --output-type float: the shortest text of each float.
  const auto r = deform({"-m", dir / "in.obj", "-H", dir / "h.json", "-o", dir / "out.obj", "--precision", "double",
                         "--output-type", "float"});
  REQUIRE(r.exit_code == 0);
  const auto lines = v_lines(cli_test::read_text(dir / "out.obj"));
  REQUIRE(lines.size() == 8);
  CHECK(lines[0] == "v " + shortest(float(v(0, 0))) + " " + shortest(float(v(0, 1))) + " " + shortest(float(v(0, 2))));
}

TEST_CASE("the handles file's numbers are doubles in double precision", "[cli][precision][handles]") {
  ScratchDir dir;
  Rows v(8, 3);
  v << 5000000.123, 4000000.456, 100.789, 5000001.25, 4000000.5, 100.5, 5000000.5, 4000002.75, 101.25,  //
      5000002.125, 4000003.375, 99.5, 4999999.5, 4000001.5, 102.25, 5000003.5, 4000000.25, 100.125,     //
      5000001.5, 4000001.5, 103.5, 5000000.25, 4000003.5, 101.5;
  write_text(dir / "in.obj", obj_text(v));
  // Vertex 0 to a target with 16 significant digits, vertex 1 by a small offset, a rest position given by
  // coordinates (vertex 2's) that moves to another; the other vertices stay.
  std::string json = R"({"points": [{"vertex": 0, "target": [5000000.123456789, 4000000.000000001, 100.00000000000001]},
    {"vertex": 1, "offset": [1e-9, -2e-9, 3e-12]},
    {"rest": [5000000.5, 4000002.75, 101.25], "target": [5000000.500000001, 4000002.7500000005, 101.25000000000001]})";
  for (int i = 3; i < 8; ++i) json += R"(, {"vertex": )" + std::to_string(i) + "}";
  write_text(dir / "h.json", json + "]}");
  const auto r = deform({"-m", dir / "in.obj", "-H", dir / "h.json", "-o", dir / "out.obj", "--precision", "double"});
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  Rows expected = v;
  expected.row(0) << 5000000.123456789, 4000000.000000001, 100.00000000000001;
  expected.row(1) += Eigen::RowVector3d(1e-9, -2e-9, 3e-12);  // rest + offset, in double as the program adds them
  expected.row(2) << 5000000.500000001, 4000002.7500000005, 101.25000000000001;
  require_bitwise(expected, read_mesh<double>(dir / "out.obj").vertices);
  CHECK(v_lines(cli_test::read_text(dir / "out.obj"))[0] == "v 5000000.123456789 4000000.000000001 100.00000000000001");
}
