// mlsdeform files: a frame's attributes carried through each vertex's frame (carry.hpp). No file system or
// zlib: the page's module carries splats with it too.
#include "core/files/carry.hpp"

#include <stdexcept>

namespace mlsdeform::files {

template <class T>
CarryPlan carry_plan(const BasicMesh<T>& rest, Transform transform, bool transform_normals, const std::string& path) {
  CarryPlan plan;
  plan.normals = transform_normals && rest.extras.has_normals();
  // A 3D Gaussian splat file (docs/splats.md): each splat turns (and grows) by its centre's frame.
  if (rest.extras.ply) plan.splats = splat_layout(*rest.extras.ply, path);
  plan.affine = transform == Transform::affine;
  plan.scales = transform == Transform::similarity;
  return plan;
}

template <class T>
void carry_frame(const BasicMesh<T>& rest, BasicMesh<T>& result, const PointsRowMajor<T>& positions,
                 const CarryPlan& plan, const VertexFrames<T>& frames, int threads, const std::string& path) {
  if (positions.rows() != rest.vertex_count())
    throw std::invalid_argument("carry_frame: " + std::to_string(positions.rows()) + " positions for " +
                                std::to_string(rest.vertex_count()) + " vertices");
  if (!positions.allFinite()) {  // a file never gets a NaN or infinite coordinate (the readers refuse them too)
    Eigen::Index v = 0;
    while (positions.row(v).allFinite()) ++v;
    throw std::invalid_argument("carry_frame: vertex " + std::to_string(v) + "'s position is not finite");
  }
  if (plan.needs_linear() && !frames.linear)
    throw std::invalid_argument("carry_frame: the mesh's " +
                                std::string(plan.normals ? "normals need" : "splats under an affine fit need") +
                                " each vertex's linear part (FramesOut::linear; in Python linear=, as Mesh.frames_for "
                                "gives)");
  if (plan.needs_quaternions() && (!frames.quaternions || (plan.scales && !frames.scales)))
    throw std::invalid_argument(std::string("carry_frame: the mesh's splats need each vertex's rotation") +
                                (plan.scales ? " and scale" : "") +
                                " (FramesOut::quaternions, scales; in Python quaternions=, scales=, as Mesh.frames_for "
                                "gives)");
  result.vertices = positions;
  if (plan.normals) {
    result.extras = rest.extras;  // each frame's normals from the input's
    transform_normals(result, frames.linear);
  }
  if (plan.splats) {  // each frame's splats from the input's
    if (!result.extras.ply) result.extras = rest.extras;
    if (plan.affine)
      transform_splats_linear(*rest.extras.ply, *result.extras.ply, frames.linear, threads, path);
    else
      transform_splats(*rest.extras.ply, *result.extras.ply, frames.quaternions,
                       plan.scales ? frames.scales : static_cast<const T*>(nullptr), threads, path);
  }
}

#define MLSDEFORM_FILES_CARRY(T)                                                                            \
  template CarryPlan carry_plan(const BasicMesh<T>&, Transform, bool, const std::string&);                  \
  template void carry_frame(const BasicMesh<T>&, BasicMesh<T>&, const PointsRowMajor<T>&, const CarryPlan&, \
                            const VertexFrames<T>&, int, const std::string&);
MLSDEFORM_FILES_CARRY(float)
MLSDEFORM_FILES_CARRY(double)
#undef MLSDEFORM_FILES_CARRY

}  // namespace mlsdeform::files
