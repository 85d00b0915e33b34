// mlsdeform files: what a mesh file carries besides the positions and faces that the deformation uses, kept by
// the readers so that the writers give it back: every PLY element and property with its type and order, OBJ's
// other statements (texture coordinates, normals, materials, groups, vertex colours) in their order, OFF's
// colours. Values are kept exactly (PLY: in the file's types; text: the file's own tokens), so that a file
// read and written again holds the same values bit for bit. Normals are transformed by each vertex's linear
// part (attributes.cpp, transform_normals); the rest is passed through.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace mlsdeform::files {

/// A PLY property's type.
enum class PlyScalar : std::uint8_t { i8, u8, i16, u16, i32, u32, f32, f64 };
std::size_t size_of(PlyScalar s);
/// The type's name as written in headers ("char", "uchar", ..., "float", "double": PLY's original names).
std::string_view type_name(PlyScalar s);
/// Reads PLY's names, both the original ("uchar") and the sized ones ("uint8"); false for anything else.
bool parse_scalar(std::string_view name, PlyScalar& s);
inline bool is_integer(PlyScalar s) { return s != PlyScalar::f32 && s != PlyScalar::f64; }
/// A value of type s stored at `p` in the machine's byte order, as a double (exact for every PLY type).
double ply_load(PlyScalar s, const unsigned char* p);
/// Stores `v` at `p` as type s (see PlyElement::set).
void ply_store(PlyScalar s, double v, unsigned char* p);

struct PlyProperty {
  std::string name;
  PlyScalar type = PlyScalar::f32;  ///< a list's value type
  bool list = false;
  PlyScalar count_type = PlyScalar::u8;
};

/// One element of a PLY file: its declaration and every item's values, in the file's types and the machine's
/// byte order, item after item, each property's value in declaration order (a list: its count, then its
/// values). This is the accessor for a property by name and type: find(), properties[k].type, get(), set().
struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
  std::vector<unsigned char> data;

  bool has_lists() const;
  /// The index of the property called `name`, or -1.
  int find(std::string_view property) const;
  /// For an element without list properties (the vertex element: the reader refuses lists there): the bytes of
  /// one item, and where property k starts in it.
  std::size_t stride() const;
  std::size_t offset(std::size_t k) const;
  /// Property k of item i as a double (exact for every PLY type); an element without lists.
  double get(std::size_t i, std::size_t k) const;
  /// Sets property k of item i to `v`, converted to the property's type (rounded once to float; an integer
  /// type takes the nearest integer, clamped to its range); an element without lists.
  void set(std::size_t i, std::size_t k, double v);
};

/// A PLY file's layout and data as read. The vertex element's x, y, z are written from the mesh's vertices
/// (in the output's coordinate type) and the face element as read (its vertex_indices are the mesh's faces).
struct PlyLayout {
  /// comment and obj_info lines, verbatim, each after `after` element and property lines of the header.
  struct HeaderLine {
    std::size_t after;
    std::string text;
  };
  std::vector<HeaderLine> header;
  std::vector<PlyElement> elements;
  int vertex_element = -1, face_element = -1;
  std::string format;  ///< as read: "ascii", "binary_little_endian" or "binary_big_endian"

  const PlyElement& vertices() const { return elements[std::size_t(vertex_element)]; }
  PlyElement& vertices() { return elements[std::size_t(vertex_element)]; }
};

/// One short text per item (vertex or face), most of them often empty; nothing stored while all are empty.
struct TextColumn {
  std::string text;
  std::vector<std::uint64_t> end;  ///< end[i]: where item i's text ends; empty while every text is empty
  /// Item i's text; items are set in increasing order, each at most once.
  void set(std::size_t i, std::string_view s) {
    if (s.empty()) return;
    end.resize(i, text.size());
    text.append(s);
    end.push_back(text.size());
  }
  /// After the last set(): every one of `n` items has an entry (when any is non-empty).
  void finish(std::size_t n) {
    if (!end.empty()) end.resize(n, text.size());
  }
  bool empty() const { return end.empty(); }
  std::size_t non_empty() const;
  std::string_view operator[](std::size_t i) const {
    if (end.empty()) return {};
    const std::size_t b = i ? std::size_t(end[i - 1]) : 0;
    return std::string_view(text).substr(b, std::size_t(end[i]) - b);
  }
};

/// An OBJ file's statements other than the vertex positions, in order.
struct ObjExtras {
  /// Every line that is not a `v` statement, verbatim (comments and blank lines too), each ending in '\n'.
  std::string text;
  /// The order of the file: runs of `v` statements (is_vertex, their count) and of lines of `text`.
  struct Run {
    bool vertices;
    std::uint64_t count;
  };
  std::vector<Run> runs;
  /// What follows x y z (or x y z w) on each `v` line: vertex colours ("r g b"), a comment.
  TextColumn vertex_tails;
  /// The `vn` statements' values (3 per normal) and, per face corner in face order, the 0-based `vn` it
  /// names (kNone: none); empty when no corner names one.
  static constexpr std::uint32_t kNone = 0xffffffffu;
  std::vector<double> normals;
  std::vector<std::uint32_t> corner_normals;
  std::uint64_t texture_coordinates = 0, normal_lines = 0, other_lines = 0;  ///< counts for the summary
  /// Set when `normals` and `corner_normals` were replaced (transformed or computed): the writer then writes
  /// `normals` as one block of `vn` in place of the file's and rewrites each corner's normal index.
  bool normals_rewritten = false;
  /// With normals_rewritten, per normal of `normals`: the file's `vn` (0-based) that it repeats unchanged
  /// (its vertex's frame is exactly the identity), which the writer writes as the file's own line, so that
  /// its text is as read; kNone for a transformed one. Empty: none repeats one.
  std::vector<std::uint32_t> normal_sources;
};

/// OFF's optional colours after a vertex's coordinates or a face's indices, verbatim.
struct OffExtras {
  TextColumn vertex_tails, face_tails;
  std::string keyword = "OFF";  ///< "OFF", or "COFF" (vertices carry colours)
  std::uint64_t comments = 0;   ///< comment lines, not kept
};

/// Everything a file carried besides positions and faces (at most one of the three, the file's format).
struct MeshExtras {
  std::optional<PlyLayout> ply;
  std::optional<ObjExtras> obj;
  std::optional<OffExtras> off;
  bool empty() const { return !ply && !obj && !off; }
  /// Whether the input has normals: PLY nx, ny, nz (float or double) or OBJ vn named by faces.
  bool has_normals() const;
};

/// The indices of the vertex element's nx, ny, nz when all three are float or double properties, else none.
std::optional<std::array<std::size_t, 3>> ply_normals(const PlyLayout& ply);

}  // namespace mlsdeform::files
