// End-to-end tests of the mlsdeform program on bad input: each kind ends with exit code 2, one line on stderr
// naming the file and the problem, and no output file and no temporary left.
#include "tests/cli/cli_test_util.hpp"
#include "tests/cli/cube_fixture.hpp"
#include "tests/cli/malformed_meshes.hpp"

#include "core/files/mesh.hpp"

#include "tests/support/catch.hpp"

#include <filesystem>
#include <string>

using namespace mlsdeform;
using namespace mlsdeform::files;
using cli_test::cube_obj;
using cli_test::Fixture;
using cli_test::program;
using cli_test::require_bad_input;
using cli_test::ScratchDir;
using cli_test::write_text;

TEST_CASE("deform: OBJ and OFF may start with a UTF-8 byte-order mark but PLY may not", "[cli][commands][errors]") {
  Fixture f;
  const std::string bom = "\xef\xbb\xbf", h = f.in + "/shear.json";
  write_text(f.in + "/bom.obj", bom + cube_obj);
  write_text(f.in + "/bom.off", bom + encode_mesh(cli_test::cube_mesh(), "cube.off"));
  write_text(f.in + "/bom.obj.gz", gzip(bom + cube_obj));
  const Mesh plain = read_mesh(f.in + "/cube.obj");
  for (const char* name : {"bom.obj", "bom.off", "bom.obj.gz"}) {
    INFO(name);
    const auto r =
        cli_test::run(program, {"deform", "-m", f.in + "/" + name, "-H", h, "-o", f.out + "/a.obj", "-q", "--force"});
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const Mesh m = read_mesh(f.in + "/" + name);
    CHECK(m.vertices == plain.vertices);
    CHECK(m.face_indices.size() == 24);
  }
  write_text(f.in + "/bom.ply", bom + encode_mesh(cli_test::cube_mesh(), "cube.ply", {false, PlyEncoding::ascii}));
  std::filesystem::remove(f.out + "/a.obj");
  require_bad_input(f, {"deform", "-m", f.in + "/bom.ply", "-H", h, "-o", f.out + "/a.obj"},
                    f.in +
                        "/bom.ply: line 1: malformed PLY: the file starts with a UTF-8 byte-order mark; the first "
                        "line must be 'ply' (remove the mark)");
  write_text(f.in + "/only_bom.obj", bom);
  require_bad_input(f, {"deform", "-m", f.in + "/only_bom.obj", "-H", h, "-o", f.out + "/a.obj"},
                    f.in + "/only_bom.obj: empty file (only a UTF-8 byte-order mark)");
}

TEST_CASE("deform: bad input files", "[cli][commands][errors]") {
  Fixture f;
  const std::string m = f.in + "/cube.obj", h = f.in + "/shear.json", o = f.out + "/a.obj";
  auto args = [&](const std::string& mesh, const std::string& handles, const std::string& out = "") {
    return std::vector<std::string>{"deform", "--mesh", mesh, "--handles", handles, "--out", out.empty() ? o : out};
  };

  SECTION("missing or unreadable files") {
    require_bad_input(f, args(f.in + "/nope.obj", h), f.in + "/nope.obj: cannot open: No such file or directory");
    require_bad_input(f, args(m, f.in + "/nope.json"), f.in + "/nope.json: cannot open: No such file or directory");
    require_bad_input(f, args(f.in, h), f.in + ": unknown mesh format (readable: " + readable_formats() + ")");
    std::filesystem::create_directory(f.in + "/dir.obj");
    require_bad_input(f, args(f.in + "/dir.obj", h), f.in + "/dir.obj: cannot read: is a directory");
    require_bad_input(f, args(m, f.in), f.in + ": cannot read: is a directory");
  }
  SECTION("malformed meshes") {
    write_text(f.in + "/bad.ply", "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\n");
    require_bad_input(f, args(f.in + "/bad.ply", h),
                      f.in + "/bad.ply: malformed PLY: the header has no end_header line");
    write_text(f.in + "/nan.obj", "v 0 0 0\nv 1 0 0\nv 1 NaN 0\nf 1 2 3\n");
    require_bad_input(f, args(f.in + "/nan.obj", h), f.in + "/nan.obj: line 3: vertex 2 has a non-finite coordinate");
    write_text(f.in + "/face.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
    require_bad_input(f, args(f.in + "/face.off", h),
                      f.in + "/face.off: line 6: face 0 refers to vertex 3, but there are only 3 vertices (0 to 2)");
    write_text(f.in + "/gz.ply.gz", "not gzip");
    require_bad_input(f, args(f.in + "/gz.ply.gz", h), f.in + "/gz.ply.gz: corrupt gzip data (incorrect header check)");
  }
  SECTION("every malformed mesh of the issue's findings, through the program") {
    for (const auto& c : cli_test::malformed_meshes()) {
      const std::string path = f.in + "/" + c.name;
      write_text(path, c.bytes);
      const auto r = cli_test::run(program, args(path, h));
      INFO(c.name << ": " << r.err);
      CHECK(r.exit_code == 2);
      CHECK(r.err.rfind("mlsdeform: error: " + path + ": ", 0) == 0);
      CHECK(r.err.find(c.expected) != std::string::npos);
      CHECK(cli_test::line_count(r.err) == 1);
      CHECK(f.outputs().empty());
    }
  }
  SECTION("inputs past the size limit are refused unread, and --max-input-mib raises the limit") {
    // The cube and 20 MiB of comment lines, which compress to a few tens of KiB: refused at 16 MiB while
    // decompressing.
    std::string big = cube_obj;
    while (big.size() < (std::size_t(20) << 20))
      big += "# a comment line of sixty-four bytes, to make a big file.........\n";
    write_text(f.in + "/big.obj.gz", gzip(big));
    auto a = args(f.in + "/big.obj.gz", h);
    a.insert(a.end(), {"--max-input-mib", "16"});
    require_bad_input(
        f, a, f.in + "/big.obj.gz: decompresses to more than the input limit of 16 MiB (--max-input-mib raises it)");
    write_text(f.in + "/big.obj", big);
    a = args(f.in + "/big.obj", h);
    a.insert(a.end(), {"--max-input-mib", "16"});
    require_bad_input(f, a,
                      f.in + "/big.obj: file too large: " + std::to_string(big.size()) +
                          " bytes, more than the input limit of 16 MiB (--max-input-mib raises it)");
    a.back() = "32";  // now read
    const auto r = cli_test::run(program, a);
    INFO(r.err);
    CHECK(r.exit_code == 0);
  }
  SECTION("malformed handles files") {
    const std::string j = f.in + "/h.json";
    write_text(j, "{\"points\": [{\"vertex\": 0,}]}");
    require_bad_input(f, args(m, j),
                      j + ": line 1, column 26: invalid JSON: syntax error while parsing object key - unexpected '}'; "
                          "expected string literal");
    write_text(j, "{\"points\": [{\"vertex\": 8}]}");
    require_bad_input(f, args(m, j),
                      j + ": /points/0/vertex: vertex index 8 out of range (the mesh has 8 vertices, 0 to 7)");
    write_text(j, "{\"points\": [{\"rest\": [0, NaN, 0]}]}");
    require_bad_input(
        f, args(m, j),
        j + ": line 1, column 26: invalid JSON: syntax error while parsing value - invalid literal; last read: '0, N'");
    write_text(j, "{\"points\": [{\"rest\": [0, \"NaN\", 0]}]}");
    require_bad_input(f, args(m, j), j + ": /points/0/rest/1: expected a number, found string");
    write_text(j, "{\"points\": [{\"vertex\": 0}], \"frames\": [{\"points\": [[0, 0, 0], [1, 1, 1]]}]}");
    require_bad_input(f, args(m, j), j + ": /frames/0/points: 2 entries, expected 1 (one per point handle)");
    write_text(j, "{\"points\": [], \"segments\": []}");
    require_bad_input(f, args(m, j), j + ": /: no handles (give at least one entry in \"points\" or \"segments\")");
    write_text(
        j, "{\"points\": [{\"vertex\": 0}, {\"vertex\": 1}, {\"vertex\": 2}, {\"vertex\": 3, \"offset\": [0, 0, 1]}]}");
    const auto r = cli_test::run(program, {"deform", "-m", m, "-H", j, "-o", o, "--transform", "affine"});
    CHECK(r.exit_code == 2);  // affine needs handles that span 3D; these four are coplanar
    CHECK(r.err.rfind("mlsdeform: error: " + j + ": ", 0) == 0);
    CHECK(r.err.find("coplanar") != std::string::npos);
    CHECK(f.outputs().empty());
  }
  SECTION("unwritable outputs") {
    require_bad_input(
        f, args(m, h, f.out + "/no/such/dir/a.obj"),
        f.out + "/no/such/dir/a.obj: cannot write: directory '" + f.out + "/no/such/dir': No such file or directory");
    require_bad_input(f, args(m, h, m + "/a.obj"), m + "/a.obj: cannot write: '" + m + "' is not a directory");
    std::filesystem::create_directory(f.in + "/dir.obj");
    require_bad_input(f, args(m, h, f.in + "/dir.obj"), f.in + "/dir.obj: cannot write: is a directory");
    require_bad_input(f, args(m, h, f.out), f.out + ": unknown output format (writable: " + writable_formats() + ")");
    require_bad_input(f, args(m, h, f.out + "/a.stl"),
                      f.out + "/a.stl: unknown output format '.stl' (writable: " + writable_formats() + ")");
  }
  SECTION("an animation that fails part-way leaves no frames behind") {
    // Frame 2's target is finite in float but beyond what the deformer accepts (max(float) / 64): frames 0
    // and 1 are written first, then removed.
    write_text(f.in + "/anim.json", R"({"points": [{"vertex": 0}, {"vertex": 6}],
      "frames": [{}, {"points": [null, [1, 1, 2]]}, {"points": [null, [1e37, 1, 1]]}]})");
    const auto r = cli_test::run(program, {"deform", "-m", m, "-H", f.in + "/anim.json", "-o", f.out + "/anim.obj"});
    INFO(r.out << r.err);
    CHECK(r.exit_code == 2);
    CHECK(r.err.rfind("mlsdeform: error: " + f.in + "/anim.json: /frames/2: ", 0) == 0);
    CHECK(cli_test::line_count(r.err) == 1);
    CHECK(r.out.find("frame 2/3") != std::string::npos);  // it did get that far
    CHECK(f.outputs().empty());
  }
}

TEST_CASE("deform: handles the library refuses end with exit 2, one line and no file", "[cli][commands][errors]") {
  Fixture f;
  const std::string m = f.in + "/cube.obj", o = f.out + "/a.obj";
  struct Case {
    const char* json;
    const char* message;
  };
  const Case cases[] = {
      // Two handles on one vertex moved apart: a vertex there cannot follow both.
      {R"({"points": [{"vertex": 0, "target": [1, 2, 3]}, {"vertex": 0, "target": [0, 0, 0]}, {"vertex": 6}]})",
       "point handles 0 and 1 share their rest position but have different targets"},
      // Affine segments over a tiny weight budget: refused instead of a table past the budget.
      {R"({"segments": [{"vertices": [0, 6], "offset": [0, 0, 1]}, {"vertices": [1, 7]}, {"vertices": [2, 4]}]})",
       "precompute_budget_bytes"},
  };
  for (std::size_t i = 0; i < 2; ++i) {
    cli_test::write_text(f.in + "/bad.json", cases[i].json);
    std::vector<std::string> args{"deform", "-m", m, "-H", f.in + "/bad.json", "-o", o};
    if (i == 1) args.insert(args.end(), {"--transform", "affine", "--weight-budget", "0.0001"});
    const auto r = cli_test::run(program, args);
    INFO(cases[i].json << "\nstderr: " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(r.err.find(cases[i].message) != std::string::npos);
    CHECK(cli_test::line_count(r.err) == 1);
    CHECK(f.outputs().empty());
  }
}
