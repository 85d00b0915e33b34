#include "core/files/splats.hpp"

#include <mlsdeform/files_error.hpp>

#include <mlsdeform/splats.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace mlsdeform::files {

namespace {

/// Property `name` of the vertex element, which must be float or double; -1 if absent.
int float_property(const PlyElement& v, const std::string& name, const std::string& path) {
  const int k = v.find(name);
  if (k >= 0 && (v.properties[std::size_t(k)].list || is_integer(v.properties[std::size_t(k)].type)))
    throw InputError(path, "a Gaussian splat file's property " + name + " must be float or double, not " +
                               std::string(type_name(v.properties[std::size_t(k)].type)) +
                               (v.properties[std::size_t(k)].list ? " list" : ""));
  return k;
}

std::size_t required(const PlyElement& v, const std::string& name, const std::string& path) {
  const int k = float_property(v, name, path);
  if (k < 0)
    throw InputError(path, "a Gaussian splat file (its vertices have rot_0) needs the property " + name +
                               " (docs/splats.md: rot_0..3, scale_0..2, f_rest_*)");
  return std::size_t(k);
}

/// Byte offsets of properties `ks` within a vertex record.
std::vector<std::size_t> offsets(const PlyElement& v, const std::vector<std::size_t>& ks) {
  std::vector<std::size_t> all(v.properties.size() + 1, 0);
  for (std::size_t k = 0; k < v.properties.size(); ++k) all[k + 1] = all[k] + size_of(v.properties[k].type);
  std::vector<std::size_t> r;
  for (std::size_t k : ks) r.push_back(all[k]);
  return r;
}

// Splats are gathered, transformed and stored back this many at a time: in double (every PLY float or double
// value converts exactly, so a splat left alone is stored back bit for bit), 52 values a splat, 7 MiB.
constexpr std::size_t kChunk = 16384;

/// A splat property's value (float or double: splat_layout checks), in the machine's byte order as the reader
/// keeps it; read inline, these loops move 52 values a splat.
double load(PlyScalar type, const unsigned char* p) {
  if (type == PlyScalar::f32) {
    float f;
    std::memcpy(&f, p, sizeof f);
    return double(f);
  }
  double d;
  std::memcpy(&d, p, sizeof d);
  return d;
}

/// Stored back, rounded once to the property's type.
void store(PlyScalar type, double value, unsigned char* p) {
  if (type == PlyScalar::f32) {
    const float f = float(value);
    std::memcpy(p, &f, sizeof f);
  } else {
    std::memcpy(p, &value, sizeof value);
  }
}

std::vector<PlyScalar> types(const PlyElement& v, const std::vector<std::size_t>& ks) {
  std::vector<PlyScalar> t;
  for (std::size_t k : ks) t.push_back(v.properties[k].type);
  return t;
}

/// Properties `ks` (byte offsets `at`) of vertices [first, first + count) into count x ks.size() doubles.
void gather(const PlyElement& v, const std::vector<std::size_t>& ks, const std::vector<std::size_t>& at,
            std::size_t first, std::size_t count, std::vector<double>& out) {
  const std::size_t stride = v.stride(), w = ks.size();
  const std::vector<PlyScalar> type = types(v, ks);
  out.resize(count * w);
  for (std::size_t i = 0; i < count; ++i) {
    const unsigned char* record = v.data.data() + (first + i) * stride;
    for (std::size_t j = 0; j < w; ++j) out[i * w + j] = load(type[j], record + at[j]);
  }
}

/// Whether `value` is finite once rounded to `type` (float or double). A splat's values come in finite (the
/// library refuses others) and are transformed in double, where a rotated f_rest_* can grow to its band's
/// norm: a float near float's largest then rounds to inf.
bool fits(PlyScalar type, double value) {
  return type == PlyScalar::f32 ? std::isfinite(float(value)) : std::isfinite(value);
}

/// Throws InputError naming `path`, the property and the splat (vertex) where a value of vertices
/// [first, first + count) would not fit its property's type: checked for every property before any is stored,
/// so a refused file is not written at all (the caller writes only after every splat is stored).
void check_range(const PlyElement& v, const std::vector<std::size_t>& ks, std::size_t first, std::size_t count,
                 const std::vector<double>& values, const std::string& path) {
  const std::size_t w = ks.size();
  for (std::size_t i = 0; i < count; ++i)
    for (std::size_t j = 0; j < w; ++j) {
      const PlyProperty& p = v.properties[ks[j]];
      if (!fits(p.type, values[i * w + j])) {
        char number[32];
        std::snprintf(number, sizeof number, "%.9g", values[i * w + j]);
        throw InputError(path, "splat (vertex) " + std::to_string(first + i) + ": its " + p.name + " becomes " +
                                   number + " under its centre's frame, beyond the range of " +
                                   std::string(type_name(p.type)) + ", the property's type");
      }
    }
}

/// And back.
void scatter(PlyElement& v, const std::vector<std::size_t>& ks, const std::vector<std::size_t>& at, std::size_t first,
             std::size_t count, const std::vector<double>& values) {
  const std::size_t stride = v.stride(), w = ks.size();
  const std::vector<PlyScalar> type = types(v, ks);
  for (std::size_t i = 0; i < count; ++i) {
    unsigned char* record = v.data.data() + (first + i) * stride;
    for (std::size_t j = 0; j < w; ++j) store(type[j], values[i * w + j], record + at[j]);
  }
}

}  // namespace

std::optional<SplatLayout> splat_layout(const PlyLayout& ply, const std::string& path) {
  if (ply.vertex_element < 0) return std::nullopt;
  const PlyElement& v = ply.vertices();
  if (v.find("rot_0") < 0) return std::nullopt;
  SplatLayout s;
  for (std::size_t j = 0; j < 4; ++j) s.rot[j] = required(v, "rot_" + std::to_string(j), path);
  for (std::size_t j = 0; j < 3; ++j) s.scale[j] = required(v, "scale_" + std::to_string(j), path);
  for (int j = 0;; ++j) {
    const int k = float_property(v, "f_rest_" + std::to_string(j), path);
    if (k < 0) break;
    s.f_rest.push_back(std::size_t(k));
  }
  s.sh_degree = splat_sh_degree_of(int(s.f_rest.size()));
  if (s.sh_degree < 0)
    throw InputError(path, "a Gaussian splat file's f_rest_* properties number " + std::to_string(s.f_rest.size()) +
                               " (f_rest_0 onwards), not 9, 24 or 45 (SH degree 1, 2, 3) or none");
  for (const PlyProperty& p : v.properties)
    if (p.name.rfind("f_rest_", 0) == 0 && v.find(p.name) >= 0) {
      bool listed = false;
      for (std::size_t k : s.f_rest) listed = listed || v.properties[k].name == p.name;
      if (!listed) throw InputError(path, "a Gaussian splat file's " + p.name + " is out of the f_rest_0.. sequence");
    }
  return s;
}

namespace {

/// The splats of `in`'s vertex element into `out`'s, kChunk at a time, gathered in double: `f(first, count,
/// arrays)` transforms a chunk in place (rotate_splats or transform_splats_affine); a splat it refuses is named
/// within the file.
template <class F>
void each_chunk(const PlyLayout& in, PlyLayout& out, const std::string& path, F&& f) {
  const SplatLayout from = *splat_layout(in, path), to = *splat_layout(out, path);
  const PlyElement& v = in.vertices();
  PlyElement& w = out.vertices();
  auto indices = [](const SplatLayout& l, int part) {
    return part == 0   ? std::vector<std::size_t>(l.rot.begin(), l.rot.end())
           : part == 1 ? std::vector<std::size_t>(l.scale.begin(), l.scale.end())
                       : l.f_rest;
  };
  const std::vector<std::size_t> rot = indices(from, 0), scale = indices(from, 1), out_rot = indices(to, 0),
                                 out_scale = indices(to, 1);
  const std::vector<std::size_t> rot_at = offsets(v, rot), scale_at = offsets(v, scale),
                                 sh_at = offsets(v, from.f_rest), out_rot_at = offsets(w, out_rot),
                                 out_scale_at = offsets(w, out_scale), out_sh_at = offsets(w, to.f_rest);
  std::vector<double> r, s, sh;
  for (std::size_t first = 0; first < v.count; first += kChunk) {
    const std::size_t count = std::min<std::size_t>(kChunk, std::size_t(v.count) - first);
    gather(v, rot, rot_at, first, count, r);
    gather(v, scale, scale_at, first, count, s);
    gather(v, from.f_rest, sh_at, first, count, sh);
    const SplatArrays<double> arrays{r.data(), s.data(), sh.empty() ? nullptr : sh.data(), from.sh_degree};
    try {
      f(first, count, arrays);
    } catch (const std::invalid_argument& e) {
      // The library names the splat within the chunk: name it within the file
      std::string what = e.what();
      const std::size_t at = what.find("splat ");
      if (at != std::string::npos) {
        const std::size_t end = what.find(':', at);
        what = "splat (vertex) " + std::to_string(first + std::stoull(what.substr(at + 6, end - at - 6))) +
               what.substr(end);
      }
      throw InputError(path, what);
    }
    check_range(w, out_rot, first, count, r, path);
    check_range(w, out_scale, first, count, s, path);
    check_range(w, to.f_rest, first, count, sh, path);
    scatter(w, out_rot, out_rot_at, first, count, r);
    scatter(w, out_scale, out_scale_at, first, count, s);
    scatter(w, to.f_rest, out_sh_at, first, count, sh);
  }
}

}  // namespace

template <class T>
void transform_splats(const PlyLayout& in, PlyLayout& out, const T* quaternions, const T* scales, int threads,
                      const std::string& path) {
  std::vector<double> q(4 * kChunk), grow(kChunk);
  each_chunk(in, out, path, [&](std::size_t first, std::size_t count, const SplatArrays<double>& arrays) {
    // The fits' unit quaternions, renormalised in double: a float frame is a rotation to float's rounding,
    // which rotate_splats<double> would take for a quaternion off unit length. The identity stays exact.
    for (std::size_t i = 0; i < count; ++i) {
      const T* t = quaternions + 4 * (first + i);
      const double length =
          std::sqrt(double(t[0]) * t[0] + double(t[1]) * t[1] + double(t[2]) * t[2] + double(t[3]) * t[3]);
      for (std::size_t j = 0; j < 4; ++j) q[4 * i + j] = double(t[j]) / length;
      if (scales) grow[i] = double(scales[first + i]);
    }
    rotate_splats<double>(arrays, count, q.data(), scales ? grow.data() : nullptr, threads);
  });
}

template <class T>
void transform_splats_linear(const PlyLayout& in, PlyLayout& out, const T* linear, int threads,
                             const std::string& path) {
  std::vector<double> m(9 * kChunk);
  each_chunk(in, out, path, [&](std::size_t first, std::size_t count, const SplatArrays<double>& arrays) {
    std::copy_n(linear + 9 * first, 9 * count, m.begin());
    transform_splats_affine<double>(arrays, count, m.data(), threads);
  });
}

template void transform_splats<float>(const PlyLayout&, PlyLayout&, const float*, const float*, int,
                                      const std::string&);
template void transform_splats<double>(const PlyLayout&, PlyLayout&, const double*, const double*, int,
                                       const std::string&);
template void transform_splats_linear<float>(const PlyLayout&, PlyLayout&, const float*, int, const std::string&);
template void transform_splats_linear<double>(const PlyLayout&, PlyLayout&, const double*, int, const std::string&);

}  // namespace mlsdeform::files
