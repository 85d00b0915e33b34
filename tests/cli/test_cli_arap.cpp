// End-to-end tests of `mlsdeform deform --arap N`: surface-ARAP iterations after MLS on the mesh's faces.
// What the program promises: the option changes the result, handle vertices stay on their targets, the
// faces written are the input's (the triangulation is internal), a mesh without faces is refused (exit code
// 2, one line naming the file, nothing written), and N must be a whole number >= 0.
#include "tests/cli/cli_test_util.hpp"

#include "core/files/mesh.hpp"
#include "tools/cli/primitives.hpp"

#include "tests/support/catch.hpp"

#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>

using namespace mlsdeform;
using namespace mlsdeform::files;
using namespace mlsdeform::cli;
using cli_test::program;
using cli_test::ScratchDir;
using cli_test::write_text;

namespace {

// A 0.5 x 3 x 0.5 bar of quads (2 x 12 x 2 cells, 106 vertices), its four bottom corners fixed and its four
// top corners moved sideways and down: a bend that MLS leaves smooth and ARAP changes.
struct BarCase {
  ScratchDir dir;
  std::string mesh = dir / "bar.obj", handles = dir / "bend.json";
  std::vector<Eigen::Index> fixed, moved;
  Eigen::RowVector3f offset{1.0f, -0.5f, 0.0f};
  std::string points;  // the handles file's "points" array
  BarCase() {
    const Mesh bar = make_bar(2, 12, 2, 0.5, 3.0);
    write_mesh(bar, mesh);
    for (Eigen::Index i = 0; i < bar.vertex_count(); ++i) {
      const auto p = bar.vertices.row(i);
      if (std::abs(p(0)) != 0.25f || std::abs(p(2)) != 0.25f) continue;  // corners only
      if (p(1) == 0.0f) fixed.push_back(i);
      if (p(1) == 3.0f) moved.push_back(i);
    }
    points = "[";
    for (auto i : fixed) points += R"({"vertex": )" + std::to_string(i) + "}, ";
    for (std::size_t k = 0; k < moved.size(); ++k)
      points += R"({"vertex": )" + std::to_string(moved[k]) + R"(, "offset": [1, -0.5, 0]})" +
                (k + 1 < moved.size() ? ", " : "]");
    write_text(handles, R"({"points": )" + points + "}");
  }
  cli_test::Result deform(const std::string& out, std::vector<std::string> extra) const {
    extra.insert(extra.begin(), "-q");
    return cli_test::deform(mesh, handles, out, extra);
  }
};

}  // namespace

TEST_CASE("deform --arap: changes the result, keeps handles on their targets and the faces as read", "[cli][arap]") {
  BarCase c;
  REQUIRE(c.fixed.size() == 4);
  REQUIRE(c.moved.size() == 4);
  const Mesh rest = read_mesh(c.mesh);
  for (const char* precision : {"float", "double"}) {
    INFO(precision);
    const std::string mls = c.dir / (std::string("mls_") + precision + ".ply"),
                      arap = c.dir / (std::string("arap_") + precision + ".ply");
    auto r = c.deform(mls, {"--arap", "0", "--precision", precision});
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    r = c.deform(arap, {"--arap", "2", "--precision", precision});
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    CHECK(r.out.empty());  // -q
    const Mesh a = read_mesh(mls), b = read_mesh(arap);
    REQUIRE(b.vertex_count() == rest.vertex_count());
    CHECK(b.face_start == rest.face_start);  // quads stay quads: the fans are only the refiner's
    CHECK(b.face_indices == rest.face_indices);
    // The bend moves the top by about 1.1; two iterations move the bar's middle by a visible fraction of that.
    CHECK((a.vertices - b.vertices).rowwise().norm().maxCoeff() > 1e-2f);
    // Each handle sits on a vertex, which the refiner holds at MLS's result there: the target. The written
    // coordinates are floats, and the targets are O(1): a few float eps.
    for (auto i : c.fixed) CHECK((b.vertices.row(i) - rest.vertices.row(i)).norm() < 1e-5f);
    for (auto i : c.moved) CHECK((b.vertices.row(i) - rest.vertices.row(i) - c.offset).norm() < 1e-5f);
  }
  // An animation runs the iterations on every frame.
  write_text(c.dir / "anim.json", R"({"points": )" + c.points + R"(, "frames": [{}, {}]})");
  const auto r = cli_test::run(
      program, {"deform", "-m", c.mesh, "-H", c.dir / "anim.json", "-o", c.dir / "anim.obj", "--arap", "3"});
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("then 3 ARAP iterations") != std::string::npos);
  CHECK(read_mesh(c.dir / "anim_0001.obj").vertex_count() == rest.vertex_count());
}

TEST_CASE("deform --arap: a grid at 1e21 is refined as at unit size, to the bit", "[cli][arap]") {
  // The 30 x 30 grid that came out NaN in 897 of 900 vertices at 1e21, refused with exit code 2 and a message
  // blaming the handles. The reference is the same grid divided by 2^70 (exact in float): the library
  // computes in frames scaled by powers of two taken from the input (tests/test_scale_invariance.cpp derives
  // it), so the output for the grid at 1e21 must be 2^70 times the output for the divided one, bitwise.
  ScratchDir dir;
  const int n = 30;
  Mesh big;
  big.vertices.resize(n * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      big.vertices.row(i * n + j) << float(i / 32.0 * 1e21), float(j / 32.0 * 1e21),
          float(((i * 7 + j * 3) % 5) / 256.0 * 1e21);
  for (int i = 0; i + 1 < n; ++i)
    for (int j = 0; j + 1 < n; ++j) {
      const auto a = std::uint32_t(i * n + j);
      big.add_face({a, a + 1, a + std::uint32_t(n) + 1, a + std::uint32_t(n)});
    }
  Mesh small = big;
  for (Eigen::Index i = 0; i < small.vertices.size(); ++i)
    small.vertices.data()[i] = std::ldexp(big.vertices.data()[i], -70);
  // The four corners held, the middle lifted by 0.25 and a corner pulled by 0.125 (times 1e21).
  const auto handles = [&](const Mesh& m, int e) {
    const auto num = [](float x) {
      char b[32];
      std::snprintf(b, sizeof b, "%.17g", double(x));  // exact: the float, read as float or double
      return std::string(b);
    };
    const auto target = [&](int v, int c, double offset) {
      return num(m.vertices(v, c) + std::ldexp(float(offset * 1e21), e));
    };
    std::string h = R"({"points": [{"vertex": 0}, {"vertex": 29}, {"vertex": 870}, )";
    h += R"({"vertex": 899, "target": [)" + target(899, 0, 0.125) + ", " + target(899, 1, 0) + ", " +
         target(899, 2, 0) + "]}, ";
    h += R"({"vertex": 465, "target": [)" + target(465, 0, 0) + ", " + target(465, 1, 0) + ", " + target(465, 2, 0.25) +
         "]}]}";
    return h;
  };
  write_mesh(big, dir / "big.ply");
  write_mesh(small, dir / "small.ply");
  write_text(dir / "big.json", handles(big, 0));
  write_text(dir / "small.json", handles(small, -70));
  for (const char* precision : {"float", "double"}) {
    INFO(precision);
    for (const char* which : {"big", "small"}) {
      const auto r =
          cli_test::run(program, {"deform", "-m", dir / (std::string(which) + ".ply"), "-H",
                                  dir / (std::string(which) + ".json"), "-o", dir / (std::string(which) + "_out.ply"),
                                  "--arap", "2", "--precision", precision, "-q", "--force"});
      INFO(which << ": " << r.err);
      REQUIRE(r.exit_code == 0);
    }
    const Mesh a = read_mesh(dir / "big_out.ply"), b = read_mesh(dir / "small_out.ply");
    REQUIRE(a.vertices.allFinite());
    REQUIRE(a.vertex_count() == b.vertex_count());
    long differ = 0;
    for (Eigen::Index i = 0; i < a.vertices.size(); ++i)
      differ += a.vertices.data()[i] != std::ldexp(b.vertices.data()[i], 70);
    CHECK(differ == 0);
    CHECK((a.vertices - big.vertices).cwiseAbs().maxCoeff() > 1e19f);  // deformed: the middle lifted by 2.5e20
  }
}

TEST_CASE("deform: a deformed position beyond float is refused, naming the vertex and the reason", "[cli][errors]") {
  // Similarity: two handles 2^-10 apart pulled 1.3e36 apart scale the scene by about 1.4e39; the third vertex,
  // 1 away, would land beyond float's range.
  ScratchDir dir;
  write_text(dir / "tri.obj", "v 0 0 0\nv 0.0009765625 0 0\nv 1 0.5 0\nf 1 2 3\n");
  write_text(dir / "h.json", R"({"points": [{"vertex": 0}, {"vertex": 1, "target": [1.3e36, 0, 0]}]})");
  // In double the MLS result is finite and only a float file cannot hold it (--output-type float); in float
  // MLS already overflows, also before ARAP. (Double with ARAP is representable: the refinement places the
  // triangle rigidly near its handles.)
  for (const auto& [precision, arap] : {std::pair{"float", "0"}, {"float", "2"}, {"double", "0"}}) {
    const auto r = cli_test::run(
        program, {"deform", "-m", dir / "tri.obj", "-H", dir / "h.json", "-o", dir / "out.obj", "--transform",
                  "similarity", "--arap", arap, "--precision", precision, "--output-type", "float"});
    INFO(precision << ", --arap " << arap << ": " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(cli_test::line_count(r.err) == 1);
    CHECK(r.err.find(dir / "h.json") != std::string::npos);
    CHECK(r.err.find("vertex 2's deformed position overflows float") != std::string::npos);
    CHECK(!std::filesystem::exists(dir / "out.obj"));
  }
}

TEST_CASE("deform --arap: a mesh without faces is refused, with --arap 0 it is deformed", "[cli][arap][errors]") {
  ScratchDir dir;
  const std::string handles = dir / "h.json", out = dir / "out.ply";
  write_text(handles, R"({"points": [{"vertex": 0}, {"vertex": 1}, {"vertex": 2, "offset": [0, 0, 0.5]}]})");
  const std::string points = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n";
  // Vertices only; OBJ points and lines, which the reader drops; a PLY point cloud.
  write_text(dir / "cloud.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n");
  write_text(dir / "lines.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\np 1 2\nl 1 2 3 4\n");
  write_text(dir / "cloud.ply",
             "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
             "end_header\n" +
                 points);
  write_text(dir / "cloud.off", "OFF\n4 0 0\n" + points);
  for (const char* name : {"cloud.obj", "lines.obj", "cloud.ply", "cloud.off"}) {
    const std::string mesh = dir / name;
    auto r = cli_test::run(program, {"deform", "-m", mesh, "-H", handles, "-o", out, "--arap", "2"});
    INFO(name << ": " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(r.err ==
          "mlsdeform: error: " + mesh + ": --arap needs a surface, and the mesh has no faces (a point cloud?)\n");
    CHECK(!std::filesystem::exists(out));
    r = cli_test::run(program, {"deform", "-m", mesh, "-H", handles, "-o", out, "--arap", "0", "-q", "--force"});
    CHECK(r.exit_code == 0);
    CHECK(std::filesystem::exists(out));
    std::filesystem::remove(out);
  }
}

TEST_CASE("deform --arap: the count must be a whole number >= 0", "[cli][arap][errors]") {
  BarCase c;
  const std::string out = c.dir / "out.obj";
  for (const char* n : {"-1", "1.5", "2.0", "two", "", "+2", "0x10", "1e1", "99999999999"}) {
    const auto r = c.deform(out, {"--arap", n});
    INFO("--arap '" << n << "': " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(r.err.rfind("mlsdeform: error: ", 0) == 0);
    CHECK(r.err.find("--arap") != std::string::npos);
    CHECK(cli_test::line_count(r.err) == 1);
    CHECK(!std::filesystem::exists(out));
  }
  const auto r = cli_test::run(program, {"deform", "--help"});
  CHECK(r.out.find("--arap") != std::string::npos);
}

TEST_CASE("deform --centroids rbf: the RBF centroids change the result, handles stay on their targets", "[cli][rbf]") {
  BarCase c;
  const Mesh rest = read_mesh(c.mesh);
  // One top corner moved, the other seven held: not an affine move of the handles (for one, the MLS and
  // RBF centroids would agree: both reproduce affine maps).
  std::string points = "[";
  for (auto i : c.fixed) points += R"({"vertex": )" + std::to_string(i) + "}, ";
  for (std::size_t k = 0; k < c.moved.size(); ++k)
    points += R"({"vertex": )" + std::to_string(c.moved[k]) + (k == 0 ? R"(, "offset": [1, -0.5, 0]})" : "}") +
              (k + 1 < c.moved.size() ? ", " : "]");
  write_text(c.handles, R"({"points": )" + points + "}");
  auto r = c.deform(c.dir / "mls.ply", {"--centroids", "mls"});
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  r = c.deform(c.dir / "rbf.ply", {"--centroids", "rbf"});
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const Mesh a = read_mesh(c.dir / "mls.ply"), b = read_mesh(c.dir / "rbf.ply");
  CHECK((a.vertices - b.vertices).rowwise().norm().maxCoeff() > 1e-3f);
  // Vertices on handles take their targets exactly in float; written as floats.
  for (auto i : c.fixed) CHECK(b.vertices.row(i) == rest.vertices.row(i));
  r = c.deform(c.dir / "bad.ply", {"--centroids", "spline"});
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("--centroids") != std::string::npos);
}

TEST_CASE("deform --arap: the first SIGINT stops a frame of a billion iterations between two of them",
          "[cli][arap][signals]") {
  // Without the check between iterations the frame would run for days; the run must instead end with
  // 128 + SIGINT and write nothing. The signal is sent once the program has printed its set-up line (which it
  // flushes), i.e. once it is deforming; the 60 s limit is only against a hang.
  BarCase c;
  const std::string out = c.dir / "out.ply";
  int fds[2];
  REQUIRE(::pipe(fds) == 0);
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    ::dup2(fds[1], 1);
    ::close(fds[0]);
    ::execl(program.c_str(), program.c_str(), "deform", "-m", c.mesh.c_str(), "-H", c.handles.c_str(), "-o",
            out.c_str(), "--arap", "1000000000", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  ::close(fds[1]);
  std::string seen;
  char buf[256];
  while (seen.find("set-up") == std::string::npos) {
    const ssize_t got = ::read(fds[0], buf, sizeof buf);
    if (got <= 0) break;
    seen.append(buf, std::size_t(got));
  }
  ::close(fds[0]);
  INFO("stdout: " << seen);
  REQUIRE(seen.find("set-up") != std::string::npos);
  ::usleep(200000);  // well into the iterations
  ::kill(pid, SIGINT);
  int status = 0;
  pid_t done = 0;
  for (int t = 0; t < 6000 && done == 0; ++t) {
    done = ::waitpid(pid, &status, WNOHANG);
    if (done == 0) ::usleep(10000);
  }
  if (done == 0) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
  }
  CHECK(done == pid);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 128 + SIGINT);
  CHECK(!std::filesystem::exists(out));
}

TEST_CASE("deform --arap-acceleration, --arap-warm-start: change the result, keep the handles", "[cli][arap]") {
  BarCase c;
  const Mesh rest = read_mesh(c.mesh);
  const std::string plain = c.dir / "plain.ply", fast = c.dir / "fast.ply";
  auto r = c.deform(plain, {"--arap", "5"});
  REQUIRE(r.exit_code == 0);
  r = c.deform(fast, {"--arap", "5", "--arap-acceleration", "anderson"});
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const Mesh a = read_mesh(plain), b = read_mesh(fast);
  CHECK(a.vertices != b.vertices);
  for (auto i : c.moved) CHECK((b.vertices.row(i) - rest.vertices.row(i) - c.offset).norm() < 1e-5f);
  // Two frames with the same targets: warm, the second goes on from the first; cold, it repeats it.
  write_text(c.dir / "anim.json", R"({"points": )" + c.points + R"(, "frames": [{}, {}]})");
  for (const bool warm : {false, true}) {
    std::vector<std::string> args{"deform", "-m", c.mesh,   "-H", c.dir / "anim.json", "-o", c.dir / "anim.ply",
                                  "-q",     "-f", "--arap", "2"};
    if (warm) args.push_back("--arap-warm-start");
    r = cli_test::run(program, args);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const Mesh f0 = read_mesh(c.dir / "anim_0000.ply"), f1 = read_mesh(c.dir / "anim_0001.ply");
    CHECK((f0.vertices == f1.vertices) == !warm);
  }
  r = c.deform(c.dir / "bad.obj", {"--arap", "2", "--arap-acceleration", "fast"});
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("--arap-acceleration") != std::string::npos);
  CHECK(cli_test::line_count(r.err) == 1);
}
