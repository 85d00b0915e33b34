// The PLY writer: binary little-endian or ASCII. A mesh read from a PLY file is written with its file's layout
// (every element and property, in order, with its type; comments): x, y, z from the mesh in the output's
// coordinate type, every other value as read (normals as transform_normals left them), bit for bit. A mesh
// built in memory gets x, y, z (and nx, ny, nz) as float or double and faces as a list of int with uchar
// counts (uint where a face has more than 255 corners).
#include "core/files/formats/writer.hpp"

#include <array>
#include <bit>
#include <cmath>
#include <cstring>

namespace mlsdeform::files::formats {
namespace {

/// One value stored in the machine's order (PlyElement::data) written as binary little-endian or as text.
void put_value(TextOut& o, bool binary, PlyScalar s, const unsigned char* p) {
  const std::size_t n = size_of(s);
  if (binary) {
    if constexpr (std::endian::native == std::endian::little) {
      o.s.append(reinterpret_cast<const char*>(p), n);
    } else {
      for (std::size_t j = n; j-- > 0;) o.s.push_back(char(p[j]));
    }
    return;
  }
  if (s == PlyScalar::f32) {
    float f;
    std::memcpy(&f, p, 4);
    o.num(f);
  } else if (s == PlyScalar::f64) {
    double d;
    std::memcpy(&d, p, 8);
    o.num(d);
  } else {
    const double v = ply_load(s, p);  // an exact integer of at most 32 bits
    if (v < 0) o << '-';
    o.num(std::uint64_t(std::fabs(v)));
  }
}

void put_real(TextOut& o, bool binary, PlyScalar s, double v) {
  unsigned char b[8];
  ply_store(s, v, b);
  put_value(o, binary, s, b);
}

template <class O, class T>
std::string encode_layout(const BasicMesh<T>& m, const PointsRowMajor<T>* normals, bool binary) {
  const PlyLayout& ply = *m.extras.ply;
  const PlyScalar coordinate = std::is_same_v<O, float> ? PlyScalar::f32 : PlyScalar::f64;
  const PlyElement& vertex = ply.vertices();
  const int xyz[3] = {vertex.find("x"), vertex.find("y"), vertex.find("z")};
  const auto file_normals = ply_normals(ply);
  // Computed normals go where the file has its own, else into three new properties after the others.
  const bool append_normals =
      normals && !file_normals && vertex.find("nx") < 0 && vertex.find("ny") < 0 && vertex.find("nz") < 0;
  TextOut o;
  o.s.reserve(256 + vertex.data.size() * (binary ? 2 : 4));
  o << "ply\nformat " << (binary ? "binary_little_endian" : "ascii") << " 1.0\ncomment " << comment() << '\n';
  std::size_t declarations = 0, note = 0;
  auto notes = [&] {
    for (; note < ply.header.size() && ply.header[note].after <= declarations; ++note)
      o << ply.header[note].text << '\n';
  };
  notes();
  for (std::size_t e = 0; e < ply.elements.size(); ++e) {
    const PlyElement& el = ply.elements[e];
    o << "element " << el.name << ' ';
    o.num(el.count);
    o << '\n';
    ++declarations;
    notes();
    for (std::size_t k = 0; k < el.properties.size(); ++k) {
      const PlyProperty& p = el.properties[k];
      const bool is_xyz = int(e) == ply.vertex_element && (int(k) == xyz[0] || int(k) == xyz[1] || int(k) == xyz[2]);
      o << "property ";
      if (p.list) o << "list " << type_name(p.count_type) << ' ';
      o << type_name(is_xyz ? coordinate : p.type) << ' ' << p.name << '\n';
      ++declarations;
      notes();
    }
    if (int(e) == ply.vertex_element && append_normals)
      for (const char* n : {"nx", "ny", "nz"}) o << "property " << type_name(coordinate) << ' ' << n << '\n';
  }
  for (; note < ply.header.size(); ++note) o << ply.header[note].text << '\n';
  o << "end_header\n";

  for (std::size_t e = 0; e < ply.elements.size(); ++e) {
    const PlyElement& el = ply.elements[e];
    const unsigned char* p = el.data.data();
    if (int(e) == ply.vertex_element && binary && !normals && std::endian::native == std::endian::little &&
        !vertex.has_lists() && vertex.properties[std::size_t(xyz[0])].type == coordinate &&
        vertex.properties[std::size_t(xyz[1])].type == coordinate &&
        vertex.properties[std::size_t(xyz[2])].type == coordinate) {
      // The records as read, in one copy, then x, y, z stored over theirs: the bytes of the general loop below
      // (every other value copied as read; x, y, z as O in little-endian order), without a call per value (a
      // 3DGS splat file has 62 properties a vertex).
      const std::size_t stride = vertex.stride(), at = o.s.size();
      o.s.append(reinterpret_cast<const char*>(p), std::size_t(el.count) * stride);
      std::size_t offset[3];
      for (int c = 0; c < 3; ++c) offset[c] = vertex.offset(std::size_t(xyz[c]));
      char* rows = o.s.data() + at;
      for (std::size_t i = 0; i < el.count; ++i)
        for (int c = 0; c < 3; ++c) {
          const O v = O(m.vertices(Eigen::Index(i), c));
          std::memcpy(rows + i * stride + offset[c], &v, sizeof v);
        }
      continue;
    }
    if (int(e) == ply.vertex_element) {
      // Which value each property takes: 0 as read, 1 + c coordinate c, 4 + c computed normal c.
      std::vector<int> source(el.properties.size(), 0);
      for (int c = 0; c < 3; ++c) source[std::size_t(xyz[c])] = 1 + c;
      if (normals && file_normals)
        for (int c = 0; c < 3; ++c) source[(*file_normals)[std::size_t(c)]] = 4 + c;
      for (std::size_t i = 0; i < el.count; ++i) {
        for (std::size_t k = 0; k < el.properties.size(); ++k) {
          const PlyScalar s = el.properties[k].type;
          if (!binary && k) o << ' ';
          if (source[k] == 0)
            put_value(o, binary, s, p);
          else if (source[k] < 4)
            put_real(o, binary, coordinate, double(O(m.vertices(Eigen::Index(i), source[k] - 1))));
          else
            put_real(o, binary, s, double((*normals)(Eigen::Index(i), source[k] - 4)));
          p += size_of(s);
        }
        if (append_normals)
          for (int c = 0; c < 3; ++c) {
            if (!binary) o << ' ';
            put_real(o, binary, coordinate, double(O((*normals)(Eigen::Index(i), c))));
          }
        if (!binary) o << '\n';
      }
      continue;
    }
    for (std::uint64_t i = 0; i < el.count; ++i) {
      bool first = true;
      auto put = [&](PlyScalar s) {
        if (!binary && !first) o << ' ';
        first = false;
        put_value(o, binary, s, p);
        p += size_of(s);
      };
      for (const PlyProperty& q : el.properties) {
        if (!q.list) {
          put(q.type);
          continue;
        }
        const auto n = std::uint64_t(ply_load(q.count_type, p));  // not negative: the reader checked
        put(q.count_type);
        for (std::uint64_t j = 0; j < n; ++j) put(q.type);
      }
      if (!binary) o << '\n';
    }
  }
  return std::move(o.s);
}

}  // namespace

template <class O, class T>
std::string encode_ply(const BasicMesh<T>& m, const PointsRowMajor<T>* normals, PlyEncoding encoding) {
  if (m.extras.ply) return encode_layout<O>(m, normals, encoding == PlyEncoding::binary);
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

template std::string encode_ply<float, float>(const BasicMesh<float>&, const PointsRowMajor<float>*, PlyEncoding);
template std::string encode_ply<double, float>(const BasicMesh<float>&, const PointsRowMajor<float>*, PlyEncoding);
template std::string encode_ply<float, double>(const BasicMesh<double>&, const PointsRowMajor<double>*, PlyEncoding);
template std::string encode_ply<double, double>(const BasicMesh<double>&, const PointsRowMajor<double>*, PlyEncoding);

}  // namespace mlsdeform::files::formats
