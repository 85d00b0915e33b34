// See attributes.hpp.
#include "core/files/attributes.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace mlsdeform::files {

std::size_t size_of(PlyScalar s) {
  switch (s) {
    case PlyScalar::i8:
    case PlyScalar::u8:
      return 1;
    case PlyScalar::i16:
    case PlyScalar::u16:
      return 2;
    case PlyScalar::i32:
    case PlyScalar::u32:
    case PlyScalar::f32:
      return 4;
    case PlyScalar::f64:
      return 8;
  }
  return 0;
}

std::string_view type_name(PlyScalar s) {
  switch (s) {
    case PlyScalar::i8:
      return "char";
    case PlyScalar::u8:
      return "uchar";
    case PlyScalar::i16:
      return "short";
    case PlyScalar::u16:
      return "ushort";
    case PlyScalar::i32:
      return "int";
    case PlyScalar::u32:
      return "uint";
    case PlyScalar::f32:
      return "float";
    case PlyScalar::f64:
      return "double";
  }
  return "";
}

bool parse_scalar(std::string_view t, PlyScalar& s) {
  if (t == "char" || t == "int8")
    s = PlyScalar::i8;
  else if (t == "uchar" || t == "uint8")
    s = PlyScalar::u8;
  else if (t == "short" || t == "int16")
    s = PlyScalar::i16;
  else if (t == "ushort" || t == "uint16")
    s = PlyScalar::u16;
  else if (t == "int" || t == "int32")
    s = PlyScalar::i32;
  else if (t == "uint" || t == "uint32")
    s = PlyScalar::u32;
  else if (t == "float" || t == "float32")
    s = PlyScalar::f32;
  else if (t == "double" || t == "float64")
    s = PlyScalar::f64;
  else
    return false;
  return true;
}

namespace {

template <class I>
double load_as(const unsigned char* p) {
  I v;
  std::memcpy(&v, p, sizeof v);
  return double(v);
}

template <class I>
void store_as(double v, unsigned char* p) {
  I out;
  if constexpr (std::is_integral_v<I>) {
    // The nearest integer the type holds (NaN: 0), so that no conversion is undefined.
    const double r = std::isnan(v) ? 0.0 : std::nearbyint(v);
    out = r <= double(std::numeric_limits<I>::min())   ? std::numeric_limits<I>::min()
          : r >= double(std::numeric_limits<I>::max()) ? std::numeric_limits<I>::max()
                                                       : I(r);
  } else {
    out = I(v);
  }
  std::memcpy(p, &out, sizeof out);
}

}  // namespace

double ply_load(PlyScalar s, const unsigned char* p) {
  switch (s) {
    case PlyScalar::i8:
      return load_as<std::int8_t>(p);
    case PlyScalar::u8:
      return load_as<std::uint8_t>(p);
    case PlyScalar::i16:
      return load_as<std::int16_t>(p);
    case PlyScalar::u16:
      return load_as<std::uint16_t>(p);
    case PlyScalar::i32:
      return load_as<std::int32_t>(p);
    case PlyScalar::u32:
      return load_as<std::uint32_t>(p);
    case PlyScalar::f32:
      return load_as<float>(p);
    case PlyScalar::f64:
      return load_as<double>(p);
  }
  return 0;
}

void ply_store(PlyScalar s, double v, unsigned char* p) {
  switch (s) {
    case PlyScalar::i8:
      return store_as<std::int8_t>(v, p);
    case PlyScalar::u8:
      return store_as<std::uint8_t>(v, p);
    case PlyScalar::i16:
      return store_as<std::int16_t>(v, p);
    case PlyScalar::u16:
      return store_as<std::uint16_t>(v, p);
    case PlyScalar::i32:
      return store_as<std::int32_t>(v, p);
    case PlyScalar::u32:
      return store_as<std::uint32_t>(v, p);
    case PlyScalar::f32:
      return store_as<float>(v, p);
    case PlyScalar::f64:
      return store_as<double>(v, p);
  }
}

bool PlyElement::has_lists() const {
  return std::any_of(properties.begin(), properties.end(), [](const PlyProperty& p) { return p.list; });
}

int PlyElement::find(std::string_view property) const {
  for (std::size_t k = 0; k < properties.size(); ++k)
    if (properties[k].name == property) return int(k);
  return -1;
}

std::size_t PlyElement::stride() const { return offset(properties.size()); }

std::size_t PlyElement::offset(std::size_t k) const {
  if (has_lists()) throw std::logic_error("PlyElement: element '" + name + "' has list properties");
  std::size_t b = 0;
  for (std::size_t j = 0; j < k; ++j) b += size_of(properties[j].type);
  return b;
}

double PlyElement::get(std::size_t i, std::size_t k) const {
  return ply_load(properties[k].type, data.data() + i * stride() + offset(k));
}

void PlyElement::set(std::size_t i, std::size_t k, double v) {
  ply_store(properties[k].type, v, data.data() + i * stride() + offset(k));
}

std::size_t TextColumn::non_empty() const {
  std::size_t n = 0;
  for (std::size_t i = 0; i < end.size(); ++i) n += end[i] != (i ? end[i - 1] : 0);
  return n;
}

std::optional<std::array<std::size_t, 3>> ply_normals(const PlyLayout& ply) {
  if (ply.vertex_element < 0) return std::nullopt;
  const PlyElement& v = ply.vertices();
  std::array<std::size_t, 3> k{};
  for (int c = 0; c < 3; ++c) {
    const int j = v.find(std::string("n") + char('x' + c));
    if (j < 0 || is_integer(v.properties[std::size_t(j)].type)) return std::nullopt;
    k[std::size_t(c)] = std::size_t(j);
  }
  return k;
}

bool MeshExtras::has_normals() const {
  if (ply) return ply_normals(*ply).has_value();
  if (obj)
    return std::any_of(obj->corner_normals.begin(), obj->corner_normals.end(),
                       [](std::uint32_t k) { return k != ObjExtras::kNone; });
  return false;
}

}  // namespace mlsdeform::files
