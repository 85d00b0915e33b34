// mlsdeform files: a polygon mesh as read from and written to files.
#pragma once

#include "core/files/attributes.hpp"
#include "core/files/file_io.hpp"

#include <mlsdeform/files.hpp>

#include <mlsdeform/arap.hpp>
#include <mlsdeform/types.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace mlsdeform::files {

/// Vertices in the file's own order (so that a handles file can name them by index) and polygon faces kept
/// as they are (no triangulation). Coordinates are read as T: float (`--precision float`, and every scene of
/// the demo and figures) or double (`--precision double`: decimal text read to the double nearest it).
template <class T>
struct BasicMesh {
  PointsRowMajor<T> vertices;                ///< n x 3
  std::vector<std::uint32_t> face_start{0};  ///< face f is face_indices[face_start[f] .. face_start[f+1])
  std::vector<std::uint32_t> face_indices;
  std::size_t dropped_primitives = 0;  ///< OBJ points and lines (kept in ObjExtras, for OBJ output only)
  /// The type that holds the file's x, y, z values exactly, for a PLY file (float64 if any is double, int or
  /// uint; float32 if all are float or integers of 8 or 16 bits); none for text
  /// formats and meshes built in memory. Chooses the type of a PLY output (WriteOptions::coordinates).
  std::optional<CoordinateType> stored_type;
  /// What the file carried besides positions and faces (attributes.hpp), given back by the writer of the same
  /// format; empty for a mesh built in memory. A writer trusts it to match `vertices` and the faces in number.
  MeshExtras extras;

  Eigen::Index vertex_count() const { return vertices.rows(); }
  std::size_t face_count() const { return face_start.size() - 1; }
  void add_face(std::initializer_list<std::uint32_t> f) {
    face_indices.insert(face_indices.end(), f);
    face_start.push_back(std::uint32_t(face_indices.size()));
  }
};
using Mesh = BasicMesh<float>;

/// Area-weighted vertex normals (Newell's polygon normal, so non-planar polygons work too), unit length;
/// a vertex in no face, or only in degenerate ones, gets (0, 0, 0).
template <class T>
PointsRowMajor<T> vertex_normals(const BasicMesh<T>& mesh);

/// Triangles of a fan triangulation of each polygon (for renderers), as vertex index triples.
template <class T>
std::vector<std::uint32_t> triangulate(const BasicMesh<T>& mesh);
/// The same fans as the library's Triangles (m x 3, int), for the surface-ARAP refinement. Throws InputError
/// naming `path` if a vertex index does not fit in an int (more than 2^31 - 1 vertices).
template <class T>
Triangles fan_triangles(const BasicMesh<T>& mesh, const std::string& path);

/// Formats by file name: .obj, .off, .ply (ASCII, binary little- or big-endian), each optionally
/// gzip-compressed (.gz). Read by the strict parsers of core/files/formats/ and written here, with numbers as the
/// shortest decimal text that reads back to the same float or double (std::to_chars / std::from_chars), so
/// that files round-trip bit for bit. Written also: .npy (numpy's format: the positions alone, (n, 3) float32 or
/// float64 by the coordinate type; faces and attributes named as dropped).
///   read: the vertex order is the file's (for OBJ: the order of its `v` lines, counted from 0), every vertex
///   is kept (even one no face uses), faces are polygons as written; OBJ points and lines are dropped. Decimal
///   coordinates are rounded once to T (a PLY property declared float is read as float whatever T: the file
///   says what its values are). OBJ and OFF may start with a UTF-8 byte-order mark, which is skipped; a PLY
///   file must start with the bytes "ply" (its magic number), so one with a mark is refused, saying so.
///   Throws InputError naming the file, the line (or element) and the problem for anything malformed: a
///   missing or unreadable file, an unknown format, a number that is not one whole decimal number or is out of
///   T's range (1e39 in float: the message suggests --precision double), a non-finite coordinate, an index out
///   of range, a face with fewer than 3 vertices, counts in a header that the body does not hold (checked
///   before allocating), data after the last element, no vertices, or a file (or its decompressed data) larger
///   than `max_bytes`.
/// The format read_mesh reads `path` as ("obj", "off" or "ply", by its extension through a ".gz"); throws
/// InputError naming `path` for any other.
std::string mesh_format(const std::string& path);
template <class T = float>
BasicMesh<T> read_mesh(const std::string& path, std::size_t max_bytes = kDefaultMaxInputBytes);
/// read_mesh's parser on any source of bytes (a file, gzip data, memory: see file_io.hpp), for `format` "obj",
/// "off" or "ply"; `path` names the input in errors.
template <class T = float>
BasicMesh<T> parse_mesh(ByteSource& source, const std::string& format, const std::string& path);

struct WriteOptions {
  bool force = false;                      ///< overwrite an existing file
  PlyEncoding ply = PlyEncoding::binary;   ///< for .ply and .ply.gz
  NormalsOut normals = NormalsOut::input;  ///< which vertex normals are written (OFF has no place for any)
  /// The type the coordinates (and normals) are written as: PLY's property type; for OBJ and OFF, the
  /// shortest text of the float or of the double (a double mesh written as float32 is rounded to float).
  /// None: float for a float mesh; for a double mesh, the type its PLY file had (a float PLY stays float),
  /// else double.
  std::optional<CoordinateType> coordinates = std::nullopt;
};

/// The type write_mesh writes `mesh`'s coordinates as, under `options` (WriteOptions::coordinates).
template <class T>
CoordinateType output_type(const BasicMesh<T>& mesh, const WriteOptions& options);

/// The file's bytes for the format of `path`'s extension (compressed if it ends in .gz).
template <class T>
std::string encode_mesh(const BasicMesh<T>& mesh, const std::string& path, const WriteOptions& options = {});
/// encode_mesh, then write_file_atomic: all or nothing.
template <class T>
void write_mesh(const BasicMesh<T>& mesh, const std::string& path, const WriteOptions& options = {});

/// Transforms the input's normals (OBJ vn, PLY nx ny nz) by each vertex's linear part: `linear` holds n
/// row-major 3x3 matrices L (n = the vertex count); a normal becomes L^-T n renormalised, or stays as read,
/// bit for bit, where L is exactly the identity (attributes_ops.cpp: an OBJ vn that corners of vertices with
/// different L share is split, one vn per vertex and vn; one kept as read is written as the file's own line).
template <class T>
void transform_normals(BasicMesh<T>& mesh, const T* linear);

/// What writing `mesh` to `out_path` keeps, transforms and drops of the input's attributes, each a short
/// phrase ("vertex properties red, green, blue", "12 vt"), for the program's summary and its stderr line.
struct AttributeReport {
  std::vector<std::string> kept, transformed, dropped;
};
/// What becomes of the input's normals in the output's format (when they are not replaced by computed ones).
enum class InputNormals { kept, transformed };
template <class T>
AttributeReport attribute_report(const BasicMesh<T>& mesh, const std::string& out_path, NormalsOut normals,
                                 InputNormals fate);

/// Throws InputError naming `path` if its extension is not a format write_mesh knows.
void check_output_format(const std::string& path);
/// "obj, off, ply, ply.gz, ..." for messages and --help.
std::string readable_formats();
std::string writable_formats();

}  // namespace mlsdeform::files
