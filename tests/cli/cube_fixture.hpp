// The cube that the end-to-end tests of the program deform (test_cli_commands, test_cli_bad_input,
// test_cli_outputs): its mesh and a handles file in one scratch folder, outputs in another, and the check of a
// bad-input run.
#pragma once

#include "tests/cli/cli_test_util.hpp"

#include "tests/support/catch.hpp"

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

namespace cli_test {

// A 2 x 2 x 2 grid of vertices (a cube's corners and no more), six quad faces.
inline const char* cube_obj =
    "# unit cube\n"
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

// Bottom corners fixed, top corners moved 0.5 along x.
inline const char* shear_json = R"({
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
inline void require_bad_input(const Fixture& f, const std::vector<std::string>& args, const std::string& expected) {
  const auto r = cli_test::run(program, args);
  INFO("args: " << Catch::Detail::stringify(args) << "\nstdout: " << r.out << "\nstderr: " << r.err);
  CHECK(r.exit_code == 2);
  CHECK(r.err == "mlsdeform: error: " + expected + "\n");
  CHECK(f.outputs().empty());
}

}  // namespace cli_test
