// mlsdeform files: DeformJob's set-up (mlsdeform/files.hpp): the mesh and handles files read and checked, the
// outputs named and checked, what the output keeps of the input's attributes decided, the deformer built.
#include "core/files/file_io.hpp"
#include "core/files/formats/splat_codecs.hpp"
#include "core/files/job_impl.hpp"
#include "core/files/splat_io.hpp"

#include <algorithm>
#include <chrono>

namespace mlsdeform::files {

std::string frame_path(const std::string& out, std::size_t frame, std::size_t frame_count) {
  // Insert "_NNNN" before the format extension (".ply" or ".ply.gz"; ".compressed.ply" is one: splat_io.hpp).
  const std::string ext = format_extension(out);
  std::size_t suffix = ext.empty() ? 0 : ext.size() + 1 + (is_gzip_path(out) ? 3 : 0);
  if (splat_format(out) == SplatFormat::compressed_ply) suffix = std::string(".compressed.ply").size();
  const std::size_t digits = std::max<std::size_t>(4, std::to_string(frame_count > 0 ? frame_count - 1 : 0).size());
  std::string number = std::to_string(frame);
  number.insert(0, digits - std::min(digits, number.size()), '0');
  return out.substr(0, out.size() - suffix) + "_" + number + out.substr(out.size() - suffix);
}

template <class T>
DeformJob<T>::DeformJob(const std::string& mesh_path, const std::string& handles_path, const std::string& out_path,
                        const JobOptions& options)
    : impl_(std::make_unique<Impl>()) {
  Impl& j = *impl_;
  j.mesh_path = mesh_path;
  j.handles_path = handles_path;
  j.options = options;
  check_output_format(out_path);
  j.mesh = read_mesh<T>(mesh_path, options.max_input_bytes);
  const BasicMesh<T>& mesh = j.mesh;
  // A compact splat output needs a splat file: refused here, before any work, not after the first frame.
  if (splat_format(out_path) != SplatFormat::none) check_splat_output(mesh, out_path);
  const bool arap = options.options.arap_iterations > 0;
  if (arap && mesh.face_count() == 0)
    throw InputError(mesh_path, "--arap needs a surface, and the mesh has no faces (a point cloud?)");
  // Normals of faces need faces: a point cloud's would all be zero, written over the input's.
  if (options.normals == NormalsOut::computed && mesh.face_count() == 0)
    throw InputError(mesh_path,
                     "--normals computed needs a surface, and the mesh has no faces (a point cloud?); --normals "
                     "input carries the file's own normals through the deformation");
  // The normals are carried where the output keeps the input's (same format) and does not compute its own.
  const bool same_format = format_extension(mesh_path) == format_extension(out_path);
  const bool carry_normals = options.normals == NormalsOut::input && same_format && mesh.extras.has_normals();
  j.plan = carry_plan(mesh, options.options.transform, carry_normals, mesh_path);
  const HandlesFile file = read_handles(handles_path);

  const std::size_t frame_count = file.animated() ? file.frames.size() : 1;
  for (std::size_t f = 0; f < frame_count; ++f)
    j.outputs.push_back(file.animated() ? frame_path(out_path, f, frame_count) : out_path);
  for (const auto& o : j.outputs) check_output_path(o, options.force);  // before any work: fail fast

  // What the output keeps of the input's attributes, named before any work (strict_attributes refuses then).
  const AttributeReport report =
      attribute_report(mesh, out_path, options.normals, carry_normals ? InputNormals::transformed : InputNormals::kept);
  if (!report.dropped.empty() && options.strict_attributes) {
    std::string list;
    for (const auto& d : report.dropped) list += (list.empty() ? "" : "; ") + d;
    throw InputError(mesh_path, "the output " + out_path + " cannot keep: " + list + " (--strict-attributes)");
  }

  j.handles = resolve_handles<T>(file, mesh.vertices);
  if (arap && !j.handles.region.empty())
    throw InputError(handles_path, "a region and --arap cannot be combined (give one or the other)", "/region");
  Options lib = options.options;
  lib.region = j.handles.region;
  // An affine fit's matrix (FramesOut::linear) takes a table 3 times alpha's: built only when the output needs it.
  lib.affine_frames = lib.transform == Transform::affine && j.plan.needs_linear();
  const Points<T> rest = mesh.vertices;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    // With a region, the faces give its border ring (a point cloud: the nearest vertices, Options::region).
    if (arap || (!lib.region.empty() && mesh.face_count() > 0))
      j.deformer.emplace(rest, fan_triangles(mesh, mesh_path), j.handles.rest, lib);
    else
      j.deformer.emplace(rest, j.handles.rest, lib);
  } catch (const std::invalid_argument& e) {  // e.g. affine handles that do not span 3D
    throw InputError(handles_path, e.what());
  }

  JobSummary& s = j.summary;
  s.setup_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  s.memory_bytes = j.deformer->memory_bytes();
  s.vertices = std::size_t(mesh.vertex_count());
  s.faces = mesh.face_count();
  s.dropped_primitives = mesh.dropped_primitives;
  s.points = file.points.size();
  s.segments = file.segments.size();
  s.frames = frame_count;
  s.animated = file.animated();
  s.region = lib.region.size();
  s.splat_sh_degree = j.plan.splats ? j.plan.splats->sh_degree : -1;
  s.kept = report.kept;
  s.transformed = report.transformed;
  s.dropped = report.dropped;

  j.result = mesh;
  j.write = WriteOptions{options.force, options.ply, options.normals, options.output_type};
  const auto n = std::size_t(mesh.vertex_count());
  j.out.resize(Eigen::Index(n), 3);
  j.linear.resize(j.plan.needs_linear() ? 9 * n : 0);
  j.quaternions.resize(j.plan.needs_quaternions() ? 4 * n : 0);
  j.scales.resize(j.plan.needs_quaternions() && j.plan.scales ? n : 0);
}

template <class T>
DeformJob<T>::DeformJob(DeformJob&&) noexcept = default;
template <class T>
DeformJob<T>& DeformJob<T>::operator=(DeformJob&&) noexcept = default;
template <class T>
DeformJob<T>::~DeformJob() = default;

template <class T>
const std::vector<std::string>& DeformJob<T>::outputs() const {
  return impl_->outputs;
}
template <class T>
const JobSummary& DeformJob<T>::summary() const {
  return impl_->summary;
}

template class DeformJob<float>;
template class DeformJob<double>;

}  // namespace mlsdeform::files
