// `mlsdeform deform`: a mesh file and a handles file in, one deformed mesh (or one per animation frame) out.
#include "tools/cli/commands.hpp"
#include "tools/cli/error.hpp"
#include "tools/cli/file_io.hpp"
#include "tools/cli/handles_file.hpp"
#include "tools/cli/mesh.hpp"
#include "tools/cli/progress.hpp"
#include "tools/cli/splats.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <optional>

namespace mlsdeform::cli {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

const char* name(Transform t) {
  return t == Transform::rigid ? "rigid" : t == Transform::similarity ? "similarity" : "affine";
}

template <class T>
int deform(const DeformArgs& a) {
  const Isa isa = checked_active_isa();
  check_output_format(a.out);
  const BasicMesh<T> mesh = read_mesh<T>(a.mesh, a.max_input_bytes);
  const bool arap = a.options.arap_iterations > 0;
  if (arap && mesh.face_count() == 0)
    throw InputError(a.mesh, "--arap needs a surface, and the mesh has no faces (a point cloud?)");
  // Normals of faces need faces: a point cloud's would all be zero, written over the input's.
  if (a.normals == NormalsOut::computed && mesh.face_count() == 0)
    throw InputError(a.mesh,
                     "--normals computed needs a surface, and the mesh has no faces (a point cloud?); --normals "
                     "input carries the file's own normals through the deformation");
  // A 3D Gaussian splat file (docs/splats.md): each splat turns (and grows) by its centre's frame.
  const std::optional<SplatLayout> splats = mesh.extras.ply ? splat_layout(*mesh.extras.ply, a.mesh) : std::nullopt;
  const HandlesFile handles = read_handles(a.handles);

  const std::size_t frame_count = handles.animated() ? handles.frames.size() : 1;
  std::vector<std::string> outputs;
  for (std::size_t f = 0; f < frame_count; ++f)
    outputs.push_back(handles.animated() ? frame_path(a.out, f, frame_count) : a.out);
  for (const auto& o : outputs) check_output_path(o, a.force);  // before any work: fail fast, write nothing

  // What the output keeps of the input's attributes, named before any work (--strict-attributes refuses then).
  const bool same_format = format_extension(a.mesh) == format_extension(a.out);
  const bool transform_normals_wanted = a.normals == NormalsOut::input && same_format && mesh.extras.has_normals();
  const InputNormals fate = transform_normals_wanted ? InputNormals::transformed : InputNormals::kept;
  const AttributeReport report = attribute_report(mesh, a.out, a.normals, fate);
  if (!report.dropped.empty()) {
    std::string list;
    for (const auto& d : report.dropped) list += (list.empty() ? "" : "; ") + d;
    if (a.strict_attributes)
      throw InputError(a.mesh, "the output " + a.out + " cannot keep: " + list + " (--strict-attributes)");
    std::fprintf(stderr, "mlsdeform: dropped from %s: %s\n", a.mesh.c_str(), list.c_str());
  }

  const ResolvedHandles<T> resolved = resolve_handles<T>(handles, mesh.vertices);
  if (arap && !resolved.region.empty())
    throw InputError(a.handles, "a region and --arap cannot be combined (give one or the other)", "/region");
  Options options = a.options;
  options.region = resolved.region;
  // An affine fit's matrix (FramesOut::linear) takes a table 3 times alpha's: built only when the output needs it,
  // for the input's normals or a splat file's covariances.
  options.affine_frames =
      options.transform == Transform::affine && (fate == InputNormals::transformed || splats.has_value());
  const Points<T> rest = mesh.vertices;
  auto t0 = Clock::now();
  std::optional<Deformer<T>> deformer;
  try {
    // With a region, the faces give its border ring (a point cloud: the nearest vertices, Options::region).
    if (arap || (!options.region.empty() && mesh.face_count() > 0))
      deformer.emplace(rest, fan_triangles(mesh, a.mesh), resolved.rest, options);
    else
      deformer.emplace(rest, resolved.rest, options);
  } catch (const std::invalid_argument& e) {  // e.g. affine handles that do not span 3D
    throw InputError(a.handles, e.what());
  }
  const double setup_ms = ms_since(t0);

  if (!a.quiet) {
    std::printf(
        "%s: %lld vertices, %zu faces%s\n", a.mesh.c_str(), static_cast<long long>(mesh.vertex_count()),
        mesh.face_count(),
        // Points and lines are not deformed: kept in OBJ output, named as dropped in another format.
        mesh.dropped_primitives ? (", " + std::to_string(mesh.dropped_primitives) + " points/lines").c_str() : "");
    std::printf("%s: %zu point and %zu segment handles%s%s\n", a.handles.c_str(), handles.points.size(),
                handles.segments.size(),
                handles.animated() ? (", " + std::to_string(frame_count) + " frames").c_str() : "",
                options.region.empty()
                    ? ""
                    : (", a region of " + std::to_string(options.region.size()) + " vertices (the " +
                       std::to_string(mesh.vertex_count() - Eigen::Index(options.region.size())) + " others stay)")
                          .c_str());
    auto listed = [](const std::vector<std::string>& items) {
      std::string s;
      for (const auto& i : items) s += (s.empty() ? "" : "; ") + i;
      return s;
    };
    if (!report.kept.empty() || !report.transformed.empty())
      std::printf("attributes: %s%s%s%s\n", report.kept.empty() ? "" : "kept ", listed(report.kept).c_str(),
                  report.kept.empty() || report.transformed.empty() ? "" : "; ",
                  report.transformed.empty() ? "" : ("transformed " + listed(report.transformed)).c_str());
    char threads[32];
    std::snprintf(threads, sizeof threads, a.options.threads > 0 ? "%d threads" : "all cores", a.options.threads);
    const std::string then_arap =
        arap ? ", then " + std::to_string(a.options.arap_iterations) + " ARAP iterations" : "";
    std::printf("deformer: %s, u = %g, %s, %s, %s backend, %s%s; set-up %.2f ms, %.1f MiB\n", name(a.options.transform),
                a.options.weight_exponent, std::string(to_string(a.options.method)).c_str(),
                std::is_same_v<T, float> ? "float" : "double",
                !a.options.isa ? ("simd (" + std::string(to_string(isa)) + ")").c_str() : "scalar", threads,
                then_arap.c_str(), setup_ms, double(deformer->memory_bytes()) / (1 << 20));
    if (splats)
      std::printf("splats: %lld Gaussian splats, SH degree %d: rot_*%s and f_rest_* turned by each centre's frame\n",
                  static_cast<long long>(mesh.vertex_count()), splats->sh_degree,
                  a.options.transform == Transform::rigid ? "" : ", scale_*");
    std::fflush(stdout);  // seen before a long first frame, also through a pipe
  }

  BasicMesh<T> result = mesh;
  const WriteOptions write{a.force, a.ply_ascii ? PlyEncoding::ascii : PlyEncoding::binary, a.normals, a.output_type};
  const bool narrowed = std::is_same_v<T, double> && output_type(mesh, write) == CoordinateType::float32;
  Points<T> out(rest.rows(), 3);
  // Each vertex's linear part (R, s R, the affine fit's matrix, or ARAP's refined rotation), to carry the input's
  // normals through.
  // A splat file's: each centre's rotation, and its scale for similarity fits; for affine fits the linear part.
  const bool affine_splats = splats && a.options.transform == Transform::affine;
  std::vector<T> linear(fate == InputNormals::transformed || affine_splats ? std::size_t(rest.rows()) * 9 : 0);
  FramesOut<T> frames;
  frames.linear = std::span<T>(linear);
  const bool grows = a.options.transform == Transform::similarity;
  std::vector<T> splat_turns(splats && !affine_splats ? 4 * std::size_t(rest.rows()) : 0),
      splat_scales(splats && grows ? std::size_t(rest.rows()) : 0);
  frames.quaternions = std::span<T>(splat_turns);
  frames.scales = std::span<T>(splat_scales);
  double splat_ms = 0;
  std::vector<double> deform_ms;
  std::vector<std::string> written;
  Progress progress(frame_count, a.quiet || !handles.animated());
  defer_interrupts(true);
  try {
    for (std::size_t f = 0; f < frame_count; ++f) {
      if (const int sig = pending_interrupt()) throw Interrupted{sig, written.size()};
      const std::string where = handles.animated() ? "/frames/" + std::to_string(f) : std::string();
      t0 = Clock::now();
      try {
        // The first SIGINT stops a long ARAP frame between iterations, not after the last one.
        const auto cancel = [] { return pending_interrupt() != 0; };
        if (frames.any())
          deformer->deform(resolved.frames[f], out, frames, cancel);
        else
          deformer->deform(resolved.frames[f], out, cancel);
      } catch (const std::invalid_argument& e) {
        throw InputError(a.handles, e.what(), where);
      } catch (const Cancelled&) {
        throw Interrupted{pending_interrupt(), written.size()};
      }
      deform_ms.push_back(ms_since(t0));
      result.vertices = out;
      if (fate == InputNormals::transformed) {
        result.extras = mesh.extras;  // each frame's normals from the input's
        transform_normals(result, linear.data());
      }
      if (splats) {  // each frame's splats from the input's
        t0 = Clock::now();
        if (affine_splats)
          transform_splats_linear(*mesh.extras.ply, *result.extras.ply, linear.data(), a.options.threads, a.mesh);
        else
          transform_splats(*mesh.extras.ply, *result.extras.ply, splat_turns.data(),
                           grows ? splat_scales.data() : static_cast<const T*>(nullptr), a.options.threads, a.mesh);
        splat_ms += ms_since(t0);
      }
      // The library refuses a result T cannot hold; here only a double result beyond float, the coordinate
      // type of the mesh written, is left to refuse.
      if (narrowed && !result.vertices.template cast<float>().allFinite()) {
        Eigen::Index v = 0;
        while (result.vertices.row(v).template cast<float>().allFinite()) ++v;
        throw InputError(a.handles,
                         "vertex " + std::to_string(v) +
                             "'s deformed position overflows float, the output's coordinate type (--output-type "
                             "double writes it)",
                         where);
      }
      t0 = Clock::now();
      write_mesh(result, outputs[f], write);
      written.push_back(outputs[f]);
      progress.frame(f, deform_ms.back(), ms_since(t0), outputs[f]);
    }
    if (const int sig = pending_interrupt()) throw Interrupted{sig, written.size()};
    defer_interrupts(false);
  } catch (...) {
    // All or nothing for an animation too: remove the frames this run already wrote.
    progress.abort();
    for (const auto& w : written) std::filesystem::remove(w);
    throw;
  }

  if (!a.quiet) {
    double total = 0;
    for (double d : deform_ms) total += d;
    const auto [lo, hi] = std::minmax_element(deform_ms.begin(), deform_ms.end());
    if (splats) std::printf("splats turned in %.3f ms (all frames)\n", splat_ms);
    if (frame_count == 1)
      std::printf("deformed in %.3f ms -> %s\n", total, a.out.c_str());
    else
      std::printf("%zu frames deformed in %.1f ms: %.3f ms per frame (min %.3f, max %.3f), %.1f frames/s -> %s .. %s\n",
                  frame_count, total, total / double(frame_count), *lo, *hi, 1000.0 * double(frame_count) / total,
                  outputs.front().c_str(), outputs.back().c_str());
  }
  return 0;
}

}  // namespace

std::string frame_path(const std::string& out, std::size_t frame, std::size_t frame_count) {
  // Insert "_NNNN" before the format extension (".ply" or ".ply.gz").
  const std::string ext = format_extension(out);
  const std::size_t suffix = ext.empty() ? 0 : ext.size() + 1 + (is_gzip_path(out) ? 3 : 0);
  const std::size_t digits = std::max<std::size_t>(4, std::to_string(frame_count > 0 ? frame_count - 1 : 0).size());
  std::string number = std::to_string(frame);
  number.insert(0, digits - std::min(digits, number.size()), '0');
  return out.substr(0, out.size() - suffix) + "_" + number + out.substr(out.size() - suffix);
}

Isa checked_active_isa() {
  try {
    return active_isa();
  } catch (const std::invalid_argument& e) {  // MLSDEFORM_ISA names an unknown or unsupported instruction set
    throw InputError("MLSDEFORM_ISA", e.what());
  }
}

int run_deform(const DeformArgs& args) {
  return args.precision == Precision::single ? deform<float>(args) : deform<double>(args);
}

}  // namespace mlsdeform::cli
