// Mesh writing (OBJ, OFF, PLY) and the geometry helpers writers and renderers need, keeping the vertex order
// and writing numbers that read back exactly.
#include "tools/cli/error.hpp"
#include "tools/cli/file_io.hpp"
#include "tools/cli/mesh.hpp"

#include <mlsdeform/version.hpp>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>

namespace mlsdeform::cli {
namespace {

struct TextOut {
  std::string s;
  // The shortest decimal text that reads back to v (correctly rounded, as the readers parse): at most 17
  // significant digits for a double, 9 for a float.
  void num(float v) { real(v); }
  void num(double v) { real(v); }
  template <class R>
  void real(R v) {
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    s.append(buf, r.ptr);
  }
  void num(std::uint64_t v) {
    char buf[24];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    s.append(buf, r.ptr);
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

std::string comment() {
  return "written by mlsdeform " + std::to_string(MLSDEFORM_VERSION_MAJOR) + "." +
         std::to_string(MLSDEFORM_VERSION_MINOR) + "." + std::to_string(MLSDEFORM_VERSION_PATCH);
}

// O: the type written (WriteOptions::coordinates); T's values are converted to it (exactly, or rounded once).
template <class O, class T>
std::string encode_obj(const BasicMesh<T>& m, const PointsRowMajor<T>* normals) {
  TextOut o;
  o.s.reserve(std::size_t(m.vertex_count()) * (normals ? 70 : 35) + m.face_indices.size() * 16);
  o << "# " << comment() << '\n';
  for (Eigen::Index i = 0; i < m.vertex_count(); ++i) {
    o << "v ";
    o.num(O(m.vertices(i, 0)));
    o << ' ';
    o.num(O(m.vertices(i, 1)));
    o << ' ';
    o.num(O(m.vertices(i, 2)));
    o << '\n';
  }
  if (normals)
    for (Eigen::Index i = 0; i < normals->rows(); ++i) {
      o << "vn ";
      o.num(O((*normals)(i, 0)));
      o << ' ';
      o.num(O((*normals)(i, 1)));
      o << ' ';
      o.num(O((*normals)(i, 2)));
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

template <class O, class T>
std::string encode_off(const BasicMesh<T>& m) {
  TextOut o;
  o.s.reserve(std::size_t(m.vertex_count()) * 35 + m.face_indices.size() * 8);
  o << "OFF\n# " << comment() << '\n';
  o.num(std::uint64_t(m.vertex_count()));
  o << ' ';
  o.num(std::uint64_t(m.face_count()));
  o << " 0\n";
  for (Eigen::Index i = 0; i < m.vertex_count(); ++i) {
    o.num(O(m.vertices(i, 0)));
    o << ' ';
    o.num(O(m.vertices(i, 1)));
    o << ' ';
    o.num(O(m.vertices(i, 2)));
    o << '\n';
  }
  for (std::size_t f = 0; f < m.face_count(); ++f) {
    o.num(std::uint64_t(m.face_start[f + 1] - m.face_start[f]));
    for (auto c = m.face_start[f]; c < m.face_start[f + 1]; ++c) {
      o << ' ';
      o.num(std::uint64_t(m.face_indices[c]));
    }
    o << '\n';
  }
  return std::move(o.s);
}

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

}  // namespace

template <class T>
PointsRowMajor<T> vertex_normals(const BasicMesh<T>& mesh) {
  // Newell's products are of squared coordinates: in double for float input (no overflow or underflow from
  // float's range), in long double for double input (on x86, 15 exponent bits hold the square of any double).
  using Acc = std::conditional_t<std::is_same_v<T, float>, double, long double>;
  using Vec = Eigen::Matrix<Acc, 3, 1>;
  Eigen::Matrix<Acc, Eigen::Dynamic, 3, Eigen::RowMajor> acc = decltype(acc)::Zero(mesh.vertex_count(), 3);
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    // Newell's method: the polygon's normal scaled by twice its area.
    Vec n = Vec::Zero();
    const auto b = mesh.face_start[f], e = mesh.face_start[f + 1];
    for (auto c = b; c < e; ++c) {
      const Vec p = mesh.vertices.row(mesh.face_indices[c]).template cast<Acc>();
      const Vec q = mesh.vertices.row(mesh.face_indices[c + 1 < e ? c + 1 : b]).template cast<Acc>();
      n += Vec((p.y() - q.y()) * (p.z() + q.z()), (p.z() - q.z()) * (p.x() + q.x()), (p.x() - q.x()) * (p.y() + q.y()));
    }
    for (auto c = b; c < e; ++c) acc.row(mesh.face_indices[c]) += n.transpose();
  }
  PointsRowMajor<T> out(mesh.vertex_count(), 3);
  for (Eigen::Index i = 0; i < acc.rows(); ++i) {
    const Acc len = acc.row(i).norm();
    if (len > 0 && std::isfinite(len))
      out.row(i) = (acc.row(i) / len).template cast<T>();
    else
      out.row(i).setZero();
  }
  return out;
}

template <class T>
std::vector<std::uint32_t> triangulate(const BasicMesh<T>& mesh) {
  std::vector<std::uint32_t> t;
  t.reserve(mesh.face_indices.size() * 3);
  for (std::size_t f = 0; f < mesh.face_count(); ++f)
    for (auto c = mesh.face_start[f] + 1; c + 1 < mesh.face_start[f + 1]; ++c)
      t.insert(t.end(), {mesh.face_indices[mesh.face_start[f]], mesh.face_indices[c], mesh.face_indices[c + 1]});
  return t;
}

template <class T>
Triangles fan_triangles(const BasicMesh<T>& mesh, const std::string& path) {
  if (mesh.vertex_count() > std::numeric_limits<int>::max())
    throw InputError(path, "too many vertices for --arap (" + std::to_string(mesh.vertex_count()) +
                               "; its triangles index vertices by int)");
  const std::vector<std::uint32_t> t = triangulate(mesh);
  Triangles tris(Eigen::Index(t.size() / 3), 3);
  for (std::size_t i = 0; i < t.size(); ++i) tris(Eigen::Index(i / 3), Eigen::Index(i % 3)) = int(t[i]);
  return tris;
}

std::string writable_formats() {
  return "obj, off, ply (binary; ASCII with --ply-ascii), and each gzip-compressed (.obj.gz, .off.gz, .ply.gz)";
}

void check_output_format(const std::string& path) {
  const std::string ext = format_extension(path);
  if (ext != "obj" && ext != "off" && ext != "ply")
    throw InputError(path, "unknown output format" + (ext.empty() ? std::string() : " '." + ext + "'") +
                               " (writable: " + writable_formats() + ")");
}

template <class T>
CoordinateType output_type(const BasicMesh<T>& mesh, const WriteOptions& options) {
  if (options.coordinates) return *options.coordinates;
  if constexpr (std::is_same_v<T, float>)
    return CoordinateType::float32;
  else
    return mesh.stored_type.value_or(CoordinateType::float64);
}

template <class T>
std::string encode_mesh(const BasicMesh<T>& mesh, const std::string& path, const WriteOptions& options) {
  check_output_format(path);
  const std::string ext = format_extension(path);
  PointsRowMajor<T> normals;
  if (options.normals && ext != "off") normals = vertex_normals(mesh);
  const PointsRowMajor<T>* n = options.normals && ext != "off" ? &normals : nullptr;
  auto encode = [&](auto as) {
    using O = decltype(as);
    return ext == "obj"   ? encode_obj<O>(mesh, n)
           : ext == "off" ? encode_off<O>(mesh)
                          : encode_ply<O>(mesh, n, options.ply);
  };
  std::string bytes = output_type(mesh, options) == CoordinateType::float32 ? encode(float()) : encode(double());
  return is_gzip_path(path) ? gzip(bytes) : bytes;
}

template <class T>
void write_mesh(const BasicMesh<T>& mesh, const std::string& path, const WriteOptions& options) {
  write_file_atomic(path, encode_mesh(mesh, path, options), options.force);
}

#define MLSDEFORM_CLI_MESH_WRITE(T)                                                               \
  template PointsRowMajor<T> vertex_normals(const BasicMesh<T>&);                                 \
  template std::vector<std::uint32_t> triangulate(const BasicMesh<T>&);                           \
  template Triangles fan_triangles(const BasicMesh<T>&, const std::string&);                      \
  template CoordinateType output_type(const BasicMesh<T>&, const WriteOptions&);                  \
  template std::string encode_mesh(const BasicMesh<T>&, const std::string&, const WriteOptions&); \
  template void write_mesh(const BasicMesh<T>&, const std::string&, const WriteOptions&);
MLSDEFORM_CLI_MESH_WRITE(float)
MLSDEFORM_CLI_MESH_WRITE(double)
#undef MLSDEFORM_CLI_MESH_WRITE

}  // namespace mlsdeform::cli
