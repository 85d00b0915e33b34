// The handles file of the command-line tool (core/files/handles/): what it accepts, what it resolves to,
// and a one-line error with the JSON path for each kind of mistake.
#include "core/files/handles_file.hpp"

#include "tests/support/catch.hpp"

using namespace mlsdeform;
using namespace mlsdeform::files;

namespace {

PointsRowMajor<float> four_vertices() {
  PointsRowMajor<float> v(4, 3);
  v << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  return v;
}

// parse + resolve must fail with exactly `message` ("h.json: PATH: PROBLEM").
void require_error(const std::string& json, const std::string& message) {
  INFO("input: " << json);
  try {
    const HandlesFile h = parse_handles(json, "h.json");
    resolve_handles<float>(h, four_vertices());
    FAIL("accepted");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()) == message);
  }
}

}  // namespace

TEST_CASE("point and segment handles by vertex or position, with target, offset or neither", "[cli][handles]") {
  const HandlesFile h = parse_handles(R"({
      // a comment
      "points": [{"vertex": 1, "target": [1, 2, 3]}, {"rest": [0.5, 0.5, 0.5], "offset": [0, 0, 1]}, {"vertex": 3, "name": "fixed"}],
      "segments": [{"vertices": [0, 2], "offset": [1, 0, 0]}, {"rest": [[0, 0, 0], [0, 0, 2]], "target": [[1, 1, 1], [2, 2, 2]]}]
    })",
                                      "h.json");
  CHECK_FALSE(h.animated());
  const auto r = resolve_handles<double>(h, four_vertices());
  REQUIRE(r.frames.size() == 1);
  CHECK(r.rest.points.row(0) == Eigen::RowVector3d(1, 0, 0));
  CHECK(r.rest.points.row(1) == Eigen::RowVector3d(0.5, 0.5, 0.5));
  CHECK(r.rest.points.row(2) == Eigen::RowVector3d(0, 0, 1));
  const auto& q = r.frames[0];
  CHECK(q.points.row(0) == Eigen::RowVector3d(1, 2, 3));
  CHECK(q.points.row(1) == Eigen::RowVector3d(0.5, 0.5, 1.5));
  CHECK(q.points.row(2) == Eigen::RowVector3d(0, 0, 1));  // no target: stays
  CHECK(r.rest.segment_a.row(0) == Eigen::RowVector3d(0, 0, 0));
  CHECK(r.rest.segment_b.row(0) == Eigen::RowVector3d(0, 1, 0));
  CHECK(q.segment_a.row(0) == Eigen::RowVector3d(1, 0, 0));
  CHECK(q.segment_b.row(0) == Eigen::RowVector3d(1, 1, 0));
  CHECK(q.segment_a.row(1) == Eigen::RowVector3d(1, 1, 1));
  CHECK(q.segment_b.row(1) == Eigen::RowVector3d(2, 2, 2));
}

TEST_CASE("frames: one entry per handle, null keeps the handle's own target", "[cli][handles]") {
  const HandlesFile h = parse_handles(R"({
      "points": [{"vertex": 0}, {"vertex": 1, "target": [5, 0, 0]}],
      "segments": [{"vertices": [2, 3]}],
      "frames": [
        {"points": [[0, 0, 1], null]},
        {"points": [{"offset": [0, 1, 0]}, {"target": [6, 0, 0]}], "segments": [[[0, 2, 0], [0, 0, 2]]]},
        {"segments": [{"offset": [1, 1, 1]}]}
      ]})",
                                      "h.json");
  REQUIRE(h.animated());
  const auto r = resolve_handles<float>(h, four_vertices());
  REQUIRE(r.frames.size() == 3);
  CHECK(r.frames[0].points.row(0) == Eigen::RowVector3f(0, 0, 1));
  CHECK(r.frames[0].points.row(1) == Eigen::RowVector3f(5, 0, 0));
  CHECK(r.frames[0].segment_b.row(0) == Eigen::RowVector3f(0, 0, 1));  // no "segments": rest
  CHECK(r.frames[1].points.row(0) == Eigen::RowVector3f(0, 1, 0));
  CHECK(r.frames[1].points.row(1) == Eigen::RowVector3f(6, 0, 0));
  CHECK(r.frames[1].segment_a.row(0) == Eigen::RowVector3f(0, 2, 0));
  CHECK(r.frames[2].segment_a.row(0) == Eigen::RowVector3f(1, 2, 1));
  CHECK(r.frames[2].points.row(1) == Eigen::RowVector3f(5, 0, 0));
}

TEST_CASE("bad handles files: one line with the file, the JSON path and the problem", "[cli][handles][errors]") {
  // Not JSON.
  require_error("{\"points\": [",
                "h.json: line 1, column 13: invalid JSON: syntax error while parsing value - unexpected end of input; "
                "expected '[', '{', or a literal");
  require_error("{\"points\": [\n  {\"vertex\": 1,}\n]}",
                "h.json: line 2, column 16: invalid JSON: syntax error while parsing object key - unexpected '}'; "
                "expected string literal");
  require_error("", "h.json: line 1, column 1: invalid JSON: the file is empty");
  require_error("{\"points\": [{\"rest\": [NaN, 0, 0]}]}",
                "h.json: line 1, column 23: invalid JSON: syntax error while parsing value - invalid literal; last "
                "read: '\"rest\": [N'");
  // Structure.
  require_error("[]", "h.json: /: expected an object with \"points\" and/or \"segments\", found array");
  require_error("{}", "h.json: /: no handles (give at least one entry in \"points\" or \"segments\")");
  require_error("{\"points\": []}", "h.json: /: no handles (give at least one entry in \"points\" or \"segments\")");
  require_error("{\"point\": []}",
                "h.json: /point: unknown key (expected \"points\", \"segments\", \"groups\", \"frames\", \"region\", "
                "\"comment\")");
  require_error("{\"points\": {}}", "h.json: /points: expected an array of point handles, found object");
  require_error(
      "{\"points\": [{\"vertex\": 0, \"tagret\": [0, 0, 0]}]}",
      "h.json: /points/0/tagret: unknown key (expected \"vertex\", \"rest\", \"target\", \"offset\", \"name\")");
  require_error("{\"points\": [{\"target\": [0, 0, 0]}]}", "h.json: /points/0: missing \"vertex\" or \"rest\"");
  require_error("{\"points\": [{\"vertex\": 0, \"rest\": [0, 0, 0]}]}",
                "h.json: /points/0: give \"vertex\" or \"rest\", not both");
  require_error("{\"points\": [{\"vertex\": 0, \"target\": [0, 0, 0], \"offset\": [0, 0, 0]}]}",
                "h.json: /points/0: give \"target\" or \"offset\", not both");
  // Numbers and vectors.
  require_error("{\"points\": [{\"vertex\": 0, \"target\": [0, 0]}]}",
                "h.json: /points/0/target: expected a position [x, y, z], found an array of 2");
  require_error("{\"points\": [{\"vertex\": 0, \"target\": [0, \"1\", 0]}]}",
                "h.json: /points/0/target/1: expected a number, found string");
  require_error("{\"points\": [{\"rest\": [0, 1e999, 0]}]}", "h.json: invalid JSON: number overflow parsing '1e999'");
  require_error("{\"points\": [{\"rest\": [0, 1e300, 0]}]}",
                "h.json: /points/0/rest: coordinates too large for --precision float");
  require_error("{\"points\": [{\"vertex\": -1}]}", "h.json: /points/0/vertex: vertex index -1 is negative");
  require_error("{\"points\": [{\"vertex\": 1.5}]}",
                "h.json: /points/0/vertex: expected a vertex index (an integer from 0), found 1.5");
  // Against the mesh.
  require_error("{\"points\": [{\"vertex\": 4}]}",
                "h.json: /points/0/vertex: vertex index 4 out of range (the mesh has 4 vertices, 0 to 3)");
  require_error("{\"segments\": [{\"vertices\": [0, 9]}]}",
                "h.json: /segments/0/vertices/1: vertex index 9 out of range (the mesh has 4 vertices, 0 to 3)");
  require_error("{\"segments\": [{\"vertices\": [0, 1, 2]}]}",
                "h.json: /segments/0/vertices: expected two vertex indices [i, j], found an array of 3");
  require_error("{\"segments\": [{\"vertices\": [2, 2]}]}",
                "h.json: /segments/0/vertices: zero-length segment (its two ends coincide)");
  require_error("{\"segments\": [{\"rest\": [[0, 0, 0]]}]}",
                "h.json: /segments/0/rest: expected two end points [[x, y, z], [x, y, z]], found an array of 1");
  // Frames.
  require_error("{\"points\": [{\"vertex\": 0}], \"frames\": []}",
                "h.json: /frames: no frames (leave \"frames\" out for a single output)");
  require_error("{\"points\": [{\"vertex\": 0}], \"frames\": [{\"points\": [[0, 0, 0], [1, 1, 1]]}]}",
                "h.json: /frames/0/points: 2 entries, expected 1 (one per point handle)");
  require_error("{\"points\": [{\"vertex\": 0}], \"frames\": [{}, {\"segments\": [null]}]}",
                "h.json: /frames/1/segments: 1 entries, expected 0 (one per segment handle)");
  require_error("{\"points\": [{\"vertex\": 0}], \"frames\": [{\"points\": [{\"offset\": [0, 0, 0], \"x\": 1}]}]}",
                "h.json: /frames/0/points/0/x: unknown key (expected \"target\", \"offset\")");
  require_error("{\"points\": [{\"vertex\": 0}], \"frames\": [{\"points\": [{}]}]}",
                "h.json: /frames/0/points/0: expected \"target\" or \"offset\"");
  require_error("{\"points\": [{\"vertex\": 0}], \"frames\": [{\"points\": [[1e200, 0, 0]]}]}",
                "h.json: /frames/0/points/0: coordinates too large for --precision float");
}

TEST_CASE("double precision takes coordinates float cannot", "[cli][handles]") {
  const HandlesFile h = parse_handles(R"({"points": [{"rest": [1e300, 0, 0]}]})", "h.json");
  CHECK_THROWS_AS(resolve_handles<float>(h, four_vertices()), InputError);
  CHECK(resolve_handles<double>(h, four_vertices()).rest.points(0, 0) == 1e300);
}

TEST_CASE("a missing handles file names the file", "[cli][handles][errors]") {
  CHECK_THROWS_WITH(read_handles("/nonexistent/h.json"), "/nonexistent/h.json: cannot open: No such file or directory");
}

TEST_CASE("duplicate keys in a handles file are refused, at any depth", "[cli][handles][errors]") {
  require_error(R"({"points": [{"vertex": 0, "vertex": 1}]})",
                "h.json: the key \"vertex\" appears twice in one object (keys must be unique)");
  require_error(R"({"points": [{"vertex": 0}], "points": [{"vertex": 1}]})",
                "h.json: the key \"points\" appears twice in one object (keys must be unique)");
  // The same key in different objects is fine.
  const HandlesFile h = parse_handles(R"({"points": [{"vertex": 0}, {"vertex": 1}]})", "h.json");
  CHECK(h.points.size() == 2);
}

TEST_CASE("groups: members go to their rest positions under the group's rigid motion", "[cli][handles][groups]") {
  // Vertices 0 to 3 of four_vertices(); point 3 has its own offset, overridden by its group.
  const HandlesFile h = parse_handles(R"({
      "points": [{"vertex": 0}, {"vertex": 1}, {"vertex": 2}, {"vertex": 3, "offset": [5, 5, 5]}],
      "segments": [{"vertices": [1, 2]}],
      "groups": [
        {"points": [1, 2], "segments": [0], "rotate": {"axis": [0, 0, 2], "degrees": 90, "pivot": [0, 0, 0]},
         "translate": [0, 0, 1], "name": "quarter turn about z, then up"},
        {"points": [3], "translate": [1, 0, 0]},
        {"points": [0], "rotate": {"axis": [0, 0, 1], "degrees": 180}}
      ]})",
                                      "h.json");
  REQUIRE(h.groups.size() == 3);
  const auto r = resolve_handles<double>(h, four_vertices());
  REQUIRE(r.frames.size() == 1);
  const auto& q = r.frames[0];
  // A quarter turn is exact: (x, y, z) -> (-y, x, z), then + (0, 0, 1).
  CHECK(q.points.row(1) == Eigen::RowVector3d(0, 1, 1));
  CHECK(q.points.row(2) == Eigen::RowVector3d(-1, 0, 1));
  CHECK(q.segment_a.row(0) == Eigen::RowVector3d(0, 1, 1));
  CHECK(q.segment_b.row(0) == Eigen::RowVector3d(-1, 0, 1));
  CHECK(q.points.row(3) == Eigen::RowVector3d(1, 0, 1));  // the group's motion, not the handle's own offset
  CHECK(q.points.row(0) == Eigen::RowVector3d(0, 0, 0));  // a turn about its own centroid: itself
  CHECK(r.rest.points.row(3) == Eigen::RowVector3d(0, 0, 1));
}

TEST_CASE("groups: the default pivot is the group's rest centroid", "[cli][handles][groups]") {
  // Points at (1, 0, 0) and (0, 1, 0), segment (0, 0, 0)-(0, 0, 1): centroid (1, 1, 1) / 4.
  const HandlesFile h = parse_handles(R"({
      "points": [{"vertex": 1}, {"vertex": 2}], "segments": [{"vertices": [0, 3]}],
      "groups": [{"points": [0, 1], "segments": [0], "rotate": {"axis": [1, 1, 1], "degrees": 120}}]})",
                                      "h.json");
  const auto r = resolve_handles<double>(h, four_vertices());
  // 120 degrees about (1, 1, 1) cycles x -> y -> z, and fixes the centroid on that axis.
  const auto& q = r.frames[0];
  CHECK((q.points.row(0) - Eigen::RowVector3d(0, 1, 0)).norm() < 1e-15);
  CHECK((q.points.row(1) - Eigen::RowVector3d(0, 0, 1)).norm() < 1e-15);
  CHECK((q.segment_a.row(0) - Eigen::RowVector3d(0, 0, 0)).norm() < 1e-15);
  CHECK((q.segment_b.row(0) - Eigen::RowVector3d(1, 0, 0)).norm() < 1e-15);
}

TEST_CASE("groups in frames: one entry per group, null keeps the group's own motion", "[cli][handles][groups]") {
  const HandlesFile h = parse_handles(R"({
      "points": [{"vertex": 0}, {"vertex": 1}, {"vertex": 2}],
      "groups": [{"points": [1, 2], "translate": [0, 0, 1]}],
      "frames": [
        {"groups": [null]},
        {"groups": [{"rotate": {"axis": [0, 0, 1], "degrees": -90, "pivot": [0, 0, 0]}}]},
        {"points": [[1, 1, 1], [7, 7, 7], null], "groups": [{}]},
        {}
      ]})",
                                      "h.json");
  const auto r = resolve_handles<float>(h, four_vertices());
  REQUIRE(r.frames.size() == 4);
  CHECK(r.frames[0].points.row(1) == Eigen::RowVector3f(1, 0, 1));
  CHECK(r.frames[1].points.row(1) == Eigen::RowVector3f(0, -1, 0));  // -90 degrees: (x, y) -> (y, -x)
  CHECK(r.frames[1].points.row(2) == Eigen::RowVector3f(1, 0, 0));
  CHECK(r.frames[2].points.row(0) == Eigen::RowVector3f(1, 1, 1));  // not in a group: the frame's entry
  CHECK(r.frames[2].points.row(1) == Eigen::RowVector3f(1, 0, 0));  // {}: the group at rest, over the entry
  CHECK(r.frames[3].points.row(2) == Eigen::RowVector3f(0, 1, 1));  // no "groups": the group's own motion
}

TEST_CASE("bad groups: one line with the file, the JSON path and the problem", "[cli][handles][groups][errors]") {
  const std::string handles = R"("points": [{"vertex": 0}, {"vertex": 1}], "segments": [{"vertices": [2, 3]}], )";
  auto file = [&](const std::string& rest) { return "{" + handles + rest + "}"; };
  require_error(file(R"("groups": {})"), "h.json: /groups: expected an array of handle groups, found object");
  require_error(file(R"("groups": [[0]])"),
                "h.json: /groups/0: expected a handle group {\"points\": [...], \"segments\": [...], \"rotate\": "
                "{...}, \"translate\": [...]}, found array");
  require_error(file(R"("groups": [{"points": [0], "rotation": {}}])"),
                "h.json: /groups/0/rotation: unknown key (expected \"points\", \"segments\", \"rotate\", "
                "\"translate\", \"name\")");
  require_error(
      file(R"("groups": [{"points": [0], "rotate": {"axis": [0, 0, 1], "degrees": 9, "centre": [0, 0, 0]}}])"),
      "h.json: /groups/0/rotate/centre: unknown key (expected \"axis\", \"degrees\", \"pivot\")");
  require_error(file(R"("groups": [{}])"),
                "h.json: /groups/0: empty group (give handle indices in \"points\" or \"segments\")");
  require_error(file(R"("groups": [{"points": [2]}])"),
                "h.json: /groups/0/points/0: point handle 2 out of range (the file has 2 point handles, 0 to 1)");
  require_error(file(R"("groups": [{"segments": [0, 1]}])"),
                "h.json: /groups/0/segments/1: segment handle 1 out of range (the file has 1 segment handles, 0 to 0)");
  require_error(file(R"("groups": [{"points": [-1]}])"),
                "h.json: /groups/0/points/0: point handle index -1 is negative");
  require_error(file(R"("groups": [{"points": [0.5]}])"),
                "h.json: /groups/0/points/0: expected a point handle index (an integer from 0), found 0.5");
  require_error(file(R"("groups": [{"points": [0]}, {"points": [1, 0]}])"),
                "h.json: /groups/1/points/1: point handle 0 is already in a group (at /groups/0/points/0); a handle "
                "can be in one group only");
  require_error(file(R"("groups": [{"segments": [0, 0]}])"),
                "h.json: /groups/0/segments/1: segment handle 0 is already in a group (at /groups/0/segments/0); a "
                "handle can be in one group only");
  require_error(file(R"("groups": [{"points": [0], "rotate": {"axis": [0, 0, 0], "degrees": 30}}])"),
                "h.json: /groups/0/rotate/axis: zero axis (a rotation needs a direction)");
  require_error(file(R"("groups": [{"points": [0], "rotate": {"degrees": 30}}])"),
                "h.json: /groups/0/rotate: missing \"axis\"");
  require_error(file(R"("groups": [{"points": [0], "rotate": {"axis": [1, 0, 0]}}])"),
                "h.json: /groups/0/rotate: missing \"degrees\"");
  require_error(file(R"("groups": [{"points": [0], "rotate": {"axis": [1, 0, 0], "degrees": "30"}}])"),
                "h.json: /groups/0/rotate/degrees: expected a number, found string");
  require_error(file(R"("groups": [{"points": [0], "translate": [0, 1e999, 0]}])"),
                "h.json: invalid JSON: number overflow parsing '1e999'");
  require_error(file(R"("groups": [{"points": [0], "translate": [0, 1e300, 0]}])"),
                "h.json: /groups/0: coordinates too large for --precision float");
  require_error(file(R"("groups": [{"points": [0], "rotate": {"axis": [1, 0, 0], "degrees": 90, "pivot": [0, 0]}}])"),
                "h.json: /groups/0/rotate/pivot: expected a position [x, y, z], found an array of 2");
  // Frames.
  require_error(file(R"("groups": [{"points": [0]}], "frames": [{"groups": []}])"),
                "h.json: /frames/0/groups: 0 entries, expected 1 (one per group)");
  require_error(file(R"("frames": [{"groups": [null]}])"),
                "h.json: /frames/0/groups: 1 entries, expected 0 (one per group)");
  require_error(file(R"("groups": [{"points": [0]}], "frames": [{"groups": [{"points": [1]}]}])"),
                "h.json: /frames/0/groups/0/points: unknown key (expected \"rotate\", \"translate\")");
  require_error(file(R"("groups": [{"points": [0]}], "frames": [{"groups": [[0, 0, 1]]}])"),
                "h.json: /frames/0/groups/0: expected null or a motion {\"rotate\": {...}, \"translate\": [dx, dy, "
                "dz]}, found array");
  require_error(
      file(R"("groups": [{"points": [0]}], "frames": [{"groups": [{"rotate": {"axis": [0, 0, 0], "degrees": 1}}]}])"),
      "h.json: /frames/0/groups/0/rotate/axis: zero axis (a rotation needs a direction)");
  require_error(file(R"("groups": [{"points": [0]}], "frames": [{"groups": [{"translate": [1e300, 0, 0]}]}])"),
                "h.json: /frames/0/groups/0: coordinates too large for --precision float");
}

TEST_CASE("InputError: one line of valid UTF-8, a UTF-8 file name kept", "[files]") {
  // A newline and bytes that are not UTF-8 (a lone continuation byte, a truncated sequence, an overlong form, a
  // surrogate) escaped as \xNN; well-formed sequences of 2, 3 and 4 bytes kept.
  const std::string name = "caf\xc3\xa9_\xe2\x82\xac_\xf0\x9f\x98\x80.ply";
  const InputError e(name, "bad \x80 \xc3 \xc0\xaf \xed\xa0\x80 line\nend");
  CHECK(std::string(e.what()) == name + ": bad \\x80 \\xc3 \\xc0\\xaf \\xed\\xa0\\x80 line\\x0aend");
}
