// The OFF reader: "OFF" (or "COFF"), the counts, the vertices (each optionally followed by a colour of 3 or 4
// numbers), then the faces (each its corner count, the corners, optionally a colour); colours are kept
// verbatim (OffExtras).
#include "core/files/formats/reader.hpp"

namespace mlsdeform::files::formats {

template <class T>
BasicMesh<T> read_off(Reader& reader, const std::string& path) {
  std::vector<std::string_view> t;
  Lines lines(reader);
  OffExtras x;
  auto content = [&] {  // the next line with tokens, counting comment lines (not kept)
    while (lines.next(t)) {
      if (lines.raw().find('#') != std::string_view::npos && lines.raw().find("# written by mlsdeform ") != 0)
        ++x.comments;
      if (!t.empty()) return true;
    }
    return false;
  };
  if (!content() || (t[0] != "OFF" && t[0] != "COFF"))
    throw InputError(path, "malformed OFF: the first line is not 'OFF'", at_line(lines.line()));
  x.keyword = std::string(t[0]);
  std::vector<std::string_view> counts(t.begin() + 1, t.end());  // "OFF nv nf ne" on one line is allowed
  if (counts.empty()) {
    if (!content()) throw InputError(path, "malformed OFF: no vertex and face counts");
    counts = t;
  }
  std::uint64_t nv = 0, nf = 0, ne = 0;
  if (counts.size() != 3 || !parse_number(counts[0], nv) || !parse_number(counts[1], nf) ||
      !parse_number(counts[2], ne))
    throw InputError(path, "malformed OFF: expected 'vertices faces edges' counts", at_line(lines.line()));
  // Each vertex line needs at least "0 0 0\n", each face line its corner count and a newline ("3 0 0 0\n" for a
  // valid one; a shorter face is read, and refused with its own message); the last line may lack its newline.
  check_count(nv, 6, reader.remaining(), "vertices", path, at_line(lines.line()), true);
  check_count(nf, 2, reader.remaining(), "faces", path, at_line(lines.line()), true);
  if (nv * 6 + nf * 2 > reader.remaining() + (nv + nf > 0 ? 1 : 0))
    throw InputError(path,
                     "the header promises " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
                         " faces, but only " + std::to_string(reader.remaining()) + " bytes follow",
                     at_line(lines.line()));
  BasicMesh<T> mesh;
  mesh.vertices.resize(Eigen::Index(nv), 3);
  for (std::uint64_t i = 0; i < nv; ++i) {
    if (!content())
      throw InputError(path, "malformed OFF: truncated in vertex " + std::to_string(i) + " of " + std::to_string(nv));
    T c[3];
    if (t.size() != 3 && t.size() != 6 && t.size() != 7)
      throw InputError(path,
                       "a vertex needs 3 coordinates (optionally then a colour of 3 or 4 numbers), found " +
                           std::to_string(t.size()),
                       at_line(lines.line()));
    for (int k = 0; k < 3; ++k) c[k] = coordinate<T>(t[std::size_t(k)], path, at_line(lines.line()));
    for (std::size_t k = 3; k < t.size(); ++k) coordinate<double>(t[k], path, at_line(lines.line()));
    x.vertex_tails.set(std::size_t(i), tail_after(lines.raw(), t[2]));
    if (!finite3(c)) throw InputError(path, non_finite(std::size_t(i)), at_line(lines.line()));
    mesh.vertices.row(Eigen::Index(i)) << c[0], c[1], c[2];
  }
  std::deque<std::uint32_t> corners;
  mesh.face_start.reserve(std::size_t(nf) + 1);
  for (std::uint64_t f = 0; f < nf; ++f) {
    if (!content())
      throw InputError(path, "malformed OFF: truncated in face " + std::to_string(f) + " of " + std::to_string(nf));
    std::uint64_t k = 0;
    if (!parse_number(t[0], k) || k < 3)
      throw InputError(path,
                       "face " + std::to_string(f) + ": expected a vertex count of at least 3, found " + shown(t[0]),
                       at_line(lines.line()));
    // k indices, then optionally a colour (3 or 4 numbers).
    const std::size_t extra = t.size() - 1 >= k ? t.size() - 1 - std::size_t(k) : std::size_t(-1);
    if (extra != 0 && extra != 3 && extra != 4)
      throw InputError(path,
                       "face " + std::to_string(f) + " promises " + std::to_string(k) + " vertices but has " +
                           std::to_string(t.size() - 1) + " numbers",
                       at_line(lines.line()));
    for (std::uint64_t j = 0; j < k; ++j) {
      std::int64_t v = 0;
      const std::string_view tok = t[std::size_t(j + 1)];
      if (!parse_number(tok, v))
        throw InputError(path, "face " + std::to_string(f) + ": not an index: " + shown(tok), at_line(lines.line()));
      if (v < 0 || std::uint64_t(v) >= nv)
        throw InputError(path, out_of_range(std::size_t(f), v, nv), at_line(lines.line()));
      corners.push_back(std::uint32_t(v));
    }
    for (std::size_t j = std::size_t(k) + 1; j < t.size(); ++j) coordinate<T>(t[j], path, at_line(lines.line()));
    x.face_tails.set(std::size_t(f), tail_after(lines.raw(), t[std::size_t(k)]));
    mesh.face_start.push_back(std::uint32_t(corners.size()));
  }
  if (content()) throw InputError(path, "malformed OFF: data after the last face", at_line(lines.line()));
  if (nv == 0) throw InputError(path, "no vertices");
  mesh.face_indices = to_vector(corners);
  x.vertex_tails.finish(std::size_t(nv));
  x.face_tails.finish(std::size_t(nf));
  mesh.extras.off = std::move(x);
  return mesh;
}

template BasicMesh<float> read_off<float>(Reader&, const std::string&);
template BasicMesh<double> read_off<double>(Reader&, const std::string&);

}  // namespace mlsdeform::files::formats
