// The PLY writer: binary little-endian or ASCII; x, y, z (and nx, ny, nz) as float or double, faces as a list
// of int with uchar counts (uint where a face has more than 255 corners).
#include "tools/cli/formats/writer.hpp"

namespace mlsdeform::cli::formats {

template <class O, class T>
std::string encode_ply(const BasicMesh<T>& m, const PointsRowMajor<T>* normals, PlyEncoding encoding) {
  std::size_t largest_face = 0;
  for (std::size_t f = 0; f < m.face_count(); ++f)
    largest_face = std::max<std::size_t>(largest_face, m.face_start[f + 1] - m.face_start[f]);
  const bool uchar_counts = largest_face <= 255;

  TextOut o;
  const bool binary = encoding == PlyEncoding::binary;
  o.s.reserve(256 + std::size_t(m.vertex_count()) * (binary ? 6 * sizeof(O) : 70) +
              m.face_indices.size() * (binary ? 5 : 8));
  const std::string_view type = std::is_same_v<O, float> ? "float" : "double";
  o << "ply\nformat " << (binary ? "binary_little_endian" : "ascii") << " 1.0\ncomment " << comment()
    << "\nelement vertex ";
  o.num(std::uint64_t(m.vertex_count()));
  o << '\n';
  for (const char* name : {"x", "y", "z", "nx", "ny", "nz"})
    if (name[0] != 'n' || normals) o << "property " << type << ' ' << name << '\n';
  o << "element face ";
  o.num(std::uint64_t(m.face_count()));
  o << "\nproperty list " << (uchar_counts ? "uchar" : "uint") << " int vertex_indices\nend_header\n";
  for (Eigen::Index i = 0; i < m.vertex_count(); ++i) {
    for (int k = 0; k < 3 + (normals ? 3 : 0); ++k) {
      const O v = O(k < 3 ? m.vertices(i, k) : (*normals)(i, k - 3));
      if (binary) {
        put_le(o.s, v);
      } else {
        if (k) o << ' ';
        o.num(v);
      }
    }
    if (!binary) o << '\n';
  }
  for (std::size_t f = 0; f < m.face_count(); ++f) {
    const auto n = m.face_start[f + 1] - m.face_start[f];
    if (binary) {
      if (uchar_counts)
        put_le(o.s, std::uint8_t(n));
      else
        put_le(o.s, std::uint32_t(n));
      for (auto c = m.face_start[f]; c < m.face_start[f + 1]; ++c) put_le(o.s, std::int32_t(m.face_indices[c]));
    } else {
      o.num(std::uint64_t(n));
      for (auto c = m.face_start[f]; c < m.face_start[f + 1]; ++c) {
        o << ' ';
        o.num(std::uint64_t(m.face_indices[c]));
      }
      o << '\n';
    }
  }
  return std::move(o.s);
}

template std::string encode_ply<float, float>(const BasicMesh<float>&, const PointsRowMajor<float>*, PlyEncoding);
template std::string encode_ply<double, float>(const BasicMesh<float>&, const PointsRowMajor<float>*, PlyEncoding);
template std::string encode_ply<float, double>(const BasicMesh<double>&, const PointsRowMajor<double>*, PlyEncoding);
template std::string encode_ply<double, double>(const BasicMesh<double>&, const PointsRowMajor<double>*, PlyEncoding);

}  // namespace mlsdeform::cli::formats
