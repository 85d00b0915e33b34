// mlsdeform files: compact splat files to and from the mesh pipeline's 3DGS PLY layout (splat_io.hpp).
#include "core/files/splat_io.hpp"

#include "core/files/formats/splat_support.hpp"

#include <algorithm>
#include <cstring>

namespace mlsdeform::files {

namespace {

// SPZ's antialiasing flag, carried through the PLY layout as a comment so that an SPZ output keeps it.
const char* const kAntialiased = "comment SPZ antialiased (trained with mip-splatting's 3D filter)";

std::vector<std::string> property_names(int degree) {
  std::vector<std::string> names = {"x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2"};
  const int rest = 3 * ((degree + 1) * (degree + 1) - 1);
  for (int k = 0; k < rest; ++k) names.push_back("f_rest_" + std::to_string(k));
  for (const char* s : {"opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"})
    names.push_back(s);
  return names;
}

}  // namespace

template <class T>
BasicMesh<T> splat_mesh(const SplatCloud& c) {
  BasicMesh<T> mesh;
  const std::size_t n = c.count, k = 3 * c.sh_per_channel();
  mesh.vertices.resize(Eigen::Index(n), 3);
  PlyLayout ply;
  ply.format = "binary_little_endian";
  if (c.antialiased) ply.header.push_back({0, kAntialiased});
  PlyElement v;
  v.name = "vertex";
  v.count = n;
  for (const std::string& name : property_names(c.sh_degree)) v.properties.push_back(PlyProperty{name});
  const std::size_t w = v.properties.size();
  v.data.resize(n * w * 4);
  std::vector<float> row(w);
  for (std::size_t i = 0; i < n; ++i) {
    float* r = row.data();
    for (std::size_t j = 0; j < 3; ++j) {
      mesh.vertices(Eigen::Index(i), Eigen::Index(j)) = T(c.position[i * 3 + j]);
      r[j] = c.position[i * 3 + j], r[3 + j] = c.f_dc[i * 3 + j];
    }
    if (k) std::memcpy(r + 6, c.f_rest.data() + i * k, k * 4);
    r[6 + k] = c.opacity[i];
    std::memcpy(r + 7 + k, &c.scale[i * 3], 12);
    std::memcpy(r + 10 + k, &c.rot[i * 4], 16);
    std::memcpy(&v.data[i * w * 4], r, w * 4);
  }
  ply.elements.push_back(std::move(v));
  ply.vertex_element = 0;
  mesh.extras.ply = std::move(ply);
  mesh.stored_type = CoordinateType::float32;
  return mesh;
}

namespace {

/// The checks of a mesh's fitness for a compact splat format that need no values (splat_cloud's first part):
/// the vertex element's 3DGS properties (every one but x, y, z, in property_names' order) and the SH degree.
template <class T>
std::vector<std::size_t> splat_properties(const BasicMesh<T>& mesh, const std::string& path, int& degree) {
  const PlyLayout* ply = mesh.extras.ply ? &*mesh.extras.ply : nullptr;
  const std::string format = splat_format_name(splat_format(path));
  if (!ply || ply->vertex_element < 0 || ply->vertices().find("rot_0") < 0)
    throw InputError(path, format +
                               " holds Gaussian splats; the input has none (no PLY vertex property rot_0: "
                               "not a 3DGS splat file)");
  if (mesh.face_count() > 0)
    throw InputError(path, format + " holds no faces; the input has " + std::to_string(mesh.face_count()));
  const PlyElement& v = ply->vertices();
  // The 3DGS properties by name, each float or double (the deformation's splat_layout checks the same).
  auto property = [&](const std::string& name) {
    const int p = v.find(name);
    if (p < 0 || v.properties[std::size_t(p)].list || is_integer(v.properties[std::size_t(p)].type))
      throw InputError(path, format + " needs the splat property " + name + " (float or double); the input's " +
                                 (p < 0 ? "has none" : "is not"));
    return std::size_t(p);
  };
  std::size_t rest = 0;
  while (v.find("f_rest_" + std::to_string(rest)) >= 0) ++rest;
  degree = sh_degree_of(rest);
  if (degree < 0)
    throw InputError(path, format + " holds SH degrees 0-3 (9, 24 or 45 f_rest_*); the input has " +
                               std::to_string(rest) + " f_rest_* properties");
  std::vector<std::size_t> props;
  for (const std::string& name : property_names(degree))
    if (name != "x" && name != "y" && name != "z") props.push_back(property(name));
  return props;
}

}  // namespace

template <class T>
void check_splat_output(const BasicMesh<T>& mesh, const std::string& path) {
  int degree = 0;
  splat_properties(mesh, path, degree);
}

template <class T>
SplatCloud splat_cloud(const BasicMesh<T>& mesh, const std::string& path) {
  int degree = 0;
  const std::vector<std::size_t> props = splat_properties(mesh, path, degree);
  const PlyLayout* ply = &*mesh.extras.ply;
  const PlyElement& v = ply->vertices();
  SplatCloud c;
  const std::size_t n = std::size_t(mesh.vertex_count()), k = std::size_t(3 * ((degree + 1) * (degree + 1) - 1));
  c.resize(n, degree);
  for (const auto& line : ply->header) c.antialiased = c.antialiased || line.text == kAntialiased;
  // Row by row (a column at a time would cross the whole element once per property): each splat's values
  // from their offsets in its record, float or double.
  std::vector<std::size_t> at(props.size());
  std::vector<bool> f32(props.size());
  for (std::size_t q = 0; q < props.size(); ++q)
    at[q] = v.offset(props[q]), f32[q] = v.properties[props[q]].type == PlyScalar::f32;
  std::vector<float> row(props.size());
  const std::size_t stride = v.stride();
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char* rec = v.data.data() + i * stride;
    for (std::size_t q = 0; q < props.size(); ++q) {
      if (f32[q]) {
        std::memcpy(&row[q], rec + at[q], 4);
      } else {
        double d;
        std::memcpy(&d, rec + at[q], 8);
        row[q] = float(d);
      }
    }
    // props: f_dc_0..2, f_rest_0..k-1, opacity, scale_0..2, rot_0..3 (property_names' order without x y z).
    for (std::size_t j = 0; j < 3; ++j) {
      c.position[i * 3 + j] = float(mesh.vertices(Eigen::Index(i), Eigen::Index(j)));
      c.f_dc[i * 3 + j] = row[j];
      c.scale[i * 3 + j] = row[4 + k + j];
    }
    if (k) std::memcpy(c.f_rest.data() + i * k, &row[3], k * 4);
    c.opacity[i] = row[3 + k];
    std::memcpy(&c.rot[i * 4], &row[7 + k], 16);
  }
  return c;
}

template <class T>
BasicMesh<T> decode_splat_file(std::string_view bytes, const std::string& path, SplatFormat format,
                               std::size_t max_bytes) {
  switch (format) {
    case SplatFormat::spz:
      return splat_mesh<T>(decode_spz(bytes, path, max_bytes));
    case SplatFormat::splat:
      return splat_mesh<T>(decode_splat(bytes, path));
    default:
      return splat_mesh<T>(decode_compressed_ply(bytes, path));
  }
}

template <class T>
BasicMesh<T> read_splat_file(const std::string& path, SplatFormat format, std::size_t max_bytes) {
  return decode_splat_file<T>(read_file(path, max_bytes), path, format, max_bytes);
}

template <class T>
std::string encode_splat_file(const BasicMesh<T>& mesh, const std::string& path, SplatFormat format) {
  if (format == SplatFormat::spz) return encode_spz(splat_cloud(mesh, path), path);
  if (format == SplatFormat::compressed_ply) return encode_compressed_ply(splat_cloud(mesh, path), path);
  throw InputError(path,
                   std::string(splat_format_name(format)) + " is read only (write .spz, .compressed.ply or .ply)");
}

std::vector<std::string> splat_output_drops(const PlyLayout& ply) {
  std::vector<std::string> drops, names;
  const std::vector<std::string> kept = property_names(3);
  for (std::size_t e = 0; e < ply.elements.size(); ++e) {
    const PlyElement& el = ply.elements[e];
    if (int(e) != ply.vertex_element) {
      drops.push_back("element " + el.name + " (" + std::to_string(el.count) + ")");
      continue;
    }
    for (const PlyProperty& p : el.properties)
      if (std::find(kept.begin(), kept.end(), p.name) == kept.end()) names.push_back(p.name);
  }
  if (!names.empty()) {
    std::string list;
    for (const auto& s : names) list += (list.empty() ? "" : ", ") + s;
    drops.insert(drops.begin(), "vertex properties " + list);
  }
  std::size_t comments = 0;
  for (const auto& line : ply.header) comments += line.text != kAntialiased;
  if (comments) drops.push_back(std::to_string(comments) + " comment/obj_info lines");
  return drops;
}

#define MLSDEFORM_FILES_SPLAT_IO(T)                                                                           \
  template BasicMesh<T> splat_mesh<T>(const SplatCloud&);                                                     \
  template SplatCloud splat_cloud(const BasicMesh<T>&, const std::string&);                                   \
  template void check_splat_output(const BasicMesh<T>&, const std::string&);                                  \
  template BasicMesh<T> read_splat_file<T>(const std::string&, SplatFormat, std::size_t);                     \
  template BasicMesh<T> decode_splat_file<T>(std::string_view, const std::string&, SplatFormat, std::size_t); \
  template std::string encode_splat_file(const BasicMesh<T>&, const std::string&, SplatFormat);
MLSDEFORM_FILES_SPLAT_IO(float)
MLSDEFORM_FILES_SPLAT_IO(double)
#undef MLSDEFORM_FILES_SPLAT_IO

}  // namespace mlsdeform::files
