// End-to-end tests of the mlsdeform program's outputs: an existing file needs --force, --force writes through
// a symbolic link and keeps the file's mode, and an interrupted animation removes the frames it wrote.
#include "tests/cli/cli_test_util.hpp"
#include "tests/cli/cube_fixture.hpp"

#include "core/files/mesh.hpp"

#include "tests/support/catch.hpp"

#include <csignal>
#include <filesystem>
#include <string>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

using namespace mlsdeform;
using namespace mlsdeform::files;
using cli_test::Fixture;
using cli_test::program;
using cli_test::ScratchDir;
using cli_test::write_text;

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
