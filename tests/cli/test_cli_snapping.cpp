// The program on a model with one stray vertex far away: snapping (core/src/deformer/snap.hpp) is decided by
// each vertex's own neighbourhood, so the stray changes which vertices land exactly on a handle nowhere else,
// and no two distinct vertices come out at one point.
#include "tests/cli/cli_test_util.hpp"

#include "core/files/mesh.hpp"

#include "tests/support/catch.hpp"

#include <algorithm>
#include <array>
#include <set>

using namespace mlsdeform::files;
using cli_test::program;
using cli_test::ScratchDir;

namespace {

// data/human_bend.json's handles in its final pose, without the animation frames.
const char* human_pose_json = R"({
  "points": [
    {"vertex": 1337}, {"vertex": 3215}, {"vertex": 3386},
    {"vertex": 411, "target": [0.00213, 1.38829, 0.68933]},
    {"vertex": 5906, "target": [-0.3, 0.55, 0.45]},
    {"vertex": 2445, "target": [0.3, 0.55, 0.45]}
  ],
  "segments": [{"vertices": [6618, 6786]}]
})";

using Row = std::array<float, 3>;

Row row(const Mesh& m, Eigen::Index i) { return {m.vertices(i, 0), m.vertices(i, 1), m.vertices(i, 2)}; }

/// The rows among the first n of `m` that occur more than once.
std::size_t repeated_rows(const Mesh& m, Eigen::Index n) {
  std::vector<Row> r;
  for (Eigen::Index i = 0; i < n; ++i) r.push_back(row(m, i));
  std::sort(r.begin(), r.end());
  std::size_t repeated = 0;
  for (std::size_t i = 1; i < r.size(); ++i) repeated += r[i] == r[i - 1];
  return repeated;
}

/// The rows among the first n of `m` that equal one of `targets` bitwise.
std::set<Eigen::Index> on_targets(const Mesh& m, Eigen::Index n, const std::vector<Row>& targets) {
  std::set<Eigen::Index> on;
  for (Eigen::Index i = 0; i < n; ++i)
    if (std::find(targets.begin(), targets.end(), row(m, i)) != targets.end()) on.insert(i);
  return on;
}

}  // namespace

TEST_CASE("deform: a vertex 10^4 away collapses no part of the model (the human, float)", "[cli][snap]") {
  // With a snapping radius of 64 eps(float) times the model's diagonal, the line `v 10000 0 0` widened it to
  // 0.08 for every vertex: 296 vertices of the left hand and 294 of the right came out at one point each.
  ScratchDir dir;
  const std::string human = cli_test::read_text(MLSDEFORM_SOURCE_DIR "/data/human_man.obj");
  cli_test::write_text(dir / "human.obj", human);
  cli_test::write_text(dir / "stray.obj", human + "v 10000 0 0\n");
  cli_test::write_text(dir / "pose.json", human_pose_json);
  const Mesh rest = read_mesh(dir / "human.obj");
  const Eigen::Index n = rest.vertex_count();
  REQUIRE(repeated_rows(rest, n) == 0);  // distinct rest vertices
  for (const char* transform : {"rigid", "similarity", "affine"}) {
    INFO("--transform " << transform);
    for (const char* name : {"human", "stray"}) {
      const auto r = cli_test::run(
          program, {"deform", "-q", "--transform", transform, "--mesh", dir / (std::string(name) + ".obj"), "--handles",
                    dir / "pose.json", "--out", dir / (std::string(name) + "_out.obj"), "--force"});
      INFO(name << ": " << r.err);
      REQUIRE(r.exit_code == 0);
    }
    const Mesh clean = read_mesh(dir / "human_out.obj"), stray = read_mesh(dir / "stray_out.obj");
    REQUIRE(stray.vertex_count() == n + 1);
    // Distinct rest vertices stay distinct, and exactly the same vertices land on a handle's target (the
    // handle vertices themselves: the points' vertices and the segment's two end vertices).
    CHECK(repeated_rows(clean, n) == 0);
    CHECK(repeated_rows(stray, n) == 0);
    std::vector<Row> targets;
    for (Eigen::Index i : {1337, 3215, 3386, 411, 5906, 2445, 6618, 6786}) targets.push_back(row(clean, i));
    const std::set<Eigen::Index> on = on_targets(clean, n, targets);
    CHECK(on.size() == 8);
    CHECK(on_targets(stray, n, targets) == on);
  }
}
