// mlsdeform/files.hpp: the files library's public API (core/files/; docs/design.md, "The files library").
//
// One deformation of files as `mlsdeform deform` runs it, for every front end: the program (tools/cli/), the
// Python module and mlsdeform.dask (python/src/bind_files.cpp). A DeformJob reads a mesh file (OBJ, OFF, PLY and
// their .gz) and a handles file, checks them and the outputs' names, and builds the deformer; each frame then
// gives the bytes of its output file: the deformed positions, and every attribute of the input kept or carried
// through each vertex's frame (normals; splats' rotations, scales and SH). The front end writes the bytes (all or
// nothing) and says what it likes: the same input, handles file and options give the same bytes everywhere.
//
// The headers beside the sources (core/files/mesh.hpp, attributes.hpp, handles_file.hpp, file_io.hpp) are the
// details that the project's own front ends use as well (the mesh object of the Python module, the page).
#pragma once

#include <mlsdeform/deformer.hpp>
#include <mlsdeform/files_error.hpp>

#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace mlsdeform::files {

/// How a file stores vertex coordinates: PLY names a type; OBJ and OFF write decimal text, which has none.
enum class CoordinateType { float32, float64 };
enum class PlyEncoding { binary, ascii };
/// The vertex normals written: the input's (transformed by each vertex's frame where the output's format is the
/// input's; none where the input has none), or area-weighted ones computed from the faces, replacing the input's.
enum class NormalsOut { input, computed };

/// The largest mesh file read (or its decompressed data), by default.
inline constexpr std::size_t kDefaultMaxInputBytes = std::size_t(1) << 30;

/// "out.ply.gz", frame 7 of 120 -> "out_0007.ply.gz": "_NNNN" before the format extension (through a ".gz"), the
/// number zero-padded to the digits of the largest index, at least 4.
std::string frame_path(const std::string& out, std::size_t frame, std::size_t frame_count);

/// What a DeformJob does beyond the library's Options (the program's options of the same names, docs/cli.md).
struct JobOptions {
  Options options;  ///< transform, weight_exponent, method, storage, threads, ARAP...; region comes from the file
  NormalsOut normals = NormalsOut::input;
  PlyEncoding ply = PlyEncoding::binary;
  /// The output's coordinate type; none: the input's, at most the precision's (WriteOptions::coordinates).
  std::optional<CoordinateType> output_type = std::nullopt;
  bool strict_attributes = false;  ///< refuse (InputError) rather than drop an attribute the output cannot keep
  bool force = false;              ///< outputs that exist may be replaced (else refused before any work)
  std::size_t max_input_bytes = kDefaultMaxInputBytes;
};

/// What a job read and will do, for the front end to report.
struct JobSummary {
  std::size_t vertices = 0, faces = 0;
  std::size_t dropped_primitives = 0;  ///< OBJ points and lines (kept in OBJ output only)
  std::size_t points = 0, segments = 0;
  std::size_t frames = 1;
  bool animated = false;     ///< the handles file has "frames" (outputs named by frame_path)
  std::size_t region = 0;    ///< vertices that may move (0: no region, all of them)
  int splat_sh_degree = -1;  ///< a 3D Gaussian splat file's SH degree (docs/splats.md); -1: no splat file
  /// Of the input's attributes, as short phrases ("vertex properties red, green, blue"): kept as read,
  /// transformed by each vertex's frame, and dropped (the output's format has no place for them; with
  /// strict_attributes the job refuses instead).
  std::vector<std::string> kept, transformed, dropped;
  double setup_ms = 0;  ///< building the deformer
  std::size_t memory_bytes = 0;
};

/// One output's bytes, and the time spent on them.
struct FrameBytes {
  std::string bytes;
  double deform_ms = 0;      ///< Deformer::deform
  double attributes_ms = 0;  ///< the splats carried through the frames (normals are counted in encode_ms)
  double encode_ms = 0;      ///< the attributes carried and the file encoded (compressed for .gz)
};

/// A mesh file, a handles file and an output name, deformed frame by frame as `mlsdeform deform` does, in
/// precision T (float or double: the program's --precision).
template <class T>
class DeformJob {
 public:
  /// Reads and checks the mesh and the handles file, checks every output's name (existing files refused unless
  /// options.force; the format by its extension) and builds the deformer. Throws InputError naming the file and
  /// the problem; writes nothing.
  DeformJob(const std::string& mesh_path, const std::string& handles_path, const std::string& out_path,
            const JobOptions& options = {});
  DeformJob(DeformJob&&) noexcept;
  DeformJob& operator=(DeformJob&&) noexcept;
  ~DeformJob();

  /// One output per frame of the handles file (frame_path), or `out_path` alone for a file without frames.
  const std::vector<std::string>& outputs() const;
  const JobSummary& summary() const;

  /// Output f's bytes. `cancel` is polled between ARAP iterations (Cancelled). Throws InputError for a frame the
  /// deformer refuses (its JSON path named) or a result the output's type cannot hold. Not reentrant: one frame
  /// at a time per job (the deformer's session is reused).
  FrameBytes encode_frame(std::size_t f, const std::function<bool()>& cancel = {});

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

extern template class DeformJob<float>;
extern template class DeformJob<double>;

}  // namespace mlsdeform::files
