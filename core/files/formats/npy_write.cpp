// The NPY writer (numpy's .npy, format version 1.0: numpy.lib.format): the positions alone, an (n, 3) array of
// little-endian float32 or float64 in C order, for training data and numpy.load; everything else a mesh file
// carries (faces, attributes) is named as dropped by attribute_report.
#include "core/files/formats/writer.hpp"

#include <bit>
#include <cstring>

namespace mlsdeform::files::formats {

template <class O, class T>
std::string encode_npy(const BasicMesh<T>& m) {
  static_assert(std::endian::native == std::endian::little, "encode_npy writes the machine's bytes as '<'");
  // The header: the magic string, version 1.0, its length (uint16 little-endian), then a Python dict literal
  // padded with spaces and ended by '\n' so that the data starts at a multiple of 64 bytes, as numpy writes it.
  std::string dict = std::string("{'descr': '<f") + (sizeof(O) == 4 ? "4" : "8") +
                     "', 'fortran_order': False, 'shape': (" + std::to_string(m.vertex_count()) + ", 3), }";
  const std::size_t total = (10 + dict.size() + 1 + 63) / 64 * 64;
  dict.append(total - 10 - dict.size() - 1, ' ');
  dict += '\n';
  std::string s = "\x93NUMPY\x01";
  s += '\0';
  s += char(dict.size() & 0xff);
  s += char(dict.size() >> 8);
  s += dict;
  const std::size_t at = s.size();
  s.resize(at + std::size_t(m.vertex_count()) * 3 * sizeof(O));
  for (Eigen::Index i = 0; i < m.vertex_count(); ++i)
    for (int c = 0; c < 3; ++c) {
      const O v = O(m.vertices(i, c));
      std::memcpy(s.data() + at + (std::size_t(i) * 3 + std::size_t(c)) * sizeof(O), &v, sizeof v);
    }
  return s;
}

template std::string encode_npy<float, float>(const BasicMesh<float>&);
template std::string encode_npy<double, float>(const BasicMesh<float>&);
template std::string encode_npy<float, double>(const BasicMesh<double>&);
template std::string encode_npy<double, double>(const BasicMesh<double>&);

}  // namespace mlsdeform::files::formats
