// End-to-end tests of the mlsdeform program: each subcommand on small inputs (bad inputs:
// test_cli_bad_input.cpp; outputs that exist or are interrupted: test_cli_outputs.cpp).
#include "tests/cli/cli_test_util.hpp"
#include "tests/cli/cube_fixture.hpp"

#include "core/files/mesh.hpp"

#include "tests/support/catch.hpp"

#include <mlsdeform/deformer.hpp>

#include <filesystem>
#include <string>
#include <utility>

using namespace mlsdeform;
using namespace mlsdeform::files;
using cli_test::Fixture;
using cli_test::program;
using cli_test::ScratchDir;
using cli_test::write_text;

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
  // The weight budget's default as the library has it (Options), in MiB, on the option's own line: CLI11 2.3
  // (Debian 12) writes it "...]=64", CLI11 2.4 (Debian 13) "...] [64]".
  const std::string mib = std::to_string(Options{}.precompute_budget_bytes >> 20);
  CHECK(Options{}.precompute_budget_bytes % (1 << 20) == 0);
  const auto at = r.out.find("--weight-budget FLOAT");
  REQUIRE(at != std::string::npos);
  const std::string line = r.out.substr(at, r.out.find('\n', at) - at);
  INFO(line);
  CHECK((line.ends_with("]=" + mib) || line.find("] [" + mib + "]") != std::string::npos));
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

TEST_CASE("deform: a minimal OFF or ASCII PLY without a final newline is read", "[cli][commands]") {
  // The last line's newline is optional: the byte counts checked before allocating must not need it.
  Fixture f;
  const std::string h = f.in + "/tri.json";
  write_text(h, R"({"points": [{"vertex": 0}, {"vertex": 1, "offset": [0, 0.5, 0]}]})");
  const std::string ply_points =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0";
  for (const auto& [name, bytes] :
       {std::pair<std::string, std::string>{"tri.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2"},
        {"pts.off", "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0"},
        {"pts.ply", ply_points}}) {
    const std::string m = f.in + "/" + name, o = f.out + "/" + name;
    write_text(m, bytes);
    const auto r = cli_test::run(program, {"deform", "-m", m, "-H", h, "-o", o, "-q"});
    INFO(name << ": " << r.err);
    REQUIRE(r.exit_code == 0);
    CHECK(read_mesh(o).vertex_count() == 3);
  }
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
