// Mesh writing (OBJ, OFF, PLY: one writer per format in core/files/formats/, chosen here by the file's
// extension) and the geometry helpers writers and renderers need, keeping the vertex order and writing numbers
// that read back exactly.
#include <mlsdeform/files_error.hpp>
#include "core/files/file_io.hpp"
#include "core/files/formats/writer.hpp"
#include "core/files/mesh.hpp"
#include "core/files/splat_io.hpp"

#include <cmath>
#include <limits>

namespace mlsdeform::files {

using formats::encode_npy;
using formats::encode_obj;
using formats::encode_off;
using formats::encode_ply;

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
  return "obj, off, ply (binary; ASCII with --ply-ascii), and each gzip-compressed (.obj.gz, .off.gz, .ply.gz); "
         "npy (numpy: the positions alone); Gaussian splats also as spz and compressed.ply";
}

void check_output_format(const std::string& path) {
  const files::SplatFormat splats = files::splat_format(path);  // splat_io.hpp
  if (splats == files::SplatFormat::spz || splats == files::SplatFormat::compressed_ply) return;
  const std::string ext = splats == files::SplatFormat::splat ? "splat (read only)" : format_extension(path);
  if (ext != "obj" && ext != "off" && ext != "ply" && ext != "npy")
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
  if (const auto splats = files::splat_format(path); splats != files::SplatFormat::none)
    return files::encode_splat_file(mesh, path, splats);
  const std::string ext = format_extension(path);
  // Computed normals only on request; the input's own (mesh.extras) are written by their format's writer.
  const bool computed = options.normals == NormalsOut::computed && ext != "off" && ext != "npy";
  PointsRowMajor<T> normals;
  if (computed) normals = vertex_normals(mesh);
  const PointsRowMajor<T>* n = computed ? &normals : nullptr;
  auto encode = [&](auto as) {
    using O = decltype(as);
    return ext == "obj"   ? encode_obj<O>(mesh, n)
           : ext == "off" ? encode_off<O>(mesh)
           : ext == "npy" ? encode_npy<O>(mesh)
                          : encode_ply<O>(mesh, n, options.ply);
  };
  std::string bytes = output_type(mesh, options) == CoordinateType::float32 ? encode(float()) : encode(double());
  return is_gzip_path(path) ? gzip(bytes) : bytes;
}

template <class T>
void write_mesh(const BasicMesh<T>& mesh, const std::string& path, const WriteOptions& options) {
  write_file_atomic(path, encode_mesh(mesh, path, options), options.force);
}

#define MLSDEFORM_FILES_MESH_WRITE(T)                                                             \
  template PointsRowMajor<T> vertex_normals(const BasicMesh<T>&);                                 \
  template std::vector<std::uint32_t> triangulate(const BasicMesh<T>&);                           \
  template Triangles fan_triangles(const BasicMesh<T>&, const std::string&);                      \
  template CoordinateType output_type(const BasicMesh<T>&, const WriteOptions&);                  \
  template std::string encode_mesh(const BasicMesh<T>&, const std::string&, const WriteOptions&); \
  template void write_mesh(const BasicMesh<T>&, const std::string&, const WriteOptions&);
MLSDEFORM_FILES_MESH_WRITE(float)
MLSDEFORM_FILES_MESH_WRITE(double)
#undef MLSDEFORM_FILES_MESH_WRITE

}  // namespace mlsdeform::files
