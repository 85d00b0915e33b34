// mlsdeform files: DeformJob's frames (mlsdeform/files.hpp): deformed, their attributes carried (carry.cpp), encoded.
#include "core/files/job_impl.hpp"

#include <chrono>
#include <stdexcept>

namespace mlsdeform::files {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

}  // namespace

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
  template void check_fits_output(const BasicMesh<T>&, const WriteOptions&, const std::string&, const std::string&); \
  template FrameBytes DeformJob<T>::encode_frame(std::size_t, const std::function<bool()>&);
MLSDEFORM_FILES_CARRY(float)
MLSDEFORM_FILES_CARRY(double)
#undef MLSDEFORM_FILES_CARRY

}  // namespace mlsdeform::files
