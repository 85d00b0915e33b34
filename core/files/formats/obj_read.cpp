// The Wavefront OBJ reader: `v` lines and `f` lines (v, v/vt, v//vn or v/vt/vn corners, every index in range,
// negative ones counted back from the last `v`, `vt` or `vn`); every other line (texture coordinates, normals,
// names, groups, materials, smoothing, points and lines, comments) is kept verbatim in order (ObjExtras), and what
// follows a vertex's coordinates (colours) with it; `vn` values and the normal each corner names are read for
// transform_normals. Points and lines are counted (other formats drop them); any other statement is refused.
#include "core/files/formats/reader.hpp"

namespace mlsdeform::files::formats {

template <class T>
BasicMesh<T> read_obj(Reader& reader, const std::string& path) {
  BasicMesh<T> mesh;
  ObjExtras x;
  std::deque<T> coords;
  std::deque<std::uint32_t> corners, face_start{0};  // corners 0-based; relative (negative) ones resolved
  std::deque<double> normals;
  std::deque<std::uint32_t> corner_normals;  // per corner, ObjExtras::kNone where it names no normal
  bool any_corner_normal = false;
  std::uint64_t max_corner = 0;  // the largest 1-based index, checked at the end
  std::size_t max_corner_line = 0;
  std::uint64_t max_normal = 0;  // the same for normals
  std::size_t max_normal_line = 0;
  std::uint64_t max_texture = 0;  // and for texture coordinates (vt)
  std::size_t max_texture_line = 0;
  std::vector<std::string_view> t;
  Lines lines(reader);
  auto keep_line = [&] {
    // This writer's stamp on the first line is written anew, not kept (it would pile up).
    if (lines.line() == 1 && lines.raw().rfind("# written by mlsdeform ", 0) == 0) return;
    x.text.append(lines.raw());
    x.text.push_back('\n');
    if (x.runs.empty() || x.runs.back().vertices)
      x.runs.push_back({false, 1});
    else
      ++x.runs.back().count;
  };
  while (lines.next(t)) {
    if (t.empty()) {
      keep_line();
      continue;
    }
    const std::string_view key = t[0];
    if (key == "v") {
      const std::size_t n = t.size() - 1;
      if (n != 3 && n != 4 && n != 6)
        throw InputError(
            path, "a vertex needs 3 coordinates (x y z, optionally w, or x y z r g b), found " + std::to_string(n),
            at_line(lines.line()));
      T c[6];
      for (std::size_t k = 0; k < n; ++k) c[k] = coordinate<T>(t[k + 1], path, at_line(lines.line()));
      if (n == 4) {
        if (c[3] == 0) throw InputError(path, "vertex with w = 0", at_line(lines.line()));
        for (int k = 0; k < 3; ++k) c[k] /= c[3];
      }
      if (!finite3(c)) throw InputError(path, non_finite(coords.size() / 3), at_line(lines.line()));
      // Kept: what follows x y z (colours, a comment); w is applied to x y z and not written again.
      x.vertex_tails.set(coords.size() / 3, tail_after(lines.raw(), t[n == 4 ? 4 : 3]));
      coords.insert(coords.end(), c, c + 3);
      if (x.runs.empty() || !x.runs.back().vertices)
        x.runs.push_back({true, 1});
      else
        ++x.runs.back().count;
      continue;
    }
    keep_line();
    if (key == "f") {
      if (t.size() < 4)
        throw InputError(path, "a face needs at least 3 vertices, found " + std::to_string(t.size() - 1),
                         at_line(lines.line()));
      const auto defined = std::int64_t(coords.size() / 3);
      for (std::size_t k = 1; k < t.size(); ++k) {
        // v, v/vt, v//vn or v/vt/vn: every part an integer.
        const std::string_view corner = t[k];
        std::size_t slash = corner.find('/');
        std::int64_t v = 0;
        if (!parse_number(corner.substr(0, slash), v) || v == 0)
          throw InputError(path, "not a vertex index: " + shown(corner), at_line(lines.line()));
        std::int64_t vt = 0, vn = 0;  // 0: none
        for (int part = 1; slash != std::string_view::npos; ++part) {
          if (part > 2)  // a fourth part would be dropped when the face is written back
            throw InputError(path, "a face corner is v, v/vt, v//vn or v/vt/vn, found " + shown(corner),
                             at_line(lines.line()));
          const std::size_t next = corner.find('/', slash + 1);
          const std::string_view text =
              corner.substr(slash + 1, next == std::string_view::npos ? next : next - slash - 1);
          std::int64_t index = 0;
          if (!(text.empty() && next != std::string_view::npos && slash + 1 == next) && !text.empty() &&
              !parse_number(text, index))
            throw InputError(path, "not an index: " + shown(corner), at_line(lines.line()));
          if (part == 1 && !text.empty()) {
            if (index == 0)
              throw InputError(path, "not a texture coordinate index: " + shown(corner), at_line(lines.line()));
            vt = index;
          }
          if (part == 2 && !text.empty()) {
            if (index == 0) throw InputError(path, "not a normal index: " + shown(corner), at_line(lines.line()));
            vn = index;
          }
          slash = next;
        }
        if (v < 0) {  // relative to the vertices defined so far
          if (-v > defined)
            throw InputError(path, "vertex index " + std::to_string(v) + " refers before the first vertex",
                             at_line(lines.line()));
          v = defined + v + 1;
        }
        if (std::uint64_t(v) > std::numeric_limits<std::uint32_t>::max())
          throw InputError(path, "vertex index " + std::to_string(v) + " is out of range", at_line(lines.line()));
        if (std::uint64_t(v) > max_corner) max_corner = std::uint64_t(v), max_corner_line = lines.line();
        corners.push_back(std::uint32_t(v - 1));
        if (vn < 0) {  // relative to the normals defined so far
          const auto normals_defined = std::int64_t(normals.size() / 3);
          if (-vn > normals_defined)
            throw InputError(path, "normal index " + std::to_string(vn) + " refers before the first vn",
                             at_line(lines.line()));
          vn = normals_defined + vn + 1;
        }
        if (std::uint64_t(vn) >= ObjExtras::kNone)
          throw InputError(path, "normal index " + std::to_string(vn) + " is out of range", at_line(lines.line()));
        if (std::uint64_t(vn) > max_normal) max_normal = std::uint64_t(vn), max_normal_line = lines.line();
        if (vt < 0) {  // relative to the texture coordinates defined so far
          if (-vt > std::int64_t(x.texture_coordinates))
            throw InputError(path, "texture coordinate index " + std::to_string(vt) + " refers before the first vt",
                             at_line(lines.line()));
          vt = std::int64_t(x.texture_coordinates) + vt + 1;
        }
        if (std::uint64_t(vt) > max_texture) max_texture = std::uint64_t(vt), max_texture_line = lines.line();
        any_corner_normal = any_corner_normal || vn > 0;
        corner_normals.push_back(vn > 0 ? std::uint32_t(vn - 1) : ObjExtras::kNone);
      }
      face_start.push_back(std::uint32_t(corners.size()));
    } else if (key == "vn") {
      if (t.size() != 4)
        throw InputError(path, "a normal needs 3 numbers (vn x y z), found " + std::to_string(t.size() - 1),
                         at_line(lines.line()));
      for (std::size_t k = 1; k < 4; ++k) {
        const double c = coordinate<double>(t[k], path, at_line(lines.line()));
        if (!std::isfinite(c))
          throw InputError(path, "normal " + std::to_string(normals.size() / 3) + " has a non-finite component",
                           at_line(lines.line()));
        normals.push_back(c);
      }
      ++x.normal_lines;
    } else if (key == "vt") {
      ++x.texture_coordinates;
    } else if (key == "l" || key == "p") {
      ++mesh.dropped_primitives;
      ++x.other_lines;
    } else if (key == "vp" || key == "o" || key == "g" || key == "s" || key == "usemtl" || key == "mtllib") {
      ++x.other_lines;
    } else {
      throw InputError(path, "unsupported OBJ statement " + shown(key), at_line(lines.line()));
    }
  }
  const std::size_t n = coords.size() / 3;
  if (n == 0) throw InputError(path, "no vertices");
  if (n > std::numeric_limits<std::uint32_t>::max()) throw InputError(path, "too many vertices");
  // Indices may refer to vertices (and normals) defined later in the file: checked once all are known.
  if (max_corner > n)
    throw InputError(
        path, "vertex index " + std::to_string(max_corner) + " is out of range (" + std::to_string(n) + " vertices)",
        at_line(max_corner_line));
  if (max_normal > normals.size() / 3)
    throw InputError(path,
                     "normal index " + std::to_string(max_normal) + " is out of range (" +
                         std::to_string(normals.size() / 3) + " vn)",
                     at_line(max_normal_line));
  if (max_texture > x.texture_coordinates)
    throw InputError(path,
                     "texture coordinate index " + std::to_string(max_texture) + " is out of range (" +
                         std::to_string(x.texture_coordinates) + " vt)",
                     at_line(max_texture_line));
  mesh.vertices.resize(Eigen::Index(n), 3);
  std::copy(coords.begin(), coords.end(), mesh.vertices.data());
  std::deque<T>().swap(coords);
  mesh.face_indices = to_vector(corners);
  mesh.face_start = to_vector(face_start);
  x.vertex_tails.finish(n);
  x.normals = to_vector(normals);
  if (any_corner_normal) x.corner_normals = to_vector(corner_normals);
  mesh.extras.obj = std::move(x);
  return mesh;
}

template BasicMesh<float> read_obj<float>(Reader&, const std::string&);
template BasicMesh<double> read_obj<double>(Reader&, const std::string&);

}  // namespace mlsdeform::files::formats
