// What the program does with a mesh's attributes (attributes.hpp): normals transformed by each vertex's linear
// part, and the report of what a write keeps, transforms and drops.
#include <mlsdeform/files_error.hpp>
#include "core/files/file_io.hpp"
#include "core/files/mesh.hpp"
#include "core/files/splat_io.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace mlsdeform::files {
namespace {

/// v / |v|, scaled first by the power of two of its largest component (exactly) so that no square overflows or
/// underflows; false (v left alone) for a zero or non-finite v. (Not by 1 / largest: for a subnormal largest
/// component below 2^-1024 that reciprocal overflows, and a normal such as (0, 0, 5e-324) became NaN.)
bool normalise(double* v) {
  const double big = std::max(std::max(std::fabs(v[0]), std::fabs(v[1])), std::fabs(v[2]));
  if (!(big > 0) || !std::isfinite(big)) return false;
  const int e = std::ilogb(big);
  const double s[3] = {std::ldexp(v[0], -e), std::ldexp(v[1], -e), std::ldexp(v[2], -e)};
  const double inv_len = 1 / std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
  for (int r = 0; r < 3; ++r) v[r] = s[r] * inv_len;
  return true;
}

/// Whether L is exactly the identity (a vertex outside a region, or one nothing turns): its normal is then
/// written as read, bit for bit, not renormalised.
template <class T>
bool is_identity(const T* l) {
  for (int k = 0; k < 9; ++k)
    if (l[k] != (k % 4 == 0 ? T(1) : T(0))) return false;
  return true;
}

/// n' = L^-T n renormalised, through the cofactor matrix: cof(L) = det(L) L^-T, so L^-T n points along
/// sign(det L) cof(L) n, which needs no division and stays defined for a singular L of rank 2 (the normal of
/// the plane L flattens onto). The input is made unit first (any finite normal, however long, then transforms
/// without overflow). Where the result is zero or not finite (L of rank < 2, or non-finite), the input normal
/// is kept, unit length: there is no transformed direction to give. A zero or non-finite input is kept as
/// it is, and so is any input where L is exactly the identity (true: `out` is `n` unchanged). In double: float
/// input is exact in it, and the rounding to the output type comes once, at the end.
template <class T>
bool transformed(const T* l, const double* n, double* out) {
  if (is_identity(l)) {
    std::copy(n, n + 3, out);
    return true;
  }
  double u[3] = {n[0], n[1], n[2]};
  if (!normalise(u)) {
    std::copy(n, n + 3, out);
    return false;
  }
  const double a = double(l[0]), b = double(l[1]), c = double(l[2]);
  const double d = double(l[3]), e = double(l[4]), f = double(l[5]);
  const double g = double(l[6]), h = double(l[7]), i = double(l[8]);
  const double cof[9] = {e * i - f * h, f * g - d * i, d * h - e * g,   // row 0 of cof(L)
                         c * h - b * i, a * i - c * g, b * g - a * h,   // row 1
                         b * f - c * e, c * d - a * f, a * e - b * d};  // row 2
  const double det = a * cof[0] + b * cof[1] + c * cof[2];
  const double sign = det < 0 ? -1.0 : 1.0;
  double m[3];
  for (int r = 0; r < 3; ++r) m[r] = sign * (cof[3 * r] * u[0] + cof[3 * r + 1] * u[1] + cof[3 * r + 2] * u[2]);
  if (!normalise(m)) {
    std::copy(u, u + 3, out);
    return false;
  }
  std::copy(m, m + 3, out);
  return false;
}

std::string joined(const std::vector<std::string>& names, std::size_t most = 12) {
  std::string s;
  for (std::size_t i = 0; i < names.size() && i < most; ++i) s += (i ? ", " : "") + names[i];
  if (names.size() > most) s += ", ... (" + std::to_string(names.size()) + " in all)";
  return s;
}

std::string counted(std::uint64_t n, const std::string& what) { return std::to_string(n) + " " + what; }

}  // namespace

template <class T>
void transform_normals(BasicMesh<T>& mesh, const T* linear) {
  if (auto& ply = mesh.extras.ply) {
    const auto k = ply_normals(*ply);
    if (!k) return;
    PlyElement& v = ply->vertices();
    const std::size_t stride = v.stride();
    std::size_t at[3];
    PlyScalar type[3];
    for (int c = 0; c < 3; ++c)
      at[c] = v.offset((*k)[std::size_t(c)]), type[c] = v.properties[(*k)[std::size_t(c)]].type;
    for (std::size_t i = 0; i < std::size_t(v.count); ++i) {
      unsigned char* item = v.data.data() + i * stride;
      const double n[3] = {ply_load(type[0], item + at[0]), ply_load(type[1], item + at[1]),
                           ply_load(type[2], item + at[2])};
      double out[3];
      transformed(linear + 9 * i, n, out);
      for (int c = 0; c < 3; ++c) ply_store(type[c], out[c], item + at[c]);
    }
  }
  if (auto& obj = mesh.extras.obj; obj && !obj->corner_normals.empty()) {
    // A vn is a normal of face corners, and corners of different vertices may share it: each (vn, vertex)
    // pair that a corner names becomes one new vn, in the order corners first name them.
    std::unordered_map<std::uint64_t, std::uint32_t> made;
    std::vector<double> normals;
    std::vector<std::uint32_t> sources, corners(obj->corner_normals.size(), ObjExtras::kNone);
    for (std::size_t c = 0; c < corners.size(); ++c) {
      const std::uint32_t k = obj->corner_normals[c];
      if (k == ObjExtras::kNone) continue;
      const std::uint32_t vertex = mesh.face_indices[c];
      const auto [it, fresh] = made.try_emplace(std::uint64_t(k) << 32 | vertex, std::uint32_t(normals.size() / 3));
      if (fresh) {
        double out[3];
        const bool as_read = transformed(linear + 9 * std::size_t(vertex), &obj->normals[3 * std::size_t(k)], out);
        normals.insert(normals.end(), out, out + 3);
        sources.push_back(as_read ? k : ObjExtras::kNone);
      }
      corners[c] = it->second;
    }
    obj->normals = std::move(normals);
    obj->corner_normals = std::move(corners);
    obj->normal_sources = std::move(sources);
    obj->normals_rewritten = true;
  }
}

template <class T>
AttributeReport attribute_report(const BasicMesh<T>& mesh, const std::string& out_path, NormalsOut normals,
                                 InputNormals fate) {
  AttributeReport r;
  const std::string out = format_extension(out_path);
  const MeshExtras& x = mesh.extras;
  const bool computed = normals == NormalsOut::computed && out != "off" && out != "npy";
  if (computed) r.transformed.push_back("normals computed from the deformed faces");
  // numpy's .npy holds the positions alone.
  if (out == "npy" && mesh.face_count()) r.dropped.push_back(counted(mesh.face_count(), "faces"));
  auto normals_went = [&](const std::string& what) {
    if (computed)
      r.dropped.push_back(what + " (replaced by computed ones)");
    else if (fate == InputNormals::transformed)
      r.transformed.push_back(what);
    else
      r.kept.push_back(what);
  };
  if (x.ply && files::splat_format(out_path) != files::SplatFormat::none) {  // SPZ, compressed PLY: splat_io.hpp
    r.dropped = files::splat_output_drops(*x.ply);
    if (x.ply->vertex_element >= 0 && x.ply->vertices().find("rot_0") >= 0)
      r.transformed.push_back("Gaussian splats (rot_*, scale_*, f_rest_*)");
  } else if (x.ply) {
    const auto n = ply_normals(*x.ply);
    // A Gaussian splat file's rot_*, scale_* and f_rest_* turn with the splats (splats.hpp), named as such.
    const bool splats = x.ply->vertex_element >= 0 && x.ply->vertices().find("rot_0") >= 0;
    auto splat_property = [](const std::string& name) {
      return name.rfind("rot_", 0) == 0 || name.rfind("scale_", 0) == 0 || name.rfind("f_rest_", 0) == 0;
    };
    std::vector<std::string> items;
    for (std::size_t e = 0; e < x.ply->elements.size(); ++e) {
      const PlyElement& el = x.ply->elements[e];
      const bool is_vertex = int(e) == x.ply->vertex_element, is_face = int(e) == x.ply->face_element;
      std::vector<std::string> names;
      for (const PlyProperty& p : el.properties) {
        const bool position = p.name == "x" || p.name == "y" || p.name == "z";
        const bool normal = n && (p.name == "nx" || p.name == "ny" || p.name == "nz");
        const bool corners = p.list && (p.name == "vertex_indices" || p.name == "vertex_index");
        const bool splat = splats && splat_property(p.name);
        if (!(is_vertex && (position || normal || splat)) && !(is_face && corners)) names.push_back(p.name);
      }
      if (is_vertex || is_face) {
        if (!names.empty()) items.push_back((is_vertex ? "vertex properties " : "face properties ") + joined(names));
      } else {
        items.push_back("element " + el.name + " (" + std::to_string(el.count) + ")");
      }
    }
    if (!x.ply->header.empty()) items.push_back(counted(x.ply->header.size(), "comment/obj_info lines"));
    for (auto& s : items) (out == "ply" ? r.kept : r.dropped).push_back(s);
    if (splats) (out == "ply" ? r.transformed : r.dropped).push_back("Gaussian splats (rot_*, scale_*, f_rest_*)");
    if (n) {
      if (out == "ply")
        normals_went("normals (nx ny nz)");
      else if (!computed)
        r.dropped.push_back("normals (nx ny nz)");
    }
  }
  if (x.obj) {
    std::vector<std::string> items;
    if (x.obj->texture_coordinates) items.push_back(counted(x.obj->texture_coordinates, "vt"));
    if (!x.obj->vertex_tails.empty())
      items.push_back(counted(x.obj->vertex_tails.non_empty(), "vertex colours (text after v x y z)"));
    if (x.obj->other_lines)
      items.push_back(counted(x.obj->other_lines, "other statements (mtllib, usemtl, g, o, s, vp, l, p)"));
    for (auto& s : items) (out == "obj" ? r.kept : r.dropped).push_back(s);
    if (x.obj->normal_lines) {
      const std::string vn = counted(x.obj->normal_lines, "vn");
      if (out != "obj")
        r.dropped.push_back(vn);
      else if (computed || x.has_normals())
        normals_went(vn);
      else
        r.kept.push_back(vn + " (no face names them)");
    }
  }
  if (x.off) {
    std::vector<std::string> items;
    if (!x.off->vertex_tails.empty()) items.push_back(counted(x.off->vertex_tails.non_empty(), "vertex colours"));
    if (!x.off->face_tails.empty()) items.push_back(counted(x.off->face_tails.non_empty(), "face colours"));
    for (auto& s : items) (out == "off" ? r.kept : r.dropped).push_back(s);
    if (x.off->comments) r.dropped.push_back(counted(x.off->comments, "comment lines"));
  }
  return r;
}

#define MLSDEFORM_FILES_ATTRIBUTES(T)                       \
  template void transform_normals(BasicMesh<T>&, const T*); \
  template AttributeReport attribute_report(const BasicMesh<T>&, const std::string&, NormalsOut, InputNormals);
MLSDEFORM_FILES_ATTRIBUTES(float)
MLSDEFORM_FILES_ATTRIBUTES(double)
#undef MLSDEFORM_FILES_ATTRIBUTES

}  // namespace mlsdeform::files
