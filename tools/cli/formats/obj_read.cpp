// The Wavefront OBJ reader: `v` lines and `f` lines (v, v/vt, v//vn or v/vt/vn corners, negative indices
// counted back from the last `v`); points and lines are counted and dropped; texture coordinates, normals,
// names, groups and materials are skipped; any other statement is refused.
#include "tools/cli/formats/reader.hpp"

namespace mlsdeform::cli::formats {

template <class T>
BasicMesh<T> read_obj(Reader& reader, const std::string& path) {
  BasicMesh<T> mesh;
  std::deque<T> coords;
  std::deque<std::uint32_t> corners, face_start{0};  // corners 0-based; relative (negative) ones resolved
  std::uint64_t max_corner = 0;                      // the largest 1-based index, checked at the end
  std::size_t max_corner_line = 0;
  std::vector<std::string_view> t;
  Lines lines(reader);
  while (lines.next(t)) {
    if (t.empty()) continue;
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
      coords.insert(coords.end(), c, c + 3);
    } else if (key == "f") {
      if (t.size() < 4)
        throw InputError(path, "a face needs at least 3 vertices, found " + std::to_string(t.size() - 1),
                         at_line(lines.line()));
      const auto defined = std::int64_t(coords.size() / 3);
      for (std::size_t k = 1; k < t.size(); ++k) {
        // v, v/vt, v//vn or v/vt/vn: every part an integer (texture and normal indices are not used).
        const std::string_view corner = t[k];
        std::size_t slash = corner.find('/');
        std::int64_t v = 0;
        if (!parse_number(corner.substr(0, slash), v) || v == 0)
          throw InputError(path, "not a vertex index: " + shown(corner), at_line(lines.line()));
        while (slash != std::string_view::npos) {
          const std::size_t next = corner.find('/', slash + 1);
          const std::string_view part =
              corner.substr(slash + 1, next == std::string_view::npos ? next : next - slash - 1);
          std::int64_t unused = 0;
          if (!(part.empty() && next != std::string_view::npos && slash + 1 == next) && !part.empty() &&
              !parse_number(part, unused))
            throw InputError(path, "not an index: " + shown(corner), at_line(lines.line()));
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
      }
      face_start.push_back(std::uint32_t(corners.size()));
    } else if (key == "l" || key == "p") {
      ++mesh.dropped_primitives;
    } else if (key == "vt" || key == "vn" || key == "vp" || key == "o" || key == "g" || key == "s" || key == "usemtl" ||
               key == "mtllib") {
      // Texture coordinates, normals, names, groups, smoothing and materials: not used.
    } else {
      throw InputError(path, "unsupported OBJ statement " + shown(key), at_line(lines.line()));
    }
  }
  const std::size_t n = coords.size() / 3;
  if (n == 0) throw InputError(path, "no vertices");
  if (n > std::numeric_limits<std::uint32_t>::max()) throw InputError(path, "too many vertices");
  // Indices may refer to vertices defined later in the file: checked once all are known.
  if (max_corner > n)
    throw InputError(
        path, "vertex index " + std::to_string(max_corner) + " is out of range (" + std::to_string(n) + " vertices)",
        at_line(max_corner_line));
  mesh.vertices.resize(Eigen::Index(n), 3);
  std::copy(coords.begin(), coords.end(), mesh.vertices.data());
  std::deque<T>().swap(coords);
  mesh.face_indices = to_vector(corners);
  mesh.face_start = to_vector(face_start);
  return mesh;
}

template BasicMesh<float> read_obj<float>(Reader&, const std::string&);
template BasicMesh<double> read_obj<double>(Reader&, const std::string&);

}  // namespace mlsdeform::cli::formats
