// The PLY reader: ASCII, binary little- and big-endian; a vertex element with x, y, z and a face element with
// one list property of vertex indices; every element and property is kept with its type (PlyLayout), the
// values in the file's types, so that the writer gives them back bit for bit.
#include "core/files/formats/reader.hpp"

#include <algorithm>
#include <bit>

namespace mlsdeform::files::formats {
namespace {

std::size_t min_bytes(const PlyElement& el, bool binary) {  // the smallest an item can be in the body
  std::size_t b = 0;
  for (const auto& p : el.properties) b += binary ? (p.list ? size_of(p.count_type) : size_of(p.type)) : 2;
  return b;
}

/// Whether the integer v is a value of type s (an ASCII body may write anything).
bool fits(PlyScalar s, std::int64_t v) {
  switch (s) {
    case PlyScalar::i8:
      return v >= -128 && v <= 127;
    case PlyScalar::u8:
      return v >= 0 && v <= 255;
    case PlyScalar::i16:
      return v >= -32768 && v <= 32767;
    case PlyScalar::u16:
      return v >= 0 && v <= 65535;
    case PlyScalar::i32:
      return v >= std::numeric_limits<std::int32_t>::min() && v <= std::numeric_limits<std::int32_t>::max();
    case PlyScalar::u32:
      return v >= 0 && v <= std::int64_t(std::numeric_limits<std::uint32_t>::max());
    default:
      return true;
  }
}

/// One value of type s from a binary body in either byte order, appended to `data` in the machine's order
/// (kept as the file's bits); false if the body ends first. `out`: the value, exact.
bool read_binary(Reader& reader, PlyScalar s, bool big_endian, std::vector<unsigned char>& data, double& out) {
  unsigned char raw[8];
  // At most 8 (the largest PLY type), stated so that aarch64 g++ 12 can bound the copy (-Wstringop-overflow).
  const std::size_t n = std::min(size_of(s), sizeof raw);
  if (!reader.bytes(reinterpret_cast<char*>(raw), n)) return false;
  if (big_endian != (std::endian::native == std::endian::big)) std::reverse(raw, raw + n);
  data.insert(data.end(), raw, raw + n);
  out = ply_load(s, raw);
  return true;
}

}  // namespace

template <class T>
BasicMesh<T> read_ply(Reader& reader, const std::string& path) {
  auto malformed = [&](const std::string& why, std::size_t line = 0) -> InputError {
    return InputError(path, "malformed PLY: " + why, line ? at_line(line) : std::string());
  };
  // Header.
  std::size_t line_no = 0;
  std::vector<std::string_view> t;
  std::string_view raw;
  auto header_line = [&]() {
    if (!reader.line(raw)) throw malformed("the header has no end_header line");
    ++line_no;
    split(raw, t);  // no comments here: '#' is a character like any other in a PLY header
  };
  if (reader.skip_prefix(kBom))
    throw malformed("the file starts with a UTF-8 byte-order mark; the first line must be 'ply' (remove the mark)", 1);
  header_line();
  if (t.size() != 1 || t[0] != "ply") throw malformed("the first line is not 'ply'", 1);
  PlyLayout layout;
  std::string& format = layout.format;
  std::vector<PlyElement>& elements = layout.elements;
  std::size_t declarations = 0;  // element and property lines so far: where a comment stands
  for (;;) {
    header_line();
    if (t.empty()) continue;
    if (t[0] == "comment" || t[0] == "obj_info") {
      // Kept verbatim but for a line end's '\r' and this writer's own stamp (written anew).
      std::string_view text = raw;
      while (!text.empty() && text.back() == '\r') text.remove_suffix(1);
      if (!(t[0] == "comment" && t.size() > 3 && t[1] == "written" && t[2] == "by" && t[3] == "mlsdeform"))
        layout.header.push_back({declarations, std::string(text)});
      continue;
    }
    if (t[0] == "end_header") break;
    if (t[0] == "format") {
      if (t.size() != 3 || t[2] != "1.0" ||
          (t[1] != "ascii" && t[1] != "binary_little_endian" && t[1] != "binary_big_endian"))
        throw malformed("unsupported format line", line_no);
      if (!format.empty()) throw malformed("a second format line", line_no);
      format = std::string(t[1]);
    } else if (t[0] == "element") {
      PlyElement e;
      if (t.size() != 3 || !parse_number(t[2], e.count)) throw malformed("expected 'element NAME COUNT'", line_no);
      e.name = std::string(t[1]);
      for (const auto& other : elements)
        if (other.name == e.name) throw malformed("element " + shown(e.name) + " declared twice", line_no);
      elements.push_back(e);
      ++declarations;
    } else if (t[0] == "property") {
      if (elements.empty()) throw malformed("a property before any element", line_no);
      PlyProperty p;
      if (t.size() == 5 && t[1] == "list") {
        p.list = true;
        if (!parse_scalar(t[2], p.count_type) || !parse_scalar(t[3], p.type) || !is_integer(p.count_type))
          throw malformed("bad list property types", line_no);
        p.name = std::string(t[4]);
      } else if (t.size() == 3 && parse_scalar(t[1], p.type)) {
        p.name = std::string(t[2]);
      } else {
        throw malformed("expected 'property TYPE NAME' or 'property list COUNT_TYPE TYPE NAME'", line_no);
      }
      for (const auto& other : elements.back().properties)
        if (other.name == p.name) throw malformed("property " + shown(p.name) + " declared twice", line_no);
      elements.back().properties.push_back(p);
      ++declarations;
    } else {
      throw malformed("unknown header line " + shown(t[0]), line_no);
    }
  }
  if (format.empty()) throw malformed("no format line");
  for (const auto& el : elements)  // each item would be nothing in a binary body, and an empty line in ASCII
    if (el.properties.empty() && el.count > 0) throw malformed("element " + shown(el.name) + " has no properties");
  const bool binary = format != "ascii";
  const bool big_endian = format == "binary_big_endian";

  // What we read: vertex x, y, z and face vertex_indices (or vertex_index).
  int& vertex_element = layout.vertex_element;
  int& face_element = layout.face_element;
  int xyz[3] = {-1, -1, -1}, indices = -1;
  for (std::size_t e = 0; e < elements.size(); ++e) {
    const auto& el = elements[e];
    if (el.name == "vertex") {
      vertex_element = int(e);
      for (std::size_t k = 0; k < el.properties.size(); ++k) {
        if (el.properties[k].list) throw malformed("list properties in the vertex element are not supported");
        for (int c = 0; c < 3; ++c)
          if (el.properties[k].name == std::string(1, char('x' + c))) xyz[c] = int(k);
      }
    } else if (el.name == "face") {
      face_element = int(e);
      for (std::size_t k = 0; k < el.properties.size(); ++k)
        if ((el.properties[k].name == "vertex_indices" || el.properties[k].name == "vertex_index") &&
            el.properties[k].list && is_integer(el.properties[k].type))
          indices = int(k);
      if (indices < 0) throw malformed("the face element has no integer list 'vertex_indices'");
    }
  }
  if (vertex_element < 0 || xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0)
    throw malformed("no vertex element with properties x, y and z");
  // Counts against the body's size, before allocating.
  const std::size_t body = reader.remaining();
  std::size_t min_total = 0;
  for (const auto& el : elements) {
    check_count(el.count, min_bytes(el, binary), body, el.name + " elements", path, "header", !binary);
    min_total += std::size_t(el.count) * min_bytes(el, binary);
  }
  // An ASCII body's last line may end without a newline.
  if (min_total > body + (!binary && min_total > 0 ? 1 : 0))
    throw InputError(path,
                     "the header's elements need at least " + std::to_string(min_total) + " bytes, but only " +
                         std::to_string(body) + " follow",
                     "header");

  BasicMesh<T> mesh;
  const auto& vertex_properties = elements[std::size_t(vertex_element)].properties;
  // float32 holds every value of the 8- and 16-bit integer types and of float exactly; a 32-bit integer (up to
  // 2^32 - 1) needs double's 53 bits, like a double: written back as float it would be rounded.
  mesh.stored_type = CoordinateType::float32;
  for (int c = 0; c < 3; ++c) {
    const PlyScalar type = vertex_properties[std::size_t(xyz[c])].type;
    if (type == PlyScalar::f64 || type == PlyScalar::i32 || type == PlyScalar::u32)
      mesh.stored_type = CoordinateType::float64;
  }
  const std::uint64_t nv = elements[std::size_t(vertex_element)].count;
  mesh.vertices.resize(Eigen::Index(nv), 3);
  if (face_element >= 0) mesh.face_start.reserve(std::size_t(elements[std::size_t(face_element)].count) + 1);
  std::deque<std::uint32_t> corners;
  Lines ascii(reader, line_no + 1);
  std::vector<double> values;
  for (std::size_t e = 0; e < elements.size(); ++e) {
    auto& el = elements[e];
    // Stored in the file's types: at most 8 bytes per value, and the counts were checked against the body.
    const bool lists = el.has_lists();
    std::vector<std::size_t> offsets;
    for (std::size_t k = 0; !lists && k < el.properties.size(); ++k) offsets.push_back(el.offset(k));
    const std::size_t stride = lists ? 0 : el.stride();
    if (!lists) el.data.reserve(std::size_t(el.count) * stride);
    for (std::uint64_t i = 0; i < el.count; ++i) {
      // Built only for a message: most elements are fine.
      auto item = [&] { return el.name + " " + std::to_string(i); };
      // Binary messages name the element and index themselves; ASCII ones get the line too.
      auto where = [&] { return binary ? std::string() : at_line(ascii.line()); };
      auto truncated = [&] {
        return malformed("truncated in " + el.name + " " + std::to_string(i) + " of " + std::to_string(el.count));
      };
      // Each property's values, lists flattened after their count; stored in el.data as they are read.
      values.clear();
      std::size_t list_begin = 0, list_size = 0;
      if (binary && !lists) {
        // A fixed-size item (every vertex element): its bytes at once, each value then put in the machine's
        // order where the file's is the other.
        const std::size_t at = el.data.size();
        el.data.resize(at + stride);
        if (!reader.bytes(reinterpret_cast<char*>(el.data.data() + at), stride)) throw truncated();
        for (std::size_t k = 0; k < el.properties.size(); ++k) {
          unsigned char* b = el.data.data() + at + offsets[k];
          if (big_endian != (std::endian::native == std::endian::big))
            std::reverse(b, b + size_of(el.properties[k].type));
          values.push_back(ply_load(el.properties[k].type, b));
        }
      } else if (binary) {
        for (std::size_t k = 0; k < el.properties.size(); ++k) {
          const auto& p = el.properties[k];
          double v = 0;
          if (!p.list) {
            if (!read_binary(reader, p.type, big_endian, el.data, v)) throw truncated();
            values.push_back(v);
            continue;
          }
          if (!read_binary(reader, p.count_type, big_endian, el.data, v)) throw truncated();
          if (v < 0) throw malformed("negative list length in " + item());
          const auto n = std::uint64_t(v);
          if (n * size_of(p.type) > reader.remaining()) throw truncated();
          if (int(k) == indices) list_begin = values.size(), list_size = std::size_t(n);
          for (std::uint64_t j = 0; j < n; ++j) {
            if (!read_binary(reader, p.type, big_endian, el.data, v)) throw truncated();
            values.push_back(v);
          }
        }
      } else {
        if (!ascii.next_content(t)) throw truncated();
        std::size_t tok = 0;
        auto take = [&](PlyScalar s) {
          if (tok >= t.size()) throw InputError(path, "too few values for " + item(), where());
          double v = 0;
          std::errc ec;
          if (is_integer(s)) {
            std::int64_t n = 0;
            ec = read_number(t[tok], n);
            if (ec == std::errc() && !fits(s, n)) ec = std::errc::result_out_of_range;
            v = double(n);
          } else if (s == PlyScalar::f32) {
            float f = 0;  // parsed as float: correctly rounded once (decimal -> double -> float could round twice)
            ec = read_number(t[tok], f);
            v = f;
          } else {
            ec = read_number(t[tok], v);
          }
          if (ec == std::errc::result_out_of_range)
            throw InputError(path, shown(t[tok]) + " in " + item() + " is out of the range of its type", where());
          if (ec != std::errc()) throw InputError(path, "not a number: " + shown(t[tok]) + " in " + item(), where());
          ++tok;
          // Stored as its type: exact (an integer that fits, or the float or double just parsed).
          el.data.resize(el.data.size() + size_of(s));
          ply_store(s, v, el.data.data() + el.data.size() - size_of(s));
          return v;
        };
        for (std::size_t k = 0; k < el.properties.size(); ++k) {
          const auto& p = el.properties[k];
          if (!p.list) {
            values.push_back(take(p.type));
            continue;
          }
          const double n = take(p.count_type);
          if (n < 0 || n > double(t.size())) throw InputError(path, "bad list length in " + item(), where());
          if (int(k) == indices) list_begin = values.size(), list_size = std::size_t(n);
          for (std::size_t j = 0; j < std::size_t(n); ++j) values.push_back(take(p.type));
        }
        if (tok != t.size()) throw InputError(path, "too many values for " + item(), where());
      }
      if (int(e) == vertex_element) {
        // Vertex properties are all scalars (checked above): value k is property k.
        const T c[3] = {T(values[std::size_t(xyz[0])]), T(values[std::size_t(xyz[1])]), T(values[std::size_t(xyz[2])])};
        for (int k = 0; k < 3; ++k)  // a finite double property that T cannot hold (a double beyond float's range)
          if (std::isinf(c[k]) && std::isfinite(values[std::size_t(xyz[k])]))
            throw InputError(path,
                             "vertex " + std::to_string(i) + " has a coordinate beyond the range of float (" +
                                 shortest_text(values[std::size_t(xyz[k])]) + "; --precision double reads it)",
                             where());
        if (!finite3(c)) throw InputError(path, non_finite(std::size_t(i)), where());
        mesh.vertices.row(Eigen::Index(i)) << c[0], c[1], c[2];
      } else if (int(e) == face_element) {
        if (list_size < 3)
          throw InputError(path,
                           "face " + std::to_string(i) + " has " + std::to_string(list_size) + " vertices (at least 3)",
                           where());
        for (std::size_t j = 0; j < list_size; ++j) {
          const double v = values[list_begin + j];  // an exact integer of at most 32 bits
          if (v < 0 || v >= double(nv))
            throw InputError(path, out_of_range(std::size_t(i), std::int64_t(v), nv), where());
          corners.push_back(std::uint32_t(v));
        }
        mesh.face_start.push_back(std::uint32_t(corners.size()));
      }
    }
  }
  if (binary ? !reader.at_end() : ascii.next_content(t))
    throw malformed(binary ? std::to_string(reader.remaining()) + " bytes of data after the last element"
                           : "data after the last element (" + at_line(ascii.line()) + ")");
  if (nv == 0) throw InputError(path, "no vertices");
  mesh.face_indices = to_vector(corners);
  mesh.extras.ply = std::move(layout);
  return mesh;
}

template BasicMesh<float> read_ply<float>(Reader&, const std::string&);
template BasicMesh<double> read_ply<double>(Reader&, const std::string&);

}  // namespace mlsdeform::files::formats
