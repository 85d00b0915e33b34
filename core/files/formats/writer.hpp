// mlsdeform files: what the three mesh writers (obj_write.cpp, off_write.cpp, ply_write.cpp) share: text built
// with numbers as the shortest decimal that reads back exactly, little-endian binary values, and the comment
// naming the writer. mesh_write.cpp picks the writer by the file's extension.
#pragma once

#include "core/files/formats/numbers.hpp"
#include "core/files/mesh.hpp"

#include <mlsdeform/version.hpp>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

namespace mlsdeform::files::formats {

struct TextOut {
  std::string s;
  // The shortest decimal text that reads back to v (correctly rounded, as the readers parse): at most 17
  // significant digits for a double, 9 for a float.
  void num(float v) { real(v); }
  void num(double v) { real(v); }
  template <class R>
  void real(R v) {
    char buf[64];
    s.append(buf, real_to_chars(buf, buf + sizeof buf, v));
  }
  void num(std::uint64_t v) {
    char buf[24];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    s.append(buf, r.ptr);
  }
  /// Row i of the n x 3 `p` as O: "x y z".
  template <class O, class P>
  void xyz(const P& p, Eigen::Index i) {
    num(O(p(i, 0)));
    s.push_back(' ');
    num(O(p(i, 1)));
    s.push_back(' ');
    num(O(p(i, 2)));
  }
  TextOut& operator<<(std::string_view t) {
    s.append(t);
    return *this;
  }
  TextOut& operator<<(char c) {
    s.push_back(c);
    return *this;
  }
};

template <class T>
void put_le(std::string& s, T v) {
  static_assert(std::endian::native == std::endian::little || std::endian::native == std::endian::big);
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(b, b + sizeof(T));
  s.append(b, sizeof(T));
}

inline std::string comment() {
  return "written by mlsdeform " + std::to_string(MLSDEFORM_VERSION_MAJOR) + "." +
         std::to_string(MLSDEFORM_VERSION_MINOR) + "." + std::to_string(MLSDEFORM_VERSION_PATCH);
}

// The writers, one file each. O: the type written (WriteOptions::coordinates); T's values are converted to it
// (exactly, or rounded once). `normals`: none, or one per vertex (not for OFF, which has no place for them).
template <class O, class T>
std::string encode_obj(const BasicMesh<T>& m, const PointsRowMajor<T>* normals);
template <class O, class T>
std::string encode_off(const BasicMesh<T>& m);
template <class O, class T>
std::string encode_ply(const BasicMesh<T>& m, const PointsRowMajor<T>* normals, PlyEncoding encoding);
/// numpy's .npy: the positions alone (npy_write.cpp).
template <class O, class T>
std::string encode_npy(const BasicMesh<T>& m);

}  // namespace mlsdeform::files::formats
