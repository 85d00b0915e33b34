// The Wavefront OBJ writer. A mesh read from an OBJ file is written in its file's order (ObjExtras): `v` lines
// with the new positions and what followed them (colours), every other line verbatim; where the normals were
// transformed or computed, one block of `vn` stands in place of the file's and each face corner names its new
// normal. A mesh built in memory gets `v` lines, `vn` lines with the normals if any, and `f` lines (v//vn).
#include "core/files/formats/reader.hpp"
#include "core/files/formats/writer.hpp"

namespace mlsdeform::files::formats {
namespace {

std::string_view first_token(std::string_view line) {
  const std::size_t b = line.find_first_not_of(" \t\r\f\v");
  if (b == std::string_view::npos) return {};
  const std::size_t e = line.find_first_of(" \t\r\f\v#", b);
  return line.substr(b, e == std::string_view::npos ? std::string_view::npos : e - b);
}

/// An `f` line with each corner's normal index replaced by `corner_normals` (from corner `c` on).
void rewrite_face(TextOut& o, std::string_view line, const std::vector<std::uint32_t>& corner_normals, std::size_t& c) {
  const std::size_t hash = line.find('#');
  std::vector<std::string_view> t;
  split(line.substr(0, hash), t);
  o << 'f';
  for (std::size_t k = 1; k < t.size(); ++k, ++c) {
    const std::string_view corner = t[k];
    const std::size_t s1 = corner.find('/');
    const std::size_t s2 = s1 == std::string_view::npos ? s1 : corner.find('/', s1 + 1);
    const std::string_view v = corner.substr(0, s1);
    const std::string_view vt = s1 == std::string_view::npos
                                    ? std::string_view()
                                    : corner.substr(s1 + 1, s2 == std::string_view::npos ? s2 : s2 - s1 - 1);
    o << ' ' << v;
    const std::uint32_t n = c < corner_normals.size() ? corner_normals[c] : ObjExtras::kNone;
    if (n == ObjExtras::kNone) {
      if (!vt.empty()) o << '/' << vt;
      continue;
    }
    o << '/' << vt << '/';
    o.num(std::uint64_t(n) + 1);
  }
  if (hash != std::string_view::npos) o << ' ' << line.substr(hash);
  o << '\n';
}

template <class O, class T>
std::string encode_extras(const BasicMesh<T>& m, const PointsRowMajor<T>* computed) {
  const ObjExtras& x = *m.extras.obj;
  // Computed normals: one per vertex, each corner naming its vertex's.
  std::vector<double> computed_normals;
  std::vector<std::uint32_t> computed_corners;
  if (computed) {
    computed_normals.assign(computed->data(), computed->data() + computed->size());
    computed_corners = m.face_indices;
  }
  const bool rewrite = computed || x.normals_rewritten;
  const std::vector<double>& normals = computed ? computed_normals : x.normals;
  const std::vector<std::uint32_t>& corner_normals = computed ? computed_corners : x.corner_normals;
  // The file's own `vn` lines, for the normals that repeat one unchanged (ObjExtras::normal_sources).
  const std::vector<std::uint32_t>& sources = x.normal_sources;
  std::vector<std::string_view> vn_lines;
  if (!computed && !sources.empty())
    for (std::size_t at = 0; at < x.text.size();) {
      const std::size_t nl = x.text.find('\n', at);
      const std::string_view line = std::string_view(x.text).substr(at, nl - at);
      if (first_token(line) == "vn") vn_lines.push_back(line);
      at = nl + 1;
    }
  TextOut o;
  o.s.reserve(x.text.size() + std::size_t(m.vertex_count()) * 35 + x.vertex_tails.text.size() + 64);
  o << "# " << comment() << '\n';
  bool block_written = false;
  auto normal_block = [&] {
    if (!rewrite || block_written) return;
    block_written = true;
    for (std::size_t i = 0; i + 2 < normals.size(); i += 3) {
      if (!computed && i / 3 < sources.size() && sources[i / 3] < vn_lines.size()) {
        o << vn_lines[sources[i / 3]] << '\n';
        continue;
      }
      o << "vn ";
      o.num(O(normals[i]));
      o << ' ';
      o.num(O(normals[i + 1]));
      o << ' ';
      o.num(O(normals[i + 2]));
      o << '\n';
    }
  };
  Eigen::Index v = 0;
  std::size_t at = 0, corner = 0;
  for (const ObjExtras::Run& run : x.runs) {
    if (run.vertices) {
      for (std::uint64_t k = 0; k < run.count; ++k, ++v) {
        o << "v ";
        o.xyz<O>(m.vertices, v);
        o << x.vertex_tails[std::size_t(v)] << '\n';
      }
      if (x.normal_lines == 0) normal_block();  // no vn in the file: after its first vertices
      continue;
    }
    for (std::uint64_t k = 0; k < run.count; ++k) {
      const std::size_t nl = x.text.find('\n', at);
      const std::string_view line = std::string_view(x.text).substr(at, nl - at);
      at = nl + 1;
      if (rewrite) {
        const std::string_view key = first_token(line);
        if (key == "vn") {
          normal_block();
          continue;
        }
        if (key == "f") {
          rewrite_face(o, line, corner_normals, corner);
          continue;
        }
      }
      o << line << '\n';
    }
  }
  normal_block();
  return std::move(o.s);
}

}  // namespace

template <class O, class T>
std::string encode_obj(const BasicMesh<T>& m, const PointsRowMajor<T>* normals) {
  if (m.extras.obj) return encode_extras<O>(m, normals);
  TextOut o;
  o.s.reserve(std::size_t(m.vertex_count()) * (normals ? 70 : 35) + m.face_indices.size() * 16);
  o << "# " << comment() << '\n';
  for (Eigen::Index i = 0; i < m.vertex_count(); ++i) {
    o << "v ";
    o.xyz<O>(m.vertices, i);
    o << '\n';
  }
  if (normals)
    for (Eigen::Index i = 0; i < normals->rows(); ++i) {
      o << "vn ";
      o.xyz<O>(*normals, i);
      o << '\n';
    }
  for (std::size_t f = 0; f < m.face_count(); ++f) {
    o << 'f';
    for (auto c = m.face_start[f]; c < m.face_start[f + 1]; ++c) {
      const std::uint64_t k = std::uint64_t(m.face_indices[c]) + 1;  // OBJ counts from 1
      o << ' ';
      o.num(k);
      if (normals) {
        o << "//";
        o.num(k);
      }
    }
    o << '\n';
  }
  return std::move(o.s);
}

template std::string encode_obj<float, float>(const BasicMesh<float>&, const PointsRowMajor<float>*);
template std::string encode_obj<double, float>(const BasicMesh<float>&, const PointsRowMajor<float>*);
template std::string encode_obj<float, double>(const BasicMesh<double>&, const PointsRowMajor<double>*);
template std::string encode_obj<double, double>(const BasicMesh<double>&, const PointsRowMajor<double>*);

}  // namespace mlsdeform::files::formats
