// Strict mesh readers for OBJ, OFF and PLY (ASCII, binary little- and big-endian), each optionally gzip-
// compressed; one reader per format in core/files/formats/, chosen here by the file's extension. Everything
// malformed is refused with the file, the line (or element and index) and the problem: numbers are parsed
// whole and correctly rounded (std::from_chars: no hex, no "1.5.5"), every index is checked, counts promised
// by a header are checked against the size of the body before anything is allocated, and nothing may follow
// the last element.
#include <mlsdeform/files_error.hpp>
#include "core/files/file_io.hpp"
#include "core/files/formats/reader.hpp"
#include "core/files/mesh.hpp"
#include "core/files/splat_io.hpp"

#include <stdexcept>
#include <string>

namespace mlsdeform::files {

using formats::kBom;
using formats::Reader;
using formats::shown;

std::string readable_formats() {
  return "obj, off, ply (ASCII or binary), and each gzip-compressed (.obj.gz, .off.gz, .ply.gz); Gaussian splats "
         "as 3DGS ply, compressed.ply, spz and splat";
}

std::string mesh_format(const std::string& path) {
  if (files::splat_format(path) != files::SplatFormat::none) return "splat";  // splat_io.hpp
  const std::string ext = format_extension(path);
  if (ext != "obj" && ext != "off" && ext != "ply")
    throw InputError(path, "unknown mesh format" + (ext.empty() ? std::string() : " " + shown("." + ext)) +
                               " (readable: " + readable_formats() + ")");
  return ext;
}

template <class T>
BasicMesh<T> read_mesh(const std::string& path, std::size_t max_bytes) {
  const std::string ext = mesh_format(path);
  if (ext == "splat") return files::read_splat_file<T>(path, files::splat_format(path), max_bytes);
  const auto source = open_input(path, max_bytes);
  if (ext == "ply" && !is_gzip_path(path)) {  // a compressed PLY named plainly .ply is read as what it is
    std::string head(4096, '\0');
    head.resize(source->read(head.data(), head.size()));
    source->rewind();
    if (files::looks_like_compressed_ply(head))
      return files::read_splat_file<T>(path, files::SplatFormat::compressed_ply, max_bytes);
  }
  return parse_mesh<T>(*source, ext, path);
}

template <class T>
BasicMesh<T> parse_mesh(ByteSource& source, const std::string& format, const std::string& path) {
  if (source.size() == 0) throw InputError(path, "empty file");
  if (format == "splat") {  // SPZ, compressed PLY, .splat by the name (splat_io.hpp)
    std::string bytes(source.size(), '\0');
    bytes.resize(source.read(bytes.data(), bytes.size()));
    return files::decode_splat_file<T>(bytes, path, files::splat_format(path), kDefaultMaxInputBytes);
  }
  Reader reader(source, path);
  if (format == "ply") return formats::read_ply<T>(reader, path);
  // Text a Windows editor saved may start with a byte-order mark: skipped (it is no statement of OBJ or OFF).
  const bool bom = reader.skip_prefix(kBom);
  if (bom && reader.at_end()) throw InputError(path, "empty file (only a UTF-8 byte-order mark)");
  if (format == "obj") return formats::read_obj<T>(reader, path);
  if (format == "off") return formats::read_off<T>(reader, path);
  throw std::invalid_argument("parse_mesh: unknown format '" + format + "'");
}

template BasicMesh<float> read_mesh<float>(const std::string&, std::size_t);
template BasicMesh<double> read_mesh<double>(const std::string&, std::size_t);
template BasicMesh<float> parse_mesh<float>(ByteSource&, const std::string&, const std::string&);
template BasicMesh<double> parse_mesh<double>(ByteSource&, const std::string&, const std::string&);

}  // namespace mlsdeform::files
