#include "tools/cli/handles_file.hpp"

#include "tools/cli/file_io.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

namespace mlsdeform::cli {
namespace {

using nlohmann::json;

// A JSON value with its RFC 6901 path, so that every check can say where it failed.
struct Node {
  const json& v;
  std::string path;
  const std::string& file;

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(file, problem, path.empty() ? "/" : path);
  }

  Node operator[](const char* key) const { return {v.at(key), path + "/" + key, file}; }
  Node at(std::size_t i) const { return {v.at(i), path + "/" + std::to_string(i), file}; }
  bool has(const char* key) const { return v.contains(key); }

  void require_object(const char* what) const {
    if (!v.is_object()) fail(std::string("expected ") + what + ", found " + v.type_name());
  }
  void require_array(const char* what) const {
    if (!v.is_array()) fail(std::string("expected ") + what + ", found " + v.type_name());
  }
  void only_keys(std::initializer_list<const char*> allowed) const {
    for (const auto& item : v.items()) {
      bool ok = false;
      for (const char* a : allowed) ok = ok || item.key() == a;
      if (!ok) {
        std::string list;
        for (const char* a : allowed) list += std::string(list.empty() ? "" : ", ") + "\"" + a + "\"";
        Node{item.value(), path + "/" + escape(item.key()), file}.fail("unknown key (expected " + list + ")");
      }
    }
  }
  static std::string escape(const std::string& key) {  // RFC 6901: ~ -> ~0, / -> ~1
    std::string s;
    for (char c : key) s += c == '~' ? "~0" : c == '/' ? "~1" : std::string(1, c);
    return s;
  }

  double number() const {
    if (!v.is_number()) fail(std::string("expected a number, found ") + v.type_name());
    const double d = v.get<double>();
    if (!std::isfinite(d)) fail("not a finite number");
    return d;
  }
  Eigen::Vector3d vec3() const {
    if (!v.is_array() || v.size() != 3)
      fail(std::string("expected a position [x, y, z], found ") +
           (v.is_array() ? "an array of " + std::to_string(v.size()) : std::string(v.type_name())));
    return {at(0).number(), at(1).number(), at(2).number()};
  }
  std::array<Eigen::Vector3d, 2> vec3_pair() const {
    if (!v.is_array() || v.size() != 2)
      fail(std::string("expected two end points [[x, y, z], [x, y, z]], found ") +
           (v.is_array() ? "an array of " + std::to_string(v.size()) : std::string(v.type_name())));
    return {at(0).vec3(), at(1).vec3()};
  }
  std::uint64_t index(const char* what = "vertex") const {
    if (v.is_number_unsigned()) return v.get<std::uint64_t>();
    if (v.is_number_integer())
      fail(std::string(what) + " index " + std::to_string(v.get<std::int64_t>()) + " is negative");
    fail(std::string("expected a ") + what + " index (an integer from 0), found " +
         (v.is_number() ? v.dump() : v.type_name()));
  }
};

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
  if (n.has("vertex") == n.has("rest"))
    n.fail(n.has("vertex") ? "give \"vertex\" or \"rest\", not both" : "missing \"vertex\" or \"rest\"");
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
  if (n.has("vertices") == n.has("rest"))
    n.fail(n.has("vertices") ? "give \"vertices\" or \"rest\", not both" : "missing \"vertices\" or \"rest\"");
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
    if (!owner[i].empty())
      item.fail(std::string(kind) + " " + std::to_string(i) + " is already in a group (at " + owner[i] +
                "); a handle can be in one group only");
    owner[i] = item.path;
    out.push_back(std::size_t(i));
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

namespace {

template <class T>
struct Converter {
  const std::string& file;
  Vector3<T> operator()(const Eigen::Vector3d& p, const std::string& path) const {
    const Vector3<T> q = p.cast<T>();
    if (!q.allFinite())
      throw InputError(
          file, "coordinates too large for " + std::string(std::is_same_v<T, float> ? "--precision float" : "double"),
          path);
    return q;
  }
};

template <class T>
void set_row(Points<T>& m, std::size_t i, const Vector3<T>& v) {
  m.row(Eigen::Index(i)) = v.transpose();
}

// sin and cos of an angle in degrees, exact at multiples of 90 degrees (a quarter turn moves handles exactly).
std::array<double, 2> sin_cos_degrees(double degrees) {
  const double r = std::remainder(degrees, 360.0);  // exact, in [-180, 180]
  const double q = std::nearbyint(r / 90);          // quadrant, -2 to 2
  const double f = r - 90 * q;  // exact (Sterbenz: r and 90 q are within a factor 2 unless q = 0), |f| <= 45
  const double s = std::sin(f * (M_PI / 180)), c = std::cos(f * (M_PI / 180));
  switch ((int(q) + 4) % 4) {
    case 1:
      return {c, -s};
    case 2:
      return {-s, -c};
    case 3:
      return {-c, s};
    default:
      return {s, c};
  }
}

// The rotation by `degrees` about the unit `axis` (Rodrigues: R = c I + s [a]_x + (1 - c) a a^T).
Eigen::Matrix3d rotation(const Eigen::Vector3d& a, double degrees) {
  const auto [s, c] = sin_cos_degrees(degrees);
  Eigen::Matrix3d K;
  K << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return c * Eigen::Matrix3d::Identity() + s * K + (1 - c) * a * a.transpose();
}

}  // namespace

template <class T, class V>
ResolvedHandles<T> resolve_handles(const HandlesFile& h, const PointsRowMajor<V>& vertices) {
  const auto n = std::uint64_t(vertices.rows());
  const Converter<T> convert{h.file};
  auto vertex = [&](std::uint64_t i, const std::string& path) -> Eigen::Vector3d {
    if (i >= n)
      throw InputError(h.file,
                       "vertex index " + std::to_string(i) + " out of range (the mesh has " + std::to_string(n) +
                           " vertices" + (n ? ", 0 to " + std::to_string(n - 1) : std::string()) + ")",
                       path);
    return vertices.row(Eigen::Index(i)).transpose().template cast<double>();
  };

  ResolvedHandles<T> r;
  const std::size_t k = h.points.size(), s = h.segments.size();
  r.rest.points.resize(Eigen::Index(k), 3);
  r.rest.segment_a.resize(Eigen::Index(s), 3);
  r.rest.segment_b.resize(Eigen::Index(s), 3);
  std::vector<Eigen::Vector3d> point_rest(k), seg_a(s), seg_b(s);
  for (std::size_t i = 0; i < k; ++i) {
    const auto& p = h.points[i];
    point_rest[i] = p.vertex ? vertex(*p.vertex, p.path + "/vertex") : p.rest;
    set_row(r.rest.points, i, convert(point_rest[i], p.path + (p.vertex ? "/vertex" : "/rest")));
  }
  for (std::size_t i = 0; i < s; ++i) {
    const auto& g = h.segments[i];
    if (g.vertices) {
      seg_a[i] = vertex((*g.vertices)[0], g.path + "/vertices/0");
      seg_b[i] = vertex((*g.vertices)[1], g.path + "/vertices/1");
    } else {
      seg_a[i] = g.rest_a;
      seg_b[i] = g.rest_b;
    }
    const std::string where = g.path + (g.vertices ? "/vertices" : "/rest");
    set_row(r.rest.segment_a, i, convert(seg_a[i], where));
    set_row(r.rest.segment_b, i, convert(seg_b[i], where));
    if (r.rest.segment_a.row(Eigen::Index(i)) == r.rest.segment_b.row(Eigen::Index(i)))
      throw InputError(h.file, "zero-length segment (its two ends coincide)", where);
  }

  for (std::size_t i = 0; i < h.region.size(); ++i) {
    vertex(h.region[i], "/region/" + std::to_string(i));  // in range, or InputError
    r.region.push_back(Eigen::Index(h.region[i]));
  }

  // A frame: each handle's entry, or its own target when the frame has none.
  // Each group's rest centroid (the default pivot): the mean of its points and its segments' end points.
  std::vector<Eigen::Vector3d> centroid;
  for (const GroupSpec& gs : h.groups) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (std::size_t i : gs.points) sum += point_rest[i];
    for (std::size_t i : gs.segments) sum += seg_a[i] + seg_b[i];
    centroid.push_back(sum / double(gs.points.size() + 2 * gs.segments.size()));
  }

  auto moved = [&](const std::vector<std::optional<Target>>* fp, const std::vector<std::optional<Target>>* fs,
                   const std::vector<std::optional<Motion>>* fg, const std::string& frame_path) {
    Handles<T> m;
    m.points.resize(Eigen::Index(k), 3);
    m.segment_a.resize(Eigen::Index(s), 3);
    m.segment_b.resize(Eigen::Index(s), 3);
    for (std::size_t i = 0; i < k; ++i) {
      const bool own = !fp || !(*fp)[i];
      const Target& t = own ? h.points[i].target : *(*fp)[i];
      const std::string path = own ? h.points[i].path : frame_path + "/points/" + std::to_string(i);
      const Eigen::Vector3d q = t.kind == Target::Kind::rest       ? point_rest[i]
                                : t.kind == Target::Kind::absolute ? t.a
                                                                   : point_rest[i] + t.a;
      set_row(m.points, i, convert(q, path));
    }
    for (std::size_t i = 0; i < s; ++i) {
      const bool own = !fs || !(*fs)[i];
      const Target& t = own ? h.segments[i].target : *(*fs)[i];
      const std::string path = own ? h.segments[i].path : frame_path + "/segments/" + std::to_string(i);
      Eigen::Vector3d a = seg_a[i], b = seg_b[i];
      if (t.kind == Target::Kind::absolute) {
        a = t.a;
        b = t.b;
      } else if (t.kind == Target::Kind::offset) {
        a += t.a;
        b += t.a;
      }
      set_row(m.segment_a, i, convert(a, path));
      set_row(m.segment_b, i, convert(b, path));
    }
    // Groups, after the handles' own targets: their members go to their rest positions under the motion.
    for (std::size_t g = 0; g < h.groups.size(); ++g) {
      const GroupSpec& gs = h.groups[g];
      const Motion& mo = fg && (*fg)[g] ? *(*fg)[g] : gs.motion;
      const Eigen::Matrix3d R = rotation(mo.axis, mo.degrees);
      const Eigen::Vector3d c = mo.pivot ? *mo.pivot : centroid[g];
      const auto image = [&](const Eigen::Vector3d& x) -> Eigen::Vector3d { return R * (x - c) + c + mo.translate; };
      for (std::size_t i : gs.points) set_row(m.points, i, convert(image(point_rest[i]), mo.path));
      for (std::size_t i : gs.segments) {
        set_row(m.segment_a, i, convert(image(seg_a[i]), mo.path));
        set_row(m.segment_b, i, convert(image(seg_b[i]), mo.path));
      }
    }
    return m;
  };
  if (h.frames.empty()) {
    r.frames.push_back(moved(nullptr, nullptr, nullptr, {}));
  } else {
    r.frames.reserve(h.frames.size());
    for (std::size_t f = 0; f < h.frames.size(); ++f)
      r.frames.push_back(
          moved(&h.frames[f].points, &h.frames[f].segments, &h.frames[f].groups, "/frames/" + std::to_string(f)));
  }
  return r;
}

template ResolvedHandles<float> resolve_handles<float, float>(const HandlesFile&, const PointsRowMajor<float>&);
template ResolvedHandles<float> resolve_handles<float, double>(const HandlesFile&, const PointsRowMajor<double>&);
template ResolvedHandles<double> resolve_handles<double, float>(const HandlesFile&, const PointsRowMajor<float>&);
template ResolvedHandles<double> resolve_handles<double, double>(const HandlesFile&, const PointsRowMajor<double>&);

}  // namespace mlsdeform::cli
