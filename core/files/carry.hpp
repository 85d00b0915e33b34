// mlsdeform files: a mesh's attributes carried through each vertex's frame (FramesOut) into a deformed copy:
// the one place where a deformation's positions, normals and splats meet, for DeformJob (job_frames.cpp) and the
// Python module's mesh object (python/src/bind_files.cpp).
#pragma once

#include "core/files/mesh.hpp"
#include "core/files/splats.hpp"

#include <optional>
#include <string>

namespace mlsdeform::files {

/// What carrying a mesh's attributes needs of each vertex's frame (the FramesOut arrays the deformer fills).
struct CarryPlan {
  bool normals = false;               ///< the input's normals, transformed by L^-T (needs linear)
  std::optional<SplatLayout> splats;  ///< a splat file's splats (needs quaternions, or linear for affine fits)
  bool affine = false;                ///< splats mapped by the affine fit's linear part, not turned
  bool scales = false;                ///< splats grown by the similarity fit's scale
  bool needs_linear() const { return normals || (splats && affine); }
  bool needs_quaternions() const { return splats && !affine; }
};

/// The plan for `rest` deformed by `transform`: normals carried when `transform_normals` (the output keeps them
/// and they are not computed anew), splats whenever the file is a splat file. Throws InputError naming `path`
/// for a splat file that is one only in part (splat_layout).
template <class T>
CarryPlan carry_plan(const BasicMesh<T>& rest, Transform transform, bool transform_normals, const std::string& path);

/// Per-vertex frames, n rows each, as FramesOut fills them; null where the plan does not need them.
template <class T>
struct VertexFrames {
  const T* linear = nullptr;       ///< n x 9, row-major L
  const T* quaternions = nullptr;  ///< n x 4, w x y z
  const T* scales = nullptr;       ///< n
};

/// `result` := `rest` with `positions` (n x 3) and the attributes of the plan carried through `frames` (the
/// others as read, bit for bit). `result` may hold an earlier frame of the same rest mesh (its buffers are
/// reused). Throws InputError naming `path` for what the frames cannot carry (a splat value its property's type
/// cannot hold, a singular affine part) and std::invalid_argument for a position that is not finite or a frame
/// array the plan needs but that is null.
template <class T>
void carry_frame(const BasicMesh<T>& rest, BasicMesh<T>& result, const PointsRowMajor<T>& positions,
                 const CarryPlan& plan, const VertexFrames<T>& frames, int threads, const std::string& path);

/// Throws InputError naming `path` (and `where`, a JSON path or empty) when a vertex of `mesh` overflows the
/// coordinate type it is written as (a double mesh written as float: WriteOptions::coordinates).
template <class T>
void check_fits_output(const BasicMesh<T>& mesh, const WriteOptions& write, const std::string& path,
                       const std::string& where);

}  // namespace mlsdeform::files
