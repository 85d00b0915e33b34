// End-to-end tests of the handles file's "region" (Options::region): the vertices outside it are written
// exactly as read, the region follows the handles, a point cloud gets its ring from the nearest vertices,
// and bad regions end with exit code 2, one line naming the file and the JSON path, and nothing written.
#include "tests/cli/cli_test_util.hpp"

#include "core/files/mesh.hpp"
#include "tools/cli/primitives.hpp"

#include "tests/support/catch.hpp"

#include <filesystem>
#include <string>
#include <vector>

using namespace mlsdeform;
using namespace mlsdeform::files;
using namespace mlsdeform::cli;
using cli_test::program;
using cli_test::ScratchDir;
using cli_test::write_text;

namespace {

// A 0.5 x 3 x 0.5 bar of quads; the region is its top half (y > 1.5), moved by its four top corners.
struct RegionCase {
  ScratchDir dir;
  std::string mesh = dir / "bar.obj";
  Mesh bar = make_bar(2, 12, 2, 0.5, 3.0);
  std::vector<Eigen::Index> region, top;
  std::string points, region_json;
  RegionCase() {
    write_mesh(bar, mesh);
    for (Eigen::Index i = 0; i < bar.vertex_count(); ++i) {
      const auto p = bar.vertices.row(i);
      if (p(1) > 1.5f) region.push_back(i);
      if (p(1) == 3.0f && std::abs(p(0)) == 0.25f && std::abs(p(2)) == 0.25f) top.push_back(i);
    }
    points = "[";
    for (std::size_t k = 0; k < top.size(); ++k)
      points += R"({"vertex": )" + std::to_string(top[k]) + R"(, "offset": [0.5, -0.2, 0]})" +
                (k + 1 < top.size() ? ", " : "]");
    region_json = "[";
    for (std::size_t k = 0; k < region.size(); ++k)
      region_json += std::to_string(region[k]) + (k + 1 < region.size() ? ", " : "]");
  }
  cli_test::Result deform(const std::string& json, const std::string& out,
                          const std::vector<std::string>& extra = {}) const {
    write_text(dir / "h.json", json);
    return cli_test::deform(mesh, dir / "h.json", out, extra);
  }
};

}  // namespace

TEST_CASE("deform with a region: the rest of the mesh is written as read", "[cli][region]") {
  RegionCase c;
  REQUIRE(c.top.size() == 4);
  for (const char* precision : {"float", "double"}) {
    INFO(precision);
    const std::string out = c.dir / (std::string("out_") + precision + ".ply");
    const auto r = c.deform(R"({"points": )" + c.points + R"(, "region": )" + c.region_json + "}", out,
                            {"--precision", precision});
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    CHECK(r.out.find("a region of " + std::to_string(c.region.size()) + " vertices") != std::string::npos);
    const Mesh m = read_mesh(out);
    REQUIRE(m.vertex_count() == c.bar.vertex_count());
    std::vector<char> in(std::size_t(m.vertex_count()), 0);
    for (auto i : c.region) in[std::size_t(i)] = 1;
    Eigen::Index outside_moved = 0;
    for (Eigen::Index i = 0; i < m.vertex_count(); ++i)
      if (!in[std::size_t(i)] && m.vertices.row(i) != c.bar.vertices.row(i)) ++outside_moved;
    CHECK(outside_moved == 0);  // bitwise: floats round-trip exactly
    for (auto i : c.top)
      CHECK((m.vertices.row(i) - c.bar.vertices.row(i) - Eigen::RowVector3f(0.5f, -0.2f, 0)).norm() < 1e-5f);
  }
  // A point cloud (no faces): the ring comes from the nearest vertices.
  write_text(c.dir / "cloud.obj", [&] {
    std::string s;
    for (Eigen::Index i = 0; i < c.bar.vertex_count(); ++i)
      s += "v " + std::to_string(c.bar.vertices(i, 0)) + " " + std::to_string(c.bar.vertices(i, 1)) + " " +
           std::to_string(c.bar.vertices(i, 2)) + "\n";
    return s;
  }());
  write_text(c.dir / "h.json", R"({"points": )" + c.points + R"(, "region": )" + c.region_json + "}");
  const auto r = cli_test::run(
      program, {"deform", "-m", c.dir / "cloud.obj", "-H", c.dir / "h.json", "-o", c.dir / "cloud_out.obj", "-q"});
  INFO(r.err);
  CHECK(r.exit_code == 0);
  const Mesh cloud = read_mesh(c.dir / "cloud.obj"), moved = read_mesh(c.dir / "cloud_out.obj");
  CHECK(moved.vertices.row(0) == cloud.vertices.row(0));  // vertex 0 is at the bottom, outside the region
}

TEST_CASE("deform with a region: bad regions are refused", "[cli][region][errors]") {
  RegionCase c;
  const std::string out = c.dir / "out.obj", file = c.dir / "h.json";
  const std::string n = std::to_string(c.bar.vertex_count());
  const std::string pre = R"({"points": )" + c.points + R"(, "region": )";
  struct Bad {
    std::string region, message;
  };
  const std::vector<Bad> bad = {
      {"[1, " + n + "]", "/region/1: vertex index " + n + " out of range (the mesh has " + n + " vertices, 0 to " +
                             std::to_string(c.bar.vertex_count() - 1) + ")"},
      {"[1, -3]", "/region/1: vertex index -3 is negative"},
      {"[4, 2, 4]", "/region/2: vertex 4 is listed twice (first at /region/0)"},
      {"[]", "/region: no vertices (leave \"region\" out to deform the whole mesh)"},
      {"[1.5]", "/region/0: expected a vertex index (an integer from 0), found 1.5"},
      {"7", "/region: expected an array of vertex indices, found number"},
  };
  for (const Bad& b : bad) {
    const auto r = c.deform(pre + b.region + "}", out);
    INFO(b.region << ": " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(r.err == "mlsdeform: error: " + file + ": " + b.message + "\n");
    CHECK(!std::filesystem::exists(out));
  }
  const auto r = c.deform(pre + "[1, 2]}", out, {"--arap", "2"});
  INFO(r.err);
  CHECK(r.exit_code == 2);
  CHECK(r.err ==
        "mlsdeform: error: " + file + ": /region: a region and --arap cannot be combined (give one or the other)\n");
  CHECK(!std::filesystem::exists(out));
}
