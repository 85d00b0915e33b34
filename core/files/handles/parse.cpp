// mlsdeform files, the handles file: parse_handles and read_handles (handles_file.hpp), the file checked on its
// own: its syntax (no duplicate keys), the types, the required and unknown keys, and the counts.
#include "core/files/file_io.hpp"
#include "core/files/handles/json_node.hpp"
#include "core/files/handles_file.hpp"

#include <nlohmann/json.hpp>

#include <set>
#include <string>
#include <unordered_map>
#include <vector>

namespace mlsdeform::files {
namespace {

using handles::json;
using handles::Node;

// "target": absolute, or "offset": relative to the rest position; neither: stays at rest.
Target parse_target(const Node& n, bool segment) {
  if (n.has("target") && n.has("offset")) n.fail("give \"target\" or \"offset\", not both");
  Target t;
  if (n.has("target")) {
    t.kind = Target::Kind::absolute;
    if (segment) {
      const auto ab = n["target"].vec3_pair();
      t.a = ab[0];
      t.b = ab[1];
    } else {
      t.a = n["target"].vec3();
    }
  } else if (n.has("offset")) {
    t.kind = Target::Kind::offset;
    t.a = n["offset"].vec3();
  }
  return t;
}

PointHandleSpec parse_point(const Node& n) {
  n.require_object("a point handle {\"vertex\": i} or {\"rest\": [x, y, z]}");
  n.only_keys({"vertex", "rest", "target", "offset", "name"});
  PointHandleSpec h;
  h.path = n.path;
  n.exactly_one_of("vertex", "rest");
  if (n.has("vertex"))
    h.vertex = n["vertex"].index();
  else
    h.rest = n["rest"].vec3();
  h.target = parse_target(n, false);
  return h;
}

SegmentHandleSpec parse_segment(const Node& n) {
  n.require_object("a segment handle {\"vertices\": [i, j]} or {\"rest\": [[x, y, z], [x, y, z]]}");
  n.only_keys({"vertices", "rest", "target", "offset", "name"});
  SegmentHandleSpec h;
  h.path = n.path;
  n.exactly_one_of("vertices", "rest");
  if (n.has("vertices")) {
    const Node vs = n["vertices"];
    if (!vs.v.is_array() || vs.v.size() != 2)
      vs.fail(std::string("expected two vertex indices [i, j], found ") +
              (vs.v.is_array() ? "an array of " + std::to_string(vs.v.size()) : std::string(vs.v.type_name())));
    h.vertices = std::array<std::uint64_t, 2>{vs.at(0).index(), vs.at(1).index()};
  } else {
    const auto ab = n["rest"].vec3_pair();
    h.rest_a = ab[0];
    h.rest_b = ab[1];
  }
  h.target = parse_target(n, true);
  return h;
}

// A frame's entry for one handle: null (its own target), a position (point) or two (segment), or an object
// {"target": ...} / {"offset": [dx, dy, dz]}.
std::optional<Target> parse_frame_entry(const Node& n, bool segment) {
  if (n.v.is_null()) return std::nullopt;
  if (n.v.is_object()) {
    n.only_keys({"target", "offset"});
    if (!n.has("target") && !n.has("offset")) n.fail("expected \"target\" or \"offset\"");
    return parse_target(n, segment);
  }
  Target t;
  t.kind = Target::Kind::absolute;
  if (segment) {
    const auto ab = n.vec3_pair();
    t.a = ab[0];
    t.b = ab[1];
  } else {
    t.a = n.vec3();
  }
  return t;
}

std::vector<std::optional<Target>> parse_frame_list(const Node& frame, const char* key, std::size_t count,
                                                    bool segment) {
  std::vector<std::optional<Target>> out(count);
  if (!frame.has(key)) return out;
  const Node list = frame[key];
  list.require_array(segment ? "an array with one entry per segment handle"
                             : "an array with one entry per point handle");
  if (list.v.size() != count)
    list.fail(std::to_string(list.v.size()) + " entries, expected " + std::to_string(count) + " (one per " +
              (segment ? "segment" : "point") + " handle)");
  for (std::size_t i = 0; i < count; ++i) out[i] = parse_frame_entry(list.at(i), segment);
  return out;
}

// A group's or a frame's motion: {"rotate": {"axis": [x, y, z], "degrees": a, "pivot": [x, y, z]},
// "translate": [dx, dy, dz]}, each part optional (neither: the group stays at rest).
Motion parse_motion(const Node& n) {
  Motion m;
  m.path = n.path;
  if (n.has("rotate")) {
    const Node r = n["rotate"];
    r.require_object("a rotation {\"axis\": [x, y, z], \"degrees\": a, \"pivot\": [x, y, z]}");
    r.only_keys({"axis", "degrees", "pivot"});
    if (!r.has("axis") || !r.has("degrees")) r.fail(r.has("axis") ? "missing \"degrees\"" : "missing \"axis\"");
    const Eigen::Vector3d axis = r["axis"].vec3();
    // Scaled by its largest component first, so that neither tiny nor huge axes over- or underflow.
    const double big = axis.cwiseAbs().maxCoeff();
    if (big == 0) r["axis"].fail("zero axis (a rotation needs a direction)");
    m.axis = (axis / big).normalized();
    m.degrees = r["degrees"].number();
    if (r.has("pivot")) m.pivot = r["pivot"].vec3();
  }
  if (n.has("translate")) m.translate = n["translate"].vec3();
  return m;
}

// "points" / "segments" of a group: indices of handles, each in one group only (`owner` holds the path where
// each handle was listed, empty if nowhere yet).
std::vector<std::size_t> parse_members(const Node& group, const char* key, std::vector<std::string>& owner) {
  std::vector<std::size_t> out;
  if (!group.has(key)) return out;
  const bool points = std::string_view(key) == "points";
  const char* kind = points ? "point handle" : "segment handle";
  const Node list = group[key];
  list.require_array(points ? "an array of point handle indices" : "an array of segment handle indices");
  for (std::size_t j = 0; j < list.v.size(); ++j) {
    const Node item = list.at(j);
    const std::uint64_t i = item.index(kind);
    if (i >= owner.size())
      item.fail(std::string(kind) + " " + std::to_string(i) + " out of range (the file has " +
                std::to_string(owner.size()) + " " + kind + "s" +
                (owner.empty() ? std::string() : ", 0 to " + std::to_string(owner.size() - 1)) + ")");
    const std::size_t at = std::size_t(i);  // below owner.size(): fits
    if (!owner[at].empty())
      item.fail(std::string(kind) + " " + std::to_string(i) + " is already in a group (at " + owner[at] +
                "); a handle can be in one group only");
    owner[at] = item.path;
    out.push_back(at);
  }
  return out;
}

GroupSpec parse_group(const Node& n, std::vector<std::string>& point_owner, std::vector<std::string>& segment_owner) {
  n.require_object("a handle group {\"points\": [...], \"segments\": [...], \"rotate\": {...}, \"translate\": [...]}");
  n.only_keys({"points", "segments", "rotate", "translate", "name"});
  GroupSpec g;
  g.path = n.path;
  g.points = parse_members(n, "points", point_owner);
  g.segments = parse_members(n, "segments", segment_owner);
  if (g.points.empty() && g.segments.empty()) n.fail("empty group (give handle indices in \"points\" or \"segments\")");
  g.motion = parse_motion(n);
  return g;
}

// A frame's entry for one group: null (the group's own motion) or {"rotate": ..., "translate": ...}.
std::optional<Motion> parse_frame_motion(const Node& n) {
  if (n.v.is_null()) return std::nullopt;
  n.require_object("null or a motion {\"rotate\": {...}, \"translate\": [dx, dy, dz]}");
  n.only_keys({"rotate", "translate"});
  return parse_motion(n);
}

std::string one_line(std::string s) {
  for (auto& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

}  // namespace

HandlesFile parse_handles(std::string_view text, const std::string& file) {
  json doc;
  // JSON leaves duplicate keys to the reader, and nlohmann keeps the last: {"vertex": 0, "vertex": 1} would
  // silently mean vertex 1. Refuse them: one set of keys per open object.
  std::vector<std::set<std::string>> open_objects;
  std::string duplicate;
  const json::parser_callback_t unique_keys = [&](int, json::parse_event_t event, json& parsed) {
    if (event == json::parse_event_t::object_start)
      open_objects.emplace_back();
    else if (event == json::parse_event_t::object_end && !open_objects.empty())
      open_objects.pop_back();
    else if (event == json::parse_event_t::key && !open_objects.empty() && duplicate.empty() &&
             !open_objects.back().insert(parsed.get<std::string>()).second)
      duplicate = parsed.get<std::string>();
    return true;
  };
  // nlohmann's words for an empty input differ between versions (3.11.3, Debian 13: "attempting to parse an
  // empty input"): ours, the same everywhere.
  if (text.empty()) throw InputError(file, "invalid JSON: the file is empty", "line 1, column 1");
  try {
    doc = json::parse(text.begin(), text.end(), unique_keys, /*allow_exceptions=*/true, /*ignore_comments=*/true);
  } catch (const json::parse_error& e) {
    // Line and column of the byte where parsing stopped; nlohmann's text after "column N: " says why.
    std::size_t line = 1, column = 1;
    for (std::size_t i = 0; i + 1 < e.byte && i < text.size(); ++i) {
      if (text[i] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
    std::string why = e.what();
    const auto p = why.find(": ", why.find("parse error"));
    if (p != std::string::npos) why = why.substr(p + 2);
    throw InputError(file, "invalid JSON: " + one_line(why),
                     "line " + std::to_string(line) + ", column " + std::to_string(column));
  } catch (const json::exception& e) {  // e.g. out_of_range 406, "number overflow parsing '1e999'" (no position)
    std::string why = e.what();
    if (const auto p = why.find("] "); p != std::string::npos) why = why.substr(p + 2);
    throw InputError(file, "invalid JSON: " + one_line(why));
  }

  if (!duplicate.empty())
    throw InputError(file, "the key \"" + duplicate + "\" appears twice in one object (keys must be unique)");
  const Node root{doc, "", file};
  root.require_object("an object with \"points\" and/or \"segments\"");
  root.only_keys({"points", "segments", "groups", "frames", "region", "comment"});
  HandlesFile h;
  h.file = file;
  if (root.has("points")) {
    const Node points = root["points"];
    points.require_array("an array of point handles");
    for (std::size_t i = 0; i < points.v.size(); ++i) h.points.push_back(parse_point(points.at(i)));
  }
  if (root.has("segments")) {
    const Node segments = root["segments"];
    segments.require_array("an array of segment handles");
    for (std::size_t i = 0; i < segments.v.size(); ++i) h.segments.push_back(parse_segment(segments.at(i)));
  }
  if (h.points.empty() && h.segments.empty())
    root.fail("no handles (give at least one entry in \"points\" or \"segments\")");
  if (root.has("region")) {
    const Node region = root["region"];
    region.require_array("an array of vertex indices");
    if (region.v.empty()) region.fail("no vertices (leave \"region\" out to deform the whole mesh)");
    std::unordered_map<std::uint64_t, std::size_t> first;
    for (std::size_t i = 0; i < region.v.size(); ++i) {
      const std::uint64_t v = region.at(i).index();
      const auto [it, inserted] = first.emplace(v, i);
      if (!inserted)
        region.at(i).fail("vertex " + std::to_string(v) + " is listed twice (first at /region/" +
                          std::to_string(it->second) + ")");
      h.region.push_back(v);
    }
  }
  if (root.has("groups")) {
    const Node groups = root["groups"];
    groups.require_array("an array of handle groups");
    std::vector<std::string> point_owner(h.points.size()), segment_owner(h.segments.size());
    for (std::size_t g = 0; g < groups.v.size(); ++g)
      h.groups.push_back(parse_group(groups.at(g), point_owner, segment_owner));
  }
  if (root.has("frames")) {
    const Node frames = root["frames"];
    frames.require_array("an array of frames");
    if (frames.v.empty()) frames.fail("no frames (leave \"frames\" out for a single output)");
    for (std::size_t f = 0; f < frames.v.size(); ++f) {
      const Node frame = frames.at(f);
      frame.require_object("a frame {\"points\": [...], \"segments\": [...], \"groups\": [...]}");
      frame.only_keys({"points", "segments", "groups", "comment"});
      FrameSpec fs;
      fs.points = parse_frame_list(frame, "points", h.points.size(), false);
      fs.segments = parse_frame_list(frame, "segments", h.segments.size(), true);
      fs.groups.resize(h.groups.size());
      if (frame.has("groups")) {
        const Node list = frame["groups"];
        list.require_array("an array with one entry per group");
        if (list.v.size() != h.groups.size())
          list.fail(std::to_string(list.v.size()) + " entries, expected " + std::to_string(h.groups.size()) +
                    " (one per group)");
        for (std::size_t g = 0; g < h.groups.size(); ++g) fs.groups[g] = parse_frame_motion(list.at(g));
      }
      h.frames.push_back(std::move(fs));
    }
  }
  return h;
}

HandlesFile read_handles(const std::string& path) {
  return parse_handles(read_file(path, std::size_t(256) << 20), path);
}

}  // namespace mlsdeform::files
