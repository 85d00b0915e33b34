// `--precision double` through the program: coordinates are read, deformed and written as doubles (the
// shortest text that reads back to the same double; binary PLY `double` properties), from 1e-300 to 1e300 and
// beyond float's range; a float PLY stays float unless --output-type says otherwise; the handles file's
// numbers are doubles. Float precision keeps reading and writing floats exactly as it did.
//
// Most cases make every vertex a point handle that stays where it is: such a vertex is put exactly on its
// target (the library's snapping), so the output must equal the input bit for bit, and any rounding on the way
// (reading, resolving handles, writing) shows.
#include "tests/cli/cli_test_util.hpp"
#include "tests/cli/precision_files.hpp"

#include "core/files/mesh.hpp"

#include "tests/support/catch.hpp"

#include <sys/stat.h>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

using namespace mlsdeform;
using namespace mlsdeform::files;
using namespace precision_test;
using cli_test::ScratchDir;
using cli_test::write_text;

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
      CHECK(text.find("property " + type + " x\nproperty " + type + " y\nproperty " + type + " z\n") !=
            std::string::npos);
      CHECK(text.find(" nx\n") == std::string::npos);  // the input has no normals: none are invented
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
