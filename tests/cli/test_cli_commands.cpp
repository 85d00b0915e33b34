// End-to-end tests of the mlsdeform program: each subcommand on small inputs, and each kind of bad input
// (exit code 2, one line on stderr naming the file and the problem, no output file and no temporary left).
#include "tests/cli/cli_test_util.hpp"
#include "tests/cli/malformed_meshes.hpp"

#include "tools/cli/mesh.hpp"

#include <catch2/catch.hpp>

#include <csignal>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

using namespace mlsdeform;
using namespace mlsdeform::cli;
using cli_test::ScratchDir;
using cli_test::write_text;

namespace {

const std::string program = MLSDEFORM_CLI;

// A 2 x 2 x 2 grid of vertices (a cube's corners and no more), six quad faces.
const char* cube_obj =
    "# unit cube\n"
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

// Bottom corners fixed, top corners moved 0.5 along x.
const char* shear_json = R"({
  "points": [{"vertex": 0}, {"vertex": 1}, {"vertex": 4}, {"vertex": 5},
             {"vertex": 2, "offset": [0.5, 0, 0]}, {"vertex": 3, "offset": [0.5, 0, 0]},
             {"vertex": 6, "offset": [0.5, 0, 0]}, {"vertex": 7, "offset": [0.5, 0, 0]}]
})";

struct Fixture {
  ScratchDir dir;
  std::string in, out;  // inputs here; outputs there, so that "no output" means an empty folder
  Fixture() {
    in = (dir.path() / "in").string();
    out = (dir.path() / "out").string();
    std::filesystem::create_directory(in);
    std::filesystem::create_directory(out);
    write_text(in + "/cube.obj", cube_obj);
    write_text(in + "/shear.json", shear_json);
  }
  std::vector<std::string> outputs() const {
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(out)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }
};

// A bad-input run: exit code 2, exactly one line on stderr that is `expected`, nothing in the output folder.
void require_bad_input(const Fixture& f, const std::vector<std::string>& args, const std::string& expected) {
  const auto r = cli_test::run(program, args);
  INFO("args: " << Catch::Detail::stringify(args) << "\nstdout: " << r.out << "\nstderr: " << r.err);
  CHECK(r.exit_code == 2);
  CHECK(r.err == "mlsdeform: error: " + expected + "\n");
  CHECK(f.outputs().empty());
}

}  // namespace

TEST_CASE("usage: --help, --version, no arguments, bad options", "[cli][commands]") {
  auto r = cli_test::run(program, {"--help"});
  CHECK(r.exit_code == 0);
  CHECK(r.out.find("deform") != std::string::npos);
  CHECK(r.out.find("demo") != std::string::npos);
  CHECK(r.out.find("figures") != std::string::npos);
  r = cli_test::run(program, {"deform", "--help"});
  CHECK(r.exit_code == 0);
  for (const char* opt : {"--mesh", "--handles", "--out", "--transform", "--exponent", "--method", "--precision",
                          "--threads", "--force", "horn_quaternion", "similarity"})
    CHECK(r.out.find(opt) != std::string::npos);
  r = cli_test::run(program, {"--version"});
  CHECK(r.exit_code == 0);
  r = cli_test::run(program, {});
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("Usage") != std::string::npos);

  Fixture f;
  const std::string m = f.in + "/cube.obj", h = f.in + "/shear.json", o = f.out + "/a.obj";
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"deform", "--mesh", m, "--handles", h},  // no --out
        {"deform", "-m", m, "-H", h, "-o", o, "--transform", "conformal"},
        {"deform", "-m", m, "-H", h, "-o", o, "--exponent", "0.5"},
        {"deform", "-m", m, "-H", h, "-o", o, "--exponent", "nan"},
        {"deform", "-m", m, "-H", h, "-o", o, "--method", "euler"},
        {"deform", "-m", m, "-H", h, "-o", o, "--precision", "half"},
        {"deform", "-m", m, "-H", h, "-o", o, "--threads", "-1"},
        {"frobnicate"}}) {
    r = cli_test::run(program, args);
    INFO(Catch::Detail::stringify(args) << "\nstderr: " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(r.err.rfind("mlsdeform: error: ", 0) == 0);
    CHECK(cli_test::line_count(r.err) == 1);
    CHECK(f.outputs().empty());
  }
}

TEST_CASE("deform: every transform, method and precision writes the mesh with its faces", "[cli][commands]") {
  Fixture f;
  const std::string m = f.in + "/cube.obj", h = f.in + "/shear.json";
  int k = 0;
  for (const char* transform : {"rigid", "similarity", "affine"})
    for (const char* method : {"axis_angle", "horn_quaternion", "horn_matrix", "kanatani", "svd"})
      for (const char* precision : {"float", "double"}) {
        const std::string o = f.out + "/r" + std::to_string(k++) + ".ply";
        const auto r = cli_test::run(program, {"deform", "-m", m, "-H", h, "-o", o, "-t", transform, "--method", method,
                                               "--precision", precision, "-u", "3", "-j", "1"});
        INFO(transform << " " << method << " " << precision << "\n" << r.out << r.err);
        REQUIRE(r.exit_code == 0);
        CHECK(r.err.empty());
        CHECK(r.out.find("deformed in") != std::string::npos);
        const Mesh result = read_mesh(o);
        REQUIRE(result.vertex_count() == 8);
        CHECK(result.face_count() == 6);
        CHECK(result.face_start[1] == 4);  // quads stay quads
        // Handles on vertices: those vertices land on their targets (the deformer interpolates).
        CHECK((result.vertices.row(6) - Eigen::RowVector3f(1.5f, 1, 1)).norm() < 1e-5f);
        CHECK((result.vertices.row(0) - Eigen::RowVector3f(0, 0, 0)).norm() < 1e-5f);
      }
}

TEST_CASE("deform: each format in, each format out", "[cli][commands]") {
  Fixture f;
  const std::string h = f.in + "/shear.json";
  std::string previous = f.in + "/cube.obj";
  for (const char* ext : {"off", "ply", "ply.gz", "obj.gz", "off.gz", "obj"}) {
    const std::string o = f.out + "/cube." + ext;
    const auto r = cli_test::run(program, {"deform", "-m", previous, "-H", h, "-o", o, "-q"});
    INFO(previous << " -> " << o << ": " << r.err);
    REQUIRE(r.exit_code == 0);
    CHECK(r.out.empty());  // --quiet
    CHECK(read_mesh(o).vertex_count() == 8);
    previous = o;
  }
  const auto r =
      cli_test::run(program, {"deform", "-m", previous, "-H", h, "-o", f.out + "/ascii.ply", "--ply-ascii", "-q"});
  REQUIRE(r.exit_code == 0);
  CHECK(cli_test::read_text(f.out + "/ascii.ply").rfind("ply\nformat ascii 1.0\n", 0) == 0);
}

TEST_CASE("deform: frames write one numbered file each, with a line per frame", "[cli][commands]") {
  Fixture f;
  write_text(f.in + "/anim.json", R"({
    "points": [{"vertex": 0}, {"vertex": 1}, {"vertex": 4}, {"vertex": 5}, {"vertex": 6}, {"vertex": 7}],
    "frames": [
      {"points": [null, null, null, null, {"offset": [0.1, 0, 0]}, {"offset": [0.1, 0, 0]}]},
      {"points": [null, null, null, null, {"offset": [0.2, 0, 0]}, {"offset": [0.2, 0, 0]}]},
      {"points": [null, null, null, null, [1.3, 1, 1], [0.3, 1, 1]]}
    ]})");
  const auto r = cli_test::run(
      program, {"deform", "-m", f.in + "/cube.obj", "-H", f.in + "/anim.json", "-o", f.out + "/anim.ply.gz"});
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(f.outputs() == std::vector<std::string>{"anim_0000.ply.gz", "anim_0001.ply.gz", "anim_0002.ply.gz"});
  CHECK(r.out.find("frame 1/3: deform") != std::string::npos);
  CHECK(r.out.find("frame 3/3: deform") != std::string::npos);
  CHECK(r.out.find("3 frames deformed") != std::string::npos);
  CHECK((read_mesh(f.out + "/anim_0002.ply.gz").vertices.row(6) - Eigen::RowVector3f(1.3f, 1, 1)).norm() < 1e-5f);
}

TEST_CASE("deform: the README's example (data/human_bend.json) runs", "[cli][commands]") {
  Fixture f;
  const auto r = cli_test::run(program, {"deform", "--mesh", MLSDEFORM_SOURCE_DIR "/data/human_man.obj", "--handles",
                                         MLSDEFORM_SOURCE_DIR "/data/human_bend.json", "--out", f.out + "/human.obj"});
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(f.outputs().size() == 24);
  const Mesh last = read_mesh(f.out + "/human_0023.obj");
  CHECK(last.vertex_count() == 6890);
  CHECK(last.face_count() == 13776);
  CHECK((last.vertices.row(5906) - Eigen::RowVector3f(-0.3f, 0.55f, 0.45f)).norm() < 1e-5f);  // the left hand's target
}

TEST_CASE("deform: a handle group turns the cube's top a quarter turn about its centre", "[cli][commands][groups]") {
  Fixture f;
  // Bottom corners fixed; the top ones (z = 1) turned by 90 degrees about z through their centroid
  // (0.5, 0.5, 1): (x, y) -> (1 - y, x). Handles on vertices map exactly to their targets, and a quarter
  // turn's targets are exact.
  cli_test::write_text(f.in + "/turn.json", R"({
    "points": [{"vertex": 0}, {"vertex": 1}, {"vertex": 2}, {"vertex": 3},
               {"vertex": 4}, {"vertex": 5}, {"vertex": 6}, {"vertex": 7}],
    "groups": [{"points": [4, 5, 6, 7], "rotate": {"axis": [0, 0, 1], "degrees": 90}}]})");
  const std::string o = f.out + "/turn.obj";
  const auto r = cli_test::run(program, {"deform", "-m", f.in + "/cube.obj", "-H", f.in + "/turn.json", "-o", o});
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  const Mesh result = read_mesh(o);
  CHECK(result.vertices.row(0) == Eigen::RowVector3f(0, 0, 0));
  CHECK(result.vertices.row(4) == Eigen::RowVector3f(1, 0, 1));
  CHECK(result.vertices.row(5) == Eigen::RowVector3f(1, 1, 1));
  CHECK(result.vertices.row(6) == Eigen::RowVector3f(0, 1, 1));
  CHECK(result.vertices.row(7) == Eigen::RowVector3f(0, 0, 1));

  cli_test::write_text(f.in + "/twice.json", R"({"points": [{"vertex": 0}, {"vertex": 6}],
    "groups": [{"points": [0, 1], "translate": [0, 0, 1]}, {"points": [1]}]})");
  std::filesystem::remove(o);
  require_bad_input(f, {"deform", "-m", f.in + "/cube.obj", "-H", f.in + "/twice.json", "-o", o},
                    f.in +
                        "/twice.json: /groups/1/points/0: point handle 1 is already in a group (at "
                        "/groups/0/points/1); a handle can be in one group only");
}

TEST_CASE("deform: existing outputs need --force", "[cli][commands][errors]") {
  Fixture f;
  const std::string m = f.in + "/cube.obj", h = f.in + "/shear.json", o = f.out + "/a.obj";
  write_text(o, "precious\n");
  auto r = cli_test::run(program, {"deform", "-m", m, "-H", h, "-o", o});
  CHECK(r.exit_code == 2);
  CHECK(r.err == "mlsdeform: error: " + o + ": already exists (use --force to overwrite)\n");
  CHECK(cli_test::read_text(o) == "precious\n");
  CHECK(f.outputs() == std::vector<std::string>{"a.obj"});
  r = cli_test::run(program, {"deform", "-m", m, "-H", h, "-o", o, "--force"});
  CHECK(r.exit_code == 0);
  CHECK(read_mesh(o).vertex_count() == 8);
  CHECK(f.outputs() == std::vector<std::string>{"a.obj"});
  // An animation stops before writing anything if any of its frame files exists.
  write_text(f.in + "/anim.json",
             R"({"points": [{"vertex": 0}, {"vertex": 6, "offset": [0, 1, 0]}], "frames": [{}, {}]})");
  write_text(f.out + "/b_0001.obj", "precious\n");
  r = cli_test::run(program, {"deform", "-m", m, "-H", f.in + "/anim.json", "-o", f.out + "/b.obj"});
  CHECK(r.exit_code == 2);
  CHECK(r.err == "mlsdeform: error: " + f.out + "/b_0001.obj: already exists (use --force to overwrite)\n");
  CHECK(f.outputs() == std::vector<std::string>{"a.obj", "b_0001.obj"});
}

TEST_CASE("deform --force writes through a symbolic link and keeps the file's mode", "[cli][commands]") {
  Fixture f;
  const std::string m = f.in + "/cube.obj", h = f.in + "/shear.json";
  namespace fs = std::filesystem;
  const fs::path real = fs::path(f.dir.path()) / "real";
  fs::create_directory(real);
  write_text((real / "target.obj").string(), "precious\n");
  fs::permissions(real / "target.obj", fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
  fs::create_symlink("../real/target.obj", fs::path(f.out) / "link.obj");  // relative to the link's folder
  const std::string link = f.out + "/link.obj";
  auto r = cli_test::run(program, {"deform", "-m", m, "-H", h, "-o", link, "-q"});
  CHECK(r.exit_code == 2);
  CHECK(r.err == "mlsdeform: error: " + link + ": already exists (use --force to overwrite)\n");
  r = cli_test::run(program, {"deform", "-m", m, "-H", h, "-o", link, "-q", "--force"});
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(fs::is_symlink(link));
  CHECK(fs::read_symlink(link) == "../real/target.obj");
  CHECK(read_mesh((real / "target.obj").string()).vertex_count() == 8);
  CHECK(fs::status(real / "target.obj").permissions() ==
        (fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read));
  CHECK(f.outputs() == std::vector<std::string>{"link.obj"});  // no temporary left beside the link ...
  std::vector<std::string> in_real;
  for (const auto& e : fs::directory_iterator(real)) in_real.push_back(e.path().filename().string());
  CHECK(in_real == std::vector<std::string>{"target.obj"});  // ... or beside its target
  // A plain file keeps its mode too, a link to a link is followed to the end, and a dangling link is an
  // existing name without --force and the file to create with it.
  const std::string plain = f.out + "/plain.obj";
  write_text(plain, "precious\n");
  fs::permissions(plain, fs::perms::owner_read | fs::perms::owner_write);
  r = cli_test::run(program, {"deform", "-m", m, "-H", h, "-o", plain, "-q", "--force"});
  REQUIRE(r.exit_code == 0);
  CHECK(fs::status(plain).permissions() == (fs::perms::owner_read | fs::perms::owner_write));
  fs::create_symlink("link.obj", fs::path(f.out) / "link2.obj");
  fs::create_symlink("../real/new.obj", fs::path(f.out) / "dangling.obj");
  r = cli_test::run(program, {"deform", "-m", m, "-H", h, "-o", f.out + "/dangling.obj", "-q"});
  CHECK(r.exit_code == 2);
  CHECK(r.err == "mlsdeform: error: " + f.out + "/dangling.obj: already exists (use --force to overwrite)\n");
  CHECK(!fs::exists(real / "new.obj"));
  for (const char* name : {"link2.obj", "dangling.obj"}) {
    r = cli_test::run(program, {"deform", "-m", m, "-H", h, "-o", f.out + "/" + name, "-q", "--force"});
    INFO(name << ": " << r.err);
    CHECK(r.exit_code == 0);
    CHECK(fs::is_symlink(f.out + "/" + name));
  }
  CHECK(read_mesh((real / "new.obj").string()).vertex_count() == 8);
  // A loop of links is an error naming the output.
  fs::create_symlink("loop_b.obj", fs::path(f.out) / "loop_a.obj");
  fs::create_symlink("loop_a.obj", fs::path(f.out) / "loop_b.obj");
  r = cli_test::run(program, {"deform", "-m", m, "-H", h, "-o", f.out + "/loop_a.obj", "-q", "--force"});
  CHECK(r.exit_code == 2);
  CHECK(r.err == "mlsdeform: error: " + f.out + "/loop_a.obj: cannot write: too many levels of symbolic links\n");
}

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

TEST_CASE("demo runs with no arguments and writes what it says", "[cli][commands][demo]") {
  ScratchDir dir;
  // The demo's default output folder is relative: run it with its own working folder via --out-dir.
  const std::string out = dir / "demo-out";
  const auto r = cli_test::run(program, {"demo", "--frames", "2", "--out-dir", out, "--no-images"});
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  for (const char* name : {"human", "bar_twist", "cylinder", "bend_segments"})
    CHECK(r.out.find(name) != std::string::npos);
  CHECK(r.out.find("scalar f/s") != std::string::npos);
  CHECK(r.out.find("simd f/s") != std::string::npos);
  CHECK(r.out.find("human + 10 ARAP iterations") != std::string::npos);
  for (const char* file : {"human_bent.obj", "human_bent_arap.obj", "bar_twisted.ply", "cylinder_rotated.off",
                           "bar_bent_segments.ply.gz"}) {
    INFO(file);
    CHECK(std::filesystem::exists(dir.path() / "demo-out" / file));
  }
  CHECK(read_mesh(out + "/human_bent.obj").vertex_count() == 6890);
  CHECK(read_mesh(out + "/human_bent_arap.obj").vertex_count() == 6890);
  CHECK(read_mesh(out + "/bar_twisted.ply").vertex_count() == 6146);
  CHECK(read_mesh(out + "/cylinder_rotated.off").vertex_count() == 1058);
}

TEST_CASE("demo and figures draw their images (where python3-matplotlib is installed)", "[cli][commands][figures]") {
  ScratchDir dir;
  auto r = cli_test::run(program, {"figures", "--only", "5", "--out-dir", dir / "figs"});
  INFO(r.out << r.err);
  if (r.exit_code == 2 && r.err.find("cannot render") != std::string::npos) {
    WARN("skipped: " << r.err);  // no matplotlib: the program says so and exits with 2
    return;
  }
  REQUIRE(r.exit_code == 0);
  std::string png = cli_test::read_text(dir / "figs/fig5.png");
  REQUIRE(png.size() > 8);
  CHECK(png.substr(1, 3) == "PNG");
  // Fig. 2 needs the shared fish.obj: without it the figure is skipped with a line saying so.
  r = cli_test::run(program, {"figures", "--only", "arap,2,6,7,8", "--out-dir", dir / "figs"});
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  const bool fish = r.out.find("skipped fig2.png") == std::string::npos;
  if (!fish) WARN("fig2.png skipped: " << r.out);
  for (const char* file : {"arap.png", "fig2.png", "fig6.png", "fig7.png", "fig8.png"}) {
    if (!fish && std::string(file) == "fig2.png") continue;
    INFO(file);
    png = cli_test::read_text(dir / (std::string("figs/") + file));
    REQUIRE(png.size() > 8);
    CHECK(png.substr(1, 3) == "PNG");
  }
  CHECK(r.out.find("fig8: dihedral-angle change") != std::string::npos);
  // Without the shared meshes: a message, no file, exit 0.
  r = cli_test::run(program, {"figures", "--only", "2", "--out-dir", dir / "nofish"},
                    {"MLSDEFORM_MESHES=" + (dir / "no-such-folder")});
  CHECK(r.exit_code == 0);
  CHECK(r.out.find("skipped fig2.png") != std::string::npos);
  CHECK(!std::filesystem::exists(dir.path() / "nofish" / "fig2.png"));
  r = cli_test::run(program, {"demo", "--frames", "1", "--out-dir", dir / "demo"});
  REQUIRE(r.exit_code == 0);
  for (const char* file : {"human.png", "bar_twist.png", "cylinder.png", "bend_segments.png"}) {
    INFO(file);
    CHECK(std::filesystem::exists(dir.path() / "demo" / file));
  }
  r = cli_test::run(program, {"figures", "--only", "9"});
  CHECK(r.exit_code == 2);
  CHECK(r.err == "mlsdeform: error: --only: no figure '9' (choose from 1 to 8, arap)\n");
  // Without --out-dir: a folder in the current one, never the source tree's docs/figures.
  const std::filesystem::path docs_fig5 = MLSDEFORM_SOURCE_DIR "/docs/figures/fig5.png";
  const auto docs_time = std::filesystem::last_write_time(docs_fig5);
  std::filesystem::create_directory(dir.path() / "cwd");
  r = cli_test::run(program, {"figures", "--only", "5"}, {}, dir / "cwd");
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(std::filesystem::exists(dir.path() / "cwd/mlsdeform-figures-out/fig5.png"));
  CHECK(std::filesystem::last_write_time(docs_fig5) == docs_time);
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

TEST_CASE("deform: an interrupted animation removes the frames it wrote", "[cli][commands][signals]") {
  Fixture f;
  // 20,000 frames of the cube: a run of many seconds, interrupted once its first frames are on disk.
  std::string json = R"({"points": [{"vertex": 0}, {"vertex": 6, "target": [1, 1, 1]}, {"vertex": 3}], "frames": [)";
  for (int i = 0; i < 20000; ++i)
    json += (i ? ", " : "") + std::string(R"({"points": [null, {"offset": [0, 0, 0.5]}, null]})");
  json += "]}";
  write_text(f.in + "/long.json", json);
  for (int sig : {SIGINT, SIGTERM}) {
    const std::string out = f.out + "/frame.ply";
    const pid_t pid = ::fork();
    REQUIRE(pid >= 0);
    if (pid == 0) {
      const int devnull = ::open("/dev/null", O_WRONLY);
      ::dup2(devnull, 1);
      ::dup2(devnull, 2);
      ::execl(program.c_str(), program.c_str(), "deform", "-m", (f.in + "/cube.obj").c_str(), "-H",
              (f.in + "/long.json").c_str(), "-o", out.c_str(), "-q", static_cast<char*>(nullptr));
      ::_exit(127);
    }
    // Wait (at most 30 s, or until the run ends by itself) until a few frames exist, then interrupt.
    bool started = false;
    int status = 0;
    pid_t done = 0;
    for (int t = 0; t < 3000 && !started && done == 0; ++t) {
      started = f.outputs().size() >= 3;
      if (!started) ::usleep(10000);
      done = ::waitpid(pid, &status, WNOHANG);
    }
    if (done == 0) {
      ::kill(pid, sig);
      ::waitpid(pid, &status, 0);
    }
    INFO("signal " << sig << ", frames seen before it: " << started);
    CHECK(started);
    REQUIRE(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 128 + sig);
    CHECK(f.outputs().empty());  // neither frames nor temporary files are left
  }
}
