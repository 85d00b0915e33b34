// The Wavefront OBJ writer: `v` lines, `vn` lines with the normals, `f` lines (v//vn with normals).
#include "tools/cli/formats/writer.hpp"

namespace mlsdeform::cli::formats {

template <class O, class T>
std::string encode_obj(const BasicMesh<T>& m, const PointsRowMajor<T>* normals) {
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

}  // namespace mlsdeform::cli::formats
