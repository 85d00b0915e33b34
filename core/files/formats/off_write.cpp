// The OFF writer: "OFF", the counts, the vertices, then the faces (each its corner count, then the corners);
// a mesh read from an OFF file keeps its keyword and its vertex and face colours (OffExtras).
#include "core/files/formats/writer.hpp"

namespace mlsdeform::files::formats {

template <class O, class T>
std::string encode_off(const BasicMesh<T>& m) {
  TextOut o;
  o.s.reserve(std::size_t(m.vertex_count()) * 35 + m.face_indices.size() * 8);
  const OffExtras* x = m.extras.off ? &*m.extras.off : nullptr;
  o << (x ? std::string_view(x->keyword) : "OFF") << "\n# " << comment() << '\n';
  o.num(std::uint64_t(m.vertex_count()));
  o << ' ';
  o.num(std::uint64_t(m.face_count()));
  o << " 0\n";
  for (Eigen::Index i = 0; i < m.vertex_count(); ++i) {
    o.xyz<O>(m.vertices, i);
    if (x) o << x->vertex_tails[std::size_t(i)];
    o << '\n';
  }
  for (std::size_t f = 0; f < m.face_count(); ++f) {
    o.num(std::uint64_t(m.face_start[f + 1] - m.face_start[f]));
    for (auto c = m.face_start[f]; c < m.face_start[f + 1]; ++c) {
      o << ' ';
      o.num(std::uint64_t(m.face_indices[c]));
    }
    if (x) o << x->face_tails[f];
    o << '\n';
  }
  return std::move(o.s);
}

template std::string encode_off<float, float>(const BasicMesh<float>&);
template std::string encode_off<double, float>(const BasicMesh<float>&);
template std::string encode_off<float, double>(const BasicMesh<double>&);
template std::string encode_off<double, double>(const BasicMesh<double>&);

}  // namespace mlsdeform::files::formats
