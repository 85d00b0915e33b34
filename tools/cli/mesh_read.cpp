// Strict mesh readers for OBJ, OFF and PLY (ASCII, binary little- and big-endian), each optionally gzip-
// compressed. Everything malformed is refused with the file, the line (or element and index) and the problem:
// numbers are parsed whole and correctly rounded (std::from_chars: no hex, no "1.5.5"), every index is checked,
// counts promised by a header are checked against the size of the body before anything is allocated, and
// nothing may follow the last element.
//
// Memory: the input is streamed (a buffer of 1 MiB, longer only for a longer line), never held whole, and
// what is built grows in blocks (std::deque) where its final size is not known yet, then is copied once into
// the mesh's arrays: the peak is about twice the final arrays, whatever the input's size or format.
#include "tools/cli/error.hpp"
#include "tools/cli/file_io.hpp"
#include "tools/cli/mesh.hpp"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <deque>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

namespace mlsdeform::cli {

namespace {

// The UTF-8 byte-order mark, U+FEFF.
constexpr std::string_view kBom = "\xef\xbb\xbf";

std::string at_line(std::size_t line) { return "line " + std::to_string(line); }

/// A token from the file as a message shows it: quoted, bytes outside printable ASCII as \xNN (a binary file
/// read as text stays one readable line), at most 40 characters.
std::string shown(std::string_view token) {
  std::string s = "'";
  for (std::size_t i = 0; i < token.size(); ++i) {
    if (i == 40) {
      s += "...";
      break;
    }
    const auto c = static_cast<unsigned char>(token[i]);
    if (c >= 0x20 && c < 0x7f) {
      s += char(c);
    } else {
      static const char hex[] = "0123456789abcdef";
      s += "\\x";
      s += hex[c >> 4];
      s += hex[c & 15];
    }
  }
  return s + "'";
}

/// Whole-token number parsing: the token must be a number and nothing else (correctly rounded for floats).
/// std::errc::result_out_of_range: a whole number that T cannot hold (1e39 or 1e-46 as a float).
template <class T>
std::errc read_number(std::string_view token, T& out) {
  if (token.empty()) return std::errc::invalid_argument;
  const char* first = token.data();
  if (*first == '+') ++first;  // from_chars refuses a leading '+', which text formats use
  const auto r = std::from_chars(first, token.data() + token.size(), out);
  if (r.ptr != token.data() + token.size()) return std::errc::invalid_argument;
  return r.ec;
}
template <class T>
bool parse_number(std::string_view token, T& out) {
  return read_number(token, out) == std::errc();
}

std::string shortest_text(double v) {
  char buf[32];
  return std::string(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
}

/// A coordinate as T, or InputError: "not a number", or out of T's range (float: --precision double reads it).
template <class T>
T coordinate(std::string_view token, const std::string& path, const std::string& where) {
  T v = 0;
  const std::errc ec = read_number(token, v);
  if (ec == std::errc()) return v;
  if (ec == std::errc::result_out_of_range)
    throw InputError(path,
                     "number out of the range of " + std::string(std::is_same_v<T, float> ? "float" : "double") + ": " +
                         shown(token) + (std::is_same_v<T, float> ? " (--precision double reads it)" : ""),
                     where);
  throw InputError(path, "not a number: " + shown(token), where);
}

/// A ByteSource read through a buffer: whole lines (text formats) or bytes (binary PLY), counting what was
/// consumed so that header counts can be checked against what remains.
class Reader {
 public:
  static constexpr std::size_t kChunk = std::size_t(1) << 20;
  static constexpr std::size_t kMaxLine = std::size_t(64) << 20;

  // The buffer holds the whole input when it is small (no larger than need be: the fuzz targets read many).
  Reader(ByteSource& source, const std::string& path)
      : src_(source), path_(path), buf_(std::min(kChunk, source.size() + 1)) {}

  /// The next line without its '\n' (the last one also without); false at the end. Valid until the next call.
  bool line(std::string_view& out) {
    for (std::size_t scanned = begin_;;) {
      const void* nl = std::memchr(buf_.data() + scanned, '\n', end_ - scanned);
      if (nl != nullptr || (eof_ && begin_ < end_)) {
        const std::size_t stop = nl ? std::size_t(static_cast<const char*>(nl) - buf_.data()) : end_;
        out = std::string_view(buf_.data() + begin_, stop - begin_);
        const std::size_t next = nl ? stop + 1 : stop;
        consumed_ += next - begin_;
        begin_ = next;
        return true;
      }
      if (eof_) return false;
      scanned = end_ - begin_;  // offsets move to the front in fill()
      fill();
    }
  }
  /// The next `n` bytes; false if the input ends first.
  bool bytes(char* dst, std::size_t n) {
    while (n > 0) {
      if (begin_ == end_) {
        if (eof_) return false;
        fill();
        continue;
      }
      const std::size_t k = std::min(n, end_ - begin_);
      std::memcpy(dst, buf_.data() + begin_, k);
      begin_ += k, consumed_ += k, dst += k, n -= k;
    }
    return true;
  }
  /// Whether the input starts with `prefix`; if so, it is consumed. Only before anything else is read.
  bool skip_prefix(std::string_view prefix) {
    while (end_ - begin_ < prefix.size() && !eof_) fill();
    if (std::string_view(buf_.data() + begin_, end_ - begin_).substr(0, prefix.size()) != prefix) return false;
    begin_ += prefix.size();
    consumed_ += prefix.size();
    return true;
  }
  bool at_end() {
    if (begin_ == end_ && !eof_) fill();
    return begin_ == end_;
  }
  std::size_t remaining() const { return src_.size() - consumed_; }

 private:
  void fill() {
    if (begin_ > 0) {
      std::memmove(buf_.data(), buf_.data() + begin_, end_ - begin_);
      end_ -= begin_;
      begin_ = 0;
    }
    if (end_ == buf_.size()) {  // one line fills the buffer
      if (buf_.size() >= kMaxLine)
        throw InputError(path_, "a line longer than " + std::to_string(kMaxLine >> 20) + " MiB");
      buf_.resize(buf_.size() * 2);
    }
    const std::size_t want = buf_.size() - end_;
    const std::size_t got = src_.read(buf_.data() + end_, want);
    end_ += got;
    eof_ = got < want;
  }

  ByteSource& src_;
  const std::string& path_;
  std::vector<char> buf_;
  std::size_t begin_ = 0, end_ = 0, consumed_ = 0;
  bool eof_ = false;
};

/// The blank-separated tokens of a line.
void split(std::string_view line, std::vector<std::string_view>& tokens) {
  constexpr const char* blanks = " \t\r\f\v";
  tokens.clear();
  std::size_t i = 0;
  while ((i = line.find_first_not_of(blanks, i)) != std::string_view::npos) {
    const std::size_t j = std::min(line.find_first_of(blanks, i), line.size());
    tokens.push_back(line.substr(i, j - i));
    i = j;
  }
}

/// Lines of a text, with their numbers; tokens split on blanks, a '#' starts a comment.
class Lines {
 public:
  explicit Lines(Reader& reader, std::size_t first_line = 1) : reader_(reader), line_(first_line - 1) {}
  /// The tokens of the next line (empty for a blank or comment line); false at the end of the text.
  bool next(std::vector<std::string_view>& tokens) {
    std::string_view l;
    if (!reader_.line(l)) return false;
    ++line_;
    if (const auto hash = l.find('#'); hash != std::string_view::npos) l = l.substr(0, hash);
    split(l, tokens);
    return true;
  }
  /// The next line that has tokens; false at the end.
  bool next_content(std::vector<std::string_view>& tokens) {
    while (next(tokens))
      if (!tokens.empty()) return true;
    return false;
  }
  std::size_t line() const { return line_; }

 private:
  Reader& reader_;
  std::size_t line_;
};

/// The blocks' contents as one array; the blocks are freed.
template <class T>
std::vector<T> to_vector(std::deque<T>& blocks) {
  std::vector<T> v;
  v.reserve(blocks.size());
  v.assign(blocks.begin(), blocks.end());
  std::deque<T>().swap(blocks);  // free the blocks now
  return v;
}

template <class T>
bool finite3(const T* c) {
  return std::isfinite(c[0]) && std::isfinite(c[1]) && std::isfinite(c[2]);
}

std::string non_finite(std::size_t vertex) {
  return "vertex " + std::to_string(vertex) + " has a non-finite coordinate";
}

/// Refuses a count that the rest of the file cannot hold (`min_bytes` per item), before allocating for it.
void check_count(std::uint64_t count, std::size_t min_bytes, std::size_t remaining, const std::string& what,
                 const std::string& path, const std::string& where) {
  if (count > std::numeric_limits<std::uint32_t>::max() || count * min_bytes > remaining)
    throw InputError(path,
                     "the header promises " + std::to_string(count) + " " + what + ", but only " +
                         std::to_string(remaining) + " bytes follow (at least " + std::to_string(min_bytes) +
                         " per item)",
                     where);
}

std::string out_of_range(std::size_t face, std::int64_t v, std::uint64_t nv) {
  return "face " + std::to_string(face) + " refers to vertex " + std::to_string(v) + ", but there are only " +
         std::to_string(nv) + " vertices (0 to " + std::to_string(std::int64_t(nv) - 1) + ")";
}

// ---- OBJ ---------------------------------------------------------------------------------------------------

template <class T>
BasicMesh<T> read_obj(Reader& reader, const std::string& path) {
  BasicMesh<T> mesh;
  std::deque<T> coords;
  std::deque<std::uint32_t> corners, face_start{0};  // corners 0-based; relative (negative) ones resolved
  std::uint64_t max_corner = 0;                      // the largest 1-based index, checked at the end
  std::size_t max_corner_line = 0;
  std::vector<std::string_view> t;
  Lines lines(reader);
  while (lines.next(t)) {
    if (t.empty()) continue;
    const std::string_view key = t[0];
    if (key == "v") {
      const std::size_t n = t.size() - 1;
      if (n != 3 && n != 4 && n != 6)
        throw InputError(
            path, "a vertex needs 3 coordinates (x y z, optionally w, or x y z r g b), found " + std::to_string(n),
            at_line(lines.line()));
      T c[6];
      for (std::size_t k = 0; k < n; ++k) c[k] = coordinate<T>(t[k + 1], path, at_line(lines.line()));
      if (n == 4) {
        if (c[3] == 0) throw InputError(path, "vertex with w = 0", at_line(lines.line()));
        for (int k = 0; k < 3; ++k) c[k] /= c[3];
      }
      if (!finite3(c)) throw InputError(path, non_finite(coords.size() / 3), at_line(lines.line()));
      coords.insert(coords.end(), c, c + 3);
    } else if (key == "f") {
      if (t.size() < 4)
        throw InputError(path, "a face needs at least 3 vertices, found " + std::to_string(t.size() - 1),
                         at_line(lines.line()));
      const auto defined = std::int64_t(coords.size() / 3);
      for (std::size_t k = 1; k < t.size(); ++k) {
        // v, v/vt, v//vn or v/vt/vn: every part an integer (texture and normal indices are not used).
        const std::string_view corner = t[k];
        std::size_t slash = corner.find('/');
        std::int64_t v = 0;
        if (!parse_number(corner.substr(0, slash), v) || v == 0)
          throw InputError(path, "not a vertex index: " + shown(corner), at_line(lines.line()));
        while (slash != std::string_view::npos) {
          const std::size_t next = corner.find('/', slash + 1);
          const std::string_view part =
              corner.substr(slash + 1, next == std::string_view::npos ? next : next - slash - 1);
          std::int64_t unused = 0;
          if (!(part.empty() && next != std::string_view::npos && slash + 1 == next) && !part.empty() &&
              !parse_number(part, unused))
            throw InputError(path, "not an index: " + shown(corner), at_line(lines.line()));
          slash = next;
        }
        if (v < 0) {  // relative to the vertices defined so far
          if (-v > defined)
            throw InputError(path, "vertex index " + std::to_string(v) + " refers before the first vertex",
                             at_line(lines.line()));
          v = defined + v + 1;
        }
        if (std::uint64_t(v) > std::numeric_limits<std::uint32_t>::max())
          throw InputError(path, "vertex index " + std::to_string(v) + " is out of range", at_line(lines.line()));
        if (std::uint64_t(v) > max_corner) max_corner = std::uint64_t(v), max_corner_line = lines.line();
        corners.push_back(std::uint32_t(v - 1));
      }
      face_start.push_back(std::uint32_t(corners.size()));
    } else if (key == "l" || key == "p") {
      ++mesh.dropped_primitives;
    } else if (key == "vt" || key == "vn" || key == "vp" || key == "o" || key == "g" || key == "s" || key == "usemtl" ||
               key == "mtllib") {
      // Texture coordinates, normals, names, groups, smoothing and materials: not used.
    } else {
      throw InputError(path, "unsupported OBJ statement " + shown(key), at_line(lines.line()));
    }
  }
  const std::size_t n = coords.size() / 3;
  if (n == 0) throw InputError(path, "no vertices");
  if (n > std::numeric_limits<std::uint32_t>::max()) throw InputError(path, "too many vertices");
  // Indices may refer to vertices defined later in the file: checked once all are known.
  if (max_corner > n)
    throw InputError(
        path, "vertex index " + std::to_string(max_corner) + " is out of range (" + std::to_string(n) + " vertices)",
        at_line(max_corner_line));
  mesh.vertices.resize(Eigen::Index(n), 3);
  std::copy(coords.begin(), coords.end(), mesh.vertices.data());
  std::deque<T>().swap(coords);
  mesh.face_indices = to_vector(corners);
  mesh.face_start = to_vector(face_start);
  return mesh;
}

// ---- OFF ---------------------------------------------------------------------------------------------------

template <class T>
BasicMesh<T> read_off(Reader& reader, const std::string& path) {
  std::vector<std::string_view> t;
  Lines lines(reader);
  if (!lines.next_content(t) || t[0] != "OFF")
    throw InputError(path, "malformed OFF: the first line is not 'OFF'", at_line(lines.line()));
  std::vector<std::string_view> counts(t.begin() + 1, t.end());  // "OFF nv nf ne" on one line is allowed
  if (counts.empty()) {
    if (!lines.next_content(t)) throw InputError(path, "malformed OFF: no vertex and face counts");
    counts = t;
  }
  std::uint64_t nv = 0, nf = 0, ne = 0;
  if (counts.size() != 3 || !parse_number(counts[0], nv) || !parse_number(counts[1], nf) ||
      !parse_number(counts[2], ne))
    throw InputError(path, "malformed OFF: expected 'vertices faces edges' counts", at_line(lines.line()));
  // Each vertex line needs at least "0 0 0\n", each face line "3 0 0 0\n".
  check_count(nv, 6, reader.remaining(), "vertices", path, at_line(lines.line()));
  check_count(nf, 8, reader.remaining(), "faces", path, at_line(lines.line()));
  if (nv * 6 + nf * 8 > reader.remaining())
    throw InputError(path,
                     "the header promises " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
                         " faces, but only " + std::to_string(reader.remaining()) + " bytes follow",
                     at_line(lines.line()));
  BasicMesh<T> mesh;
  mesh.vertices.resize(Eigen::Index(nv), 3);
  for (std::uint64_t i = 0; i < nv; ++i) {
    if (!lines.next_content(t))
      throw InputError(path, "malformed OFF: truncated in vertex " + std::to_string(i) + " of " + std::to_string(nv));
    T c[3];
    if (t.size() != 3)
      throw InputError(path, "a vertex needs 3 coordinates, found " + std::to_string(t.size()), at_line(lines.line()));
    for (int k = 0; k < 3; ++k) c[k] = coordinate<T>(t[std::size_t(k)], path, at_line(lines.line()));
    if (!finite3(c)) throw InputError(path, non_finite(i), at_line(lines.line()));
    mesh.vertices.row(Eigen::Index(i)) << c[0], c[1], c[2];
  }
  std::deque<std::uint32_t> corners;
  mesh.face_start.reserve(std::size_t(nf) + 1);
  for (std::uint64_t f = 0; f < nf; ++f) {
    if (!lines.next_content(t))
      throw InputError(path, "malformed OFF: truncated in face " + std::to_string(f) + " of " + std::to_string(nf));
    std::uint64_t k = 0;
    if (!parse_number(t[0], k) || k < 3)
      throw InputError(path,
                       "face " + std::to_string(f) + ": expected a vertex count of at least 3, found " + shown(t[0]),
                       at_line(lines.line()));
    // k indices, then optionally a colour (3 or 4 numbers).
    const std::size_t extra = t.size() - 1 >= k ? t.size() - 1 - k : std::size_t(-1);
    if (extra != 0 && extra != 3 && extra != 4)
      throw InputError(path,
                       "face " + std::to_string(f) + " promises " + std::to_string(k) + " vertices but has " +
                           std::to_string(t.size() - 1) + " numbers",
                       at_line(lines.line()));
    for (std::uint64_t j = 0; j < k; ++j) {
      std::int64_t v = 0;
      const std::string_view tok = t[std::size_t(j + 1)];
      if (!parse_number(tok, v))
        throw InputError(path, "face " + std::to_string(f) + ": not an index: " + shown(tok), at_line(lines.line()));
      if (v < 0 || std::uint64_t(v) >= nv) throw InputError(path, out_of_range(f, v, nv), at_line(lines.line()));
      corners.push_back(std::uint32_t(v));
    }
    for (std::size_t j = std::size_t(k) + 1; j < t.size(); ++j) coordinate<T>(t[j], path, at_line(lines.line()));
    mesh.face_start.push_back(std::uint32_t(corners.size()));
  }
  if (lines.next_content(t)) throw InputError(path, "malformed OFF: data after the last face", at_line(lines.line()));
  if (nv == 0) throw InputError(path, "no vertices");
  mesh.face_indices = to_vector(corners);
  return mesh;
}

// ---- PLY ---------------------------------------------------------------------------------------------------

enum class Scalar { i8, u8, i16, u16, i32, u32, f32, f64 };

std::size_t size_of(Scalar s) {
  switch (s) {
    case Scalar::i8:
    case Scalar::u8:
      return 1;
    case Scalar::i16:
    case Scalar::u16:
      return 2;
    case Scalar::i32:
    case Scalar::u32:
    case Scalar::f32:
      return 4;
    case Scalar::f64:
      return 8;
  }
  return 0;
}

bool scalar_type(std::string_view t, Scalar& s) {
  if (t == "char" || t == "int8")
    s = Scalar::i8;
  else if (t == "uchar" || t == "uint8")
    s = Scalar::u8;
  else if (t == "short" || t == "int16")
    s = Scalar::i16;
  else if (t == "ushort" || t == "uint16")
    s = Scalar::u16;
  else if (t == "int" || t == "int32")
    s = Scalar::i32;
  else if (t == "uint" || t == "uint32")
    s = Scalar::u32;
  else if (t == "float" || t == "float32")
    s = Scalar::f32;
  else if (t == "double" || t == "float64")
    s = Scalar::f64;
  else
    return false;
  return true;
}

struct PlyProperty {
  std::string name;
  Scalar type = Scalar::f32;
  bool list = false;
  Scalar count_type = Scalar::u8;
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
  std::size_t min_bytes(bool binary) const {  // the smallest an item can be in the body
    std::size_t b = 0;
    for (const auto& p : properties) b += binary ? (p.list ? size_of(p.count_type) : size_of(p.type)) : 2;
    return b;
  }
};

bool is_integer(Scalar s) { return s != Scalar::f32 && s != Scalar::f64; }

/// Whether the integer v is a value of type s (an ASCII body may write anything).
bool fits(Scalar s, std::int64_t v) {
  switch (s) {
    case Scalar::i8:
      return v >= -128 && v <= 127;
    case Scalar::u8:
      return v >= 0 && v <= 255;
    case Scalar::i16:
      return v >= -32768 && v <= 32767;
    case Scalar::u16:
      return v >= 0 && v <= 65535;
    case Scalar::i32:
      return v >= std::numeric_limits<std::int32_t>::min() && v <= std::numeric_limits<std::int32_t>::max();
    case Scalar::u32:
      return v >= 0 && v <= std::int64_t(std::numeric_limits<std::uint32_t>::max());
    default:
      return true;
  }
}

/// One value of type s from a binary body in either byte order; false if the body ends first. Integer types
/// give exact doubles; float is widened exactly.
bool read_binary(Reader& reader, Scalar s, bool big_endian, double& out) {
  const std::size_t n = size_of(s);
  unsigned char raw[8];
  if (!reader.bytes(reinterpret_cast<char*>(raw), n)) return false;
  if (big_endian != (std::endian::native == std::endian::big)) std::reverse(raw, raw + n);
  switch (s) {
    case Scalar::i8:
      out = double(std::int8_t(raw[0]));
      break;
    case Scalar::u8:
      out = double(raw[0]);
      break;
    case Scalar::i16: {
      std::int16_t v;
      std::memcpy(&v, raw, 2);
      out = v;
      break;
    }
    case Scalar::u16: {
      std::uint16_t v;
      std::memcpy(&v, raw, 2);
      out = v;
      break;
    }
    case Scalar::i32: {
      std::int32_t v;
      std::memcpy(&v, raw, 4);
      out = v;
      break;
    }
    case Scalar::u32: {
      std::uint32_t v;
      std::memcpy(&v, raw, 4);
      out = v;
      break;
    }
    case Scalar::f32: {
      float v;
      std::memcpy(&v, raw, 4);
      out = v;
      break;
    }
    case Scalar::f64: {
      double v;
      std::memcpy(&v, raw, 8);
      out = v;
      break;
    }
  }
  return true;
}

template <class T>
BasicMesh<T> read_ply(Reader& reader, const std::string& path) {
  auto malformed = [&](const std::string& why, std::size_t line = 0) -> InputError {
    return InputError(path, "malformed PLY: " + why, line ? at_line(line) : std::string());
  };
  // Header.
  std::size_t line_no = 0;
  std::vector<std::string_view> t;
  auto header_line = [&]() {
    std::string_view l;
    if (!reader.line(l)) throw malformed("the header has no end_header line");
    ++line_no;
    split(l, t);  // no comments here: '#' is a character like any other in a PLY header
  };
  if (reader.skip_prefix(kBom))
    throw malformed("the file starts with a UTF-8 byte-order mark; the first line must be 'ply' (remove the mark)", 1);
  header_line();
  if (t.size() != 1 || t[0] != "ply") throw malformed("the first line is not 'ply'", 1);
  std::string format;
  std::vector<PlyElement> elements;
  for (;;) {
    header_line();
    if (t.empty() || t[0] == "comment" || t[0] == "obj_info") continue;
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
    } else if (t[0] == "property") {
      if (elements.empty()) throw malformed("a property before any element", line_no);
      PlyProperty p;
      if (t.size() == 5 && t[1] == "list") {
        p.list = true;
        if (!scalar_type(t[2], p.count_type) || !scalar_type(t[3], p.type) || !is_integer(p.count_type))
          throw malformed("bad list property types", line_no);
        p.name = std::string(t[4]);
      } else if (t.size() == 3 && scalar_type(t[1], p.type)) {
        p.name = std::string(t[2]);
      } else {
        throw malformed("expected 'property TYPE NAME' or 'property list COUNT_TYPE TYPE NAME'", line_no);
      }
      for (const auto& other : elements.back().properties)
        if (other.name == p.name) throw malformed("property " + shown(p.name) + " declared twice", line_no);
      elements.back().properties.push_back(p);
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
  int vertex_element = -1, face_element = -1;
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
    check_count(el.count, el.min_bytes(binary), body, el.name + " elements", path, "header");
    min_total += std::size_t(el.count) * el.min_bytes(binary);
  }
  if (min_total > body)
    throw InputError(path,
                     "the header's elements need at least " + std::to_string(min_total) + " bytes, but only " +
                         std::to_string(body) + " follow",
                     "header");

  BasicMesh<T> mesh;
  const auto& vertex_properties = elements[std::size_t(vertex_element)].properties;
  mesh.stored_type = CoordinateType::float32;
  for (int c = 0; c < 3; ++c)
    if (vertex_properties[std::size_t(xyz[c])].type == Scalar::f64) mesh.stored_type = CoordinateType::float64;
  const std::uint64_t nv = elements[std::size_t(vertex_element)].count;
  mesh.vertices.resize(Eigen::Index(nv), 3);
  if (face_element >= 0) mesh.face_start.reserve(std::size_t(elements[std::size_t(face_element)].count) + 1);
  std::deque<std::uint32_t> corners;
  Lines ascii(reader, line_no + 1);
  std::vector<double> values;
  for (std::size_t e = 0; e < elements.size(); ++e) {
    const auto& el = elements[e];
    for (std::uint64_t i = 0; i < el.count; ++i) {
      // Built only for a message: most elements are fine.
      auto item = [&] { return el.name + " " + std::to_string(i); };
      // Binary messages name the element and index themselves; ASCII ones get the line too.
      auto where = [&] { return binary ? std::string() : at_line(ascii.line()); };
      auto truncated = [&] {
        return malformed("truncated in " + el.name + " " + std::to_string(i) + " of " + std::to_string(el.count));
      };
      // Each property's values, lists flattened after their count.
      values.clear();
      std::size_t list_begin = 0, list_size = 0;
      if (binary) {
        for (std::size_t k = 0; k < el.properties.size(); ++k) {
          const auto& p = el.properties[k];
          double v = 0;
          if (!p.list) {
            if (!read_binary(reader, p.type, big_endian, v)) throw truncated();
            values.push_back(v);
            continue;
          }
          if (!read_binary(reader, p.count_type, big_endian, v)) throw truncated();
          if (v < 0) throw malformed("negative list length in " + item());
          const auto n = std::uint64_t(v);
          if (n * size_of(p.type) > reader.remaining()) throw truncated();
          if (int(k) == indices) list_begin = values.size(), list_size = std::size_t(n);
          for (std::uint64_t j = 0; j < n; ++j) {
            if (!read_binary(reader, p.type, big_endian, v)) throw truncated();
            values.push_back(v);
          }
        }
      } else {
        if (!ascii.next_content(t)) throw truncated();
        std::size_t tok = 0;
        auto take = [&](Scalar s) {
          if (tok >= t.size()) throw InputError(path, "too few values for " + item(), where());
          double v = 0;
          std::errc ec;
          if (is_integer(s)) {
            std::int64_t n = 0;
            ec = read_number(t[tok], n);
            if (ec == std::errc() && !fits(s, n)) ec = std::errc::result_out_of_range;
            v = double(n);
          } else if (s == Scalar::f32) {
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
  return mesh;
}

}  // namespace

std::string readable_formats() {
  return "obj, off, ply (ASCII or binary), and each gzip-compressed (.obj.gz, .off.gz, .ply.gz)";
}

template <class T>
BasicMesh<T> read_mesh(const std::string& path, std::size_t max_bytes) {
  const std::string ext = format_extension(path);
  if (ext != "obj" && ext != "off" && ext != "ply")
    throw InputError(path, "unknown mesh format" + (ext.empty() ? std::string() : " " + shown("." + ext)) +
                               " (readable: " + readable_formats() + ")");
  const auto source = open_input(path, max_bytes);
  return parse_mesh<T>(*source, ext, path);
}

template <class T>
BasicMesh<T> parse_mesh(ByteSource& source, const std::string& format, const std::string& path) {
  if (source.size() == 0) throw InputError(path, "empty file");
  Reader reader(source, path);
  if (format == "ply") return read_ply<T>(reader, path);
  // Text a Windows editor saved may start with a byte-order mark: skipped (it is no statement of OBJ or OFF).
  const bool bom = reader.skip_prefix(kBom);
  if (bom && reader.at_end()) throw InputError(path, "empty file (only a UTF-8 byte-order mark)");
  if (format == "obj") return read_obj<T>(reader, path);
  if (format == "off") return read_off<T>(reader, path);
  throw std::invalid_argument("parse_mesh: unknown format '" + format + "'");
}

template BasicMesh<float> read_mesh<float>(const std::string&, std::size_t);
template BasicMesh<double> read_mesh<double>(const std::string&, std::size_t);
template BasicMesh<float> parse_mesh<float>(ByteSource&, const std::string&, const std::string&);
template BasicMesh<double> parse_mesh<double>(ByteSource&, const std::string&, const std::string&);

}  // namespace mlsdeform::cli
