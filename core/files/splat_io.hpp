// mlsdeform files: the compact splat formats (SPZ, compressed PLY, .splat: formats/splat_codecs.hpp) in the
// mesh pipeline. A file read becomes the same mesh a 3DGS PLY gives (the centres as vertices, a PlyLayout
// vertex element x y z f_dc_0..2 f_rest_* opacity scale_0..2 rot_0..3 of floats), so that the deformation
// turns its splats unchanged; a mesh whose PLY layout is a splat file is written back to SPZ or compressed PLY.
#pragma once

#include "core/files/formats/splat_codecs.hpp"
#include "core/files/mesh.hpp"

#include <string>
#include <vector>

namespace mlsdeform::files {

/// The mesh of a decoded cloud: vertices = centres, extras.ply = the 3DGS vertex element (float).
template <class T>
BasicMesh<T> splat_mesh(const SplatCloud& cloud);

/// The cloud a splat mesh holds: centres from `mesh.vertices` (rounded to float), the rest from its PLY
/// layout (splat_layout, f_dc_0..2, opacity). Throws InputError naming `path` for a mesh that is no splat file
/// or lacks f_dc_0..2 or opacity, and for faces (no splat format holds them).
template <class T>
SplatCloud splat_cloud(const BasicMesh<T>& mesh, const std::string& path);

/// splat_cloud's checks that need no values (a splat file, no faces, the 3DGS properties, SH degree 0-3), for
/// a job to refuse an output it could never write before any work (DeformJob).
template <class T>
void check_splat_output(const BasicMesh<T>& mesh, const std::string& path);

/// read_mesh for a file whose name (or, for `.ply`, whose header) asks for a compact format.
template <class T>
BasicMesh<T> read_splat_file(const std::string& path, SplatFormat format, std::size_t max_bytes);

/// The same on the file's bytes (parse_mesh's "splat" format: the page's files in memory).
template <class T>
BasicMesh<T> decode_splat_file(std::string_view bytes, const std::string& path, SplatFormat format,
                               std::size_t max_bytes);

/// encode_mesh for an output named `.spz` or `.compressed.ply`.
template <class T>
std::string encode_splat_file(const BasicMesh<T>& mesh, const std::string& path, SplatFormat format);

/// What an output in a compact format drops of a splat mesh's PLY layout (vertex properties beyond the 3DGS
/// set, other elements, comments), each a short phrase for the attribute report; empty when nothing is lost.
std::vector<std::string> splat_output_drops(const PlyLayout& ply);

}  // namespace mlsdeform::files
