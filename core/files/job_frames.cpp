// mlsdeform files: a frame's attributes carried (carry.hpp) and DeformJob's frames (mlsdeform/files.hpp).
#include "core/files/job_impl.hpp"

#include <chrono>
#include <stdexcept>

namespace mlsdeform::files {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

}  // namespace

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

template <class T>
void check_fits_output(const BasicMesh<T>& mesh, const WriteOptions& write, const std::string& path,
                       const std::string& where) {
  // The library refuses a result T cannot hold; here only a double result beyond float, the coordinate type of
  // the mesh written, is left to refuse.
  if (!std::is_same_v<T, double> || output_type(mesh, write) != CoordinateType::float32) return;
  if (mesh.vertices.template cast<float>().allFinite()) return;
  Eigen::Index v = 0;
  while (mesh.vertices.row(v).template cast<float>().allFinite()) ++v;
  throw InputError(path,
                   "vertex " + std::to_string(v) +
                       "'s deformed position overflows float, the output's coordinate type (--output-type "
                       "double writes it)",
                   where);
}

template <class T>
FrameBytes DeformJob<T>::encode_frame(std::size_t f, const std::function<bool()>& cancel) {
  Impl& j = *impl_;
  if (f >= j.outputs.size())
    throw std::out_of_range("DeformJob::encode_frame: frame " + std::to_string(f) + " of " +
                            std::to_string(j.outputs.size()));
  const std::string where = j.summary.animated ? "/frames/" + std::to_string(f) : std::string();
  FrameBytes fb;
  auto t0 = Clock::now();
  FramesOut<T> frames;
  frames.linear = std::span<T>(j.linear);
  frames.quaternions = std::span<T>(j.quaternions);
  frames.scales = std::span<T>(j.scales);
  const CancelCheck check = cancel ? CancelCheck(cancel) : CancelCheck();
  try {
    if (frames.any())
      j.deformer->deform(j.handles.frames[f], j.out, frames, check);
    else
      j.deformer->deform(j.handles.frames[f], j.out, check);
  } catch (const std::invalid_argument& e) {
    throw InputError(j.handles_path, e.what(), where);
  }
  fb.deform_ms = ms_since(t0);

  t0 = Clock::now();
  const VertexFrames<T> vf{j.linear.empty() ? nullptr : j.linear.data(),
                           j.quaternions.empty() ? nullptr : j.quaternions.data(),
                           j.scales.empty() ? nullptr : j.scales.data()};
  carry_frame(j.mesh, j.result, PointsRowMajor<T>(j.out), j.plan, vf, j.options.options.threads, j.mesh_path);
  if (j.plan.splats) fb.attributes_ms = ms_since(t0);
  check_fits_output(j.result, j.write, j.handles_path, where);
  fb.bytes = encode_mesh(j.result, j.outputs[f], j.write);
  fb.encode_ms = ms_since(t0);
  return fb;
}

#define MLSDEFORM_FILES_CARRY(T)                                                                                     \
  template CarryPlan carry_plan(const BasicMesh<T>&, Transform, bool, const std::string&);                           \
  template void carry_frame(const BasicMesh<T>&, BasicMesh<T>&, const PointsRowMajor<T>&, const CarryPlan&,          \
                            const VertexFrames<T>&, int, const std::string&);                                        \
  template void check_fits_output(const BasicMesh<T>&, const WriteOptions&, const std::string&, const std::string&); \
  template FrameBytes DeformJob<T>::encode_frame(std::size_t, const std::function<bool()>&);
MLSDEFORM_FILES_CARRY(float)
MLSDEFORM_FILES_CARRY(double)
#undef MLSDEFORM_FILES_CARRY

}  // namespace mlsdeform::files
