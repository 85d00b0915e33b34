// Mesh writing (OBJ, OFF, PLY) and the geometry helpers writers and renderers need, keeping the vertex order
// and writing numbers that read back exactly.
#include "error.hpp"
#include "file_io.hpp"
#include "mesh.hpp"

#include <mlsdeform/version.hpp>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>

namespace mlsdeform::cli {
namespace {

// The shortest decimal text that reads back to v (correctly rounded, as the readers parse).
std::string_view float_text(float v, char (&buf)[64]) {
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return {buf, std::size_t(r.ptr - buf)};
}

struct TextOut {
  std::string s;
  void num(float v) {
    char buf[64];
    s.append(float_text(v, buf));
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

std::string encode_obj(const Mesh& m, const PointsRowMajor<float>* normals) {
  TextOut o;
  o.s.reserve(std::size_t(m.vertex_count()) * (normals ? 70 : 35) + m.face_indices.size() * 16);
  o << "# " << comment() << '\n';
  for (Eigen::Index i = 0; i < m.vertex_count(); ++i) {
    o << "v ";
    o.num(m.vertices(i, 0));
    o << ' ';
    o.num(m.vertices(i, 1));
    o << ' ';
    o.num(m.vertices(i, 2));
    o << '\n';
  }
  if (normals)
    for (Eigen::Index i = 0; i < normals->rows(); ++i) {
      o << "vn ";
      o.num((*normals)(i, 0));
      o << ' ';
      o.num((*normals)(i, 1));
      o << ' ';
      o.num((*normals)(i, 2));
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

std::string encode_off(const Mesh& m) {
  TextOut o;
  o.s.reserve(std::size_t(m.vertex_count()) * 35 + m.face_indices.size() * 8);
  o << "OFF\n# " << comment() << '\n';
  o.num(std::uint64_t(m.vertex_count()));
  o << ' ';
  o.num(std::uint64_t(m.face_count()));
  o << " 0\n";
  for (Eigen::Index i = 0; i < m.vertex_count(); ++i) {
    o.num(m.vertices(i, 0));
    o << ' ';
    o.num(m.vertices(i, 1));
    o << ' ';
    o.num(m.vertices(i, 2));
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

std::string encode_ply(const Mesh& m, const PointsRowMajor<float>* normals, PlyEncoding encoding) {
  std::size_t largest_face = 0;
  for (std::size_t f = 0; f < m.face_count(); ++f)
    largest_face = std::max<std::size_t>(largest_face, m.face_start[f + 1] - m.face_start[f]);
  const bool uchar_counts = largest_face <= 255;

  TextOut o;
  const bool binary = encoding == PlyEncoding::binary;
  o.s.reserve(256 + std::size_t(m.vertex_count()) * (binary ? 24 : 70) + m.face_indices.size() * (binary ? 5 : 8));
  o << "ply\nformat " << (binary ? "binary_little_endian" : "ascii") << " 1.0\ncomment " << comment()
    << "\nelement vertex ";
  o.num(std::uint64_t(m.vertex_count()));
  o << "\nproperty float x\nproperty float y\nproperty float z\n";
  if (normals) o << "property float nx\nproperty float ny\nproperty float nz\n";
  o << "element face ";
  o.num(std::uint64_t(m.face_count()));
  o << "\nproperty list " << (uchar_counts ? "uchar" : "uint") << " int vertex_indices\nend_header\n";
  for (Eigen::Index i = 0; i < m.vertex_count(); ++i) {
    for (int k = 0; k < 3 + (normals ? 3 : 0); ++k) {
      const float v = k < 3 ? m.vertices(i, k) : (*normals)(i, k - 3);
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

PointsRowMajor<float> vertex_normals(const Mesh& mesh) {
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> acc = decltype(acc)::Zero(mesh.vertex_count(), 3);
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    // Newell's method: the polygon's normal scaled by twice its area.
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    const auto b = mesh.face_start[f], e = mesh.face_start[f + 1];
    for (auto c = b; c < e; ++c) {
      const Eigen::Vector3d p = mesh.vertices.row(mesh.face_indices[c]).cast<double>();
      const Eigen::Vector3d q = mesh.vertices.row(mesh.face_indices[c + 1 < e ? c + 1 : b]).cast<double>();
      n += Eigen::Vector3d((p.y() - q.y()) * (p.z() + q.z()), (p.z() - q.z()) * (p.x() + q.x()),
                           (p.x() - q.x()) * (p.y() + q.y()));
    }
    for (auto c = b; c < e; ++c) acc.row(mesh.face_indices[c]) += n.transpose();
  }
  PointsRowMajor<float> out(mesh.vertex_count(), 3);
  for (Eigen::Index i = 0; i < acc.rows(); ++i) {
    const double len = acc.row(i).norm();
    if (len > 0 && std::isfinite(len))
      out.row(i) = (acc.row(i) / len).cast<float>();
    else
      out.row(i).setZero();
  }
  return out;
}

std::vector<std::uint32_t> triangulate(const Mesh& mesh) {
  std::vector<std::uint32_t> t;
  t.reserve(mesh.face_indices.size() * 3);
  for (std::size_t f = 0; f < mesh.face_count(); ++f)
    for (auto c = mesh.face_start[f] + 1; c + 1 < mesh.face_start[f + 1]; ++c)
      t.insert(t.end(), {mesh.face_indices[mesh.face_start[f]], mesh.face_indices[c], mesh.face_indices[c + 1]});
  return t;
}

Triangles fan_triangles(const Mesh& mesh, const std::string& path) {
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

std::string encode_mesh(const Mesh& mesh, const std::string& path, const WriteOptions& options) {
  check_output_format(path);
  const std::string ext = format_extension(path);
  PointsRowMajor<float> normals;
  if (options.normals && ext != "off") normals = vertex_normals(mesh);
  const PointsRowMajor<float>* n = options.normals && ext != "off" ? &normals : nullptr;
  std::string bytes = ext == "obj"   ? encode_obj(mesh, n)
                      : ext == "off" ? encode_off(mesh)
                                     : encode_ply(mesh, n, options.ply);
  return is_gzip_path(path) ? gzip(bytes) : bytes;
}

void write_mesh(const Mesh& mesh, const std::string& path, const WriteOptions& options) {
  write_file_atomic(path, encode_mesh(mesh, path, options), options.force);
}

}  // namespace mlsdeform::cli
